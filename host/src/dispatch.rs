//! The engine pass, compiled twice on x86-64: for the baseline (SSE2) and
//! for AVX2 (with BMI1/2, LZCNT, FMA), chosen at run time by CPU feature
//! detection (`multiversion`). The core's pass is `#[inline(always)]` down
//! to its row kernels, so the AVX2 copy is the whole pass. The core
//! computes only with integers, so both copies give the same bytes
//! (tested in `tests/tests/simd.rs`).

use multiversion::multiversion;
use reynoldsflow_core::{Engine, Error, FramePair, Plan, Scaling, Sink};

/// Which compilation of the engine pass runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Isa {
    /// The widest instructions this CPU has (AVX2 where present).
    #[default]
    Best,
    /// The baseline of the target (SSE2 on x86-64), whatever the CPU.
    Portable,
}

impl Isa {
    /// What [`Isa::Best`] runs on this CPU, for reports.
    pub fn best_name() -> &'static str {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            return "avx2";
        }
        "portable"
    }
}

/// What one engine call does.
pub enum Pass<'a> {
    /// Every tile of the plan.
    All,
    /// Tile `index` of the plan.
    Tile(usize),
    /// The core's `represent` into this RGB frame, in this scaling.
    Represent(Scaling, &'a mut [u8]),
}

/// Run `pass` of `engine` over `frames` into `sink`, compiled for `isa`.
pub fn run<const COLS: usize, S: Sink>(
    isa: Isa,
    engine: &mut Engine<COLS>,
    plan: &Plan<COLS>,
    frames: &FramePair<'_>,
    pass: Pass<'_>,
    sink: &mut S,
) -> Result<(), Error> {
    match isa {
        Isa::Best => run_best(engine, plan, frames, pass, sink),
        Isa::Portable => run_portable(engine, plan, frames, pass, sink),
    }
}

#[multiversion(targets("x86_64+avx2+bmi1+bmi2+lzcnt+popcnt+fma"))]
fn run_best<const COLS: usize, S: Sink>(
    engine: &mut Engine<COLS>,
    plan: &Plan<COLS>,
    frames: &FramePair<'_>,
    pass: Pass<'_>,
    sink: &mut S,
) -> Result<(), Error> {
    run_portable(engine, plan, frames, pass, sink)
}

#[inline(always)]
fn run_portable<const COLS: usize, S: Sink>(
    engine: &mut Engine<COLS>,
    plan: &Plan<COLS>,
    frames: &FramePair<'_>,
    pass: Pass<'_>,
    sink: &mut S,
) -> Result<(), Error> {
    match pass {
        Pass::All => engine.run(plan, frames, sink),
        Pass::Tile(index) => engine.run_tile(plan, frames, index, sink),
        Pass::Represent(scaling, rgb) => {
            reynoldsflow_core::represent(engine, plan, frames, scaling, rgb, sink)
        }
    }
}

//! The engine pass, compiled twice on x86-64: for the baseline (SSE2) and
//! for AVX2 (with BMI1/2, LZCNT, FMA), chosen at run time by CPU feature
//! detection (`multiversion`). The core's pass is `#[inline(always)]` down
//! to its row kernels, so the AVX2 copy is the whole pass. The core
//! computes only with integers, so both copies give the same bytes
//! (tested in `tests/tests/simd.rs`). Per-frame min–max's byte step, which
//! runs after the pass, is compiled the same two ways (tested in
//! `fixed_engine`'s RGB-path test).

use multiversion::multiversion;
use multiversion::target::target_cfg_f;
use reynoldsflow_core::{ByteScale, Error, FramePair, Memory, Plan, Scaling, Sink, TileEngine};

use crate::fixed_engine::{Kept, bytes_from_kept};

/// Which compilation of the engine pass runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Isa {
    /// The widest instructions this CPU has (AVX2 where present).
    #[default]
    Best,
    /// The baseline of the target (SSE2 on x86-64), whatever the CPU.
    Portable,
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

impl Pass<'_> {
    #[inline(always)]
    fn run<M: Memory, S: Sink>(
        self,
        engine: &mut TileEngine<M>,
        plan: &Plan,
        frames: &FramePair<'_>,
        sink: &mut S,
    ) -> Result<(), Error> {
        let job = plan.bind(*frames)?;
        match self {
            Pass::All => {
                engine.run(&job, sink);
                Ok(())
            }
            Pass::Tile(index) => {
                let tile = engine.run_tile(&job, index, sink);
                tile.map(|_| ()).ok_or(Error::TileOutOfFrame)
            }
            Pass::Represent(scaling, rgb) => {
                reynoldsflow_core::represent(engine, &job, scaling, rgb, sink)
            }
        }
    }
}

/// Run `pass` of `engine` over `frames` into `sink`, compiled for `isa`.
pub fn run<M: Memory, S: Sink>(
    isa: Isa,
    engine: &mut TileEngine<M>,
    plan: &Plan,
    frames: &FramePair<'_>,
    pass: Pass<'_>,
    sink: &mut S,
) -> Result<(), Error> {
    match isa {
        Isa::Best => run_best(engine, plan, frames, pass, sink),
        Isa::Portable => pass.run(engine, plan, frames, sink),
    }
}

/// The second step of per-frame min–max (`fixed_engine::bytes_from_kept`),
/// compiled for `isa` like the pass: its 64-bit multiplies and compares
/// take AVX2's lanes.
pub(crate) fn kept_to_bytes(
    isa: Isa,
    kept: &Kept,
    luma: &[u8],
    rgb: &mut [u8],
    scales: &[ByteScale; 2],
) {
    match isa {
        Isa::Best => kept_to_bytes_best(kept, luma, rgb, scales),
        Isa::Portable => bytes_from_kept(kept, luma, rgb, scales),
    }
}

/// The targets of [`Isa::Best`], written once for every function cloned for them.
macro_rules! best_targets {
    ($($function:item)*) => {
        $(#[multiversion(targets("x86_64+avx2+bmi1+bmi2+lzcnt+popcnt+fma"))] $function)*
    };
}

best_targets! {
    fn run_best<M: Memory, S: Sink>(
        engine: &mut TileEngine<M>,
        plan: &Plan,
        frames: &FramePair<'_>,
        pass: Pass<'_>,
        sink: &mut S,
    ) -> Result<(), Error> {
        pass.run(engine, plan, frames, sink)
    }

    fn kept_to_bytes_best(
        kept: &Kept,
        luma: &[u8],
        rgb: &mut [u8],
        scales: &[ByteScale; 2],
    ) {
        bytes_from_kept(kept, luma, rgb, scales)
    }

    /// What [`Isa::Best`] runs on this CPU, for reports: the clone that
    /// dispatch selects names itself.
    pub fn best_name() -> &'static str {
        if target_cfg_f!(target_feature = "avx2") {
            "avx2"
        } else {
            "portable"
        }
    }
}

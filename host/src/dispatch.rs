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

/// Run `pass` of `engine` over `frames` into `sink`, compiled for `isa`.
///
/// Each kind of pass is a function of its own, for either compilation: a
/// function holding all three compiles one stack frame for all of them,
/// and when the `represent` path grew (its bytes in lanes), `run` with
/// per-frame min–max (the `All` path) ran 1.15× slower side by side for
/// the same instruction count (`farm-bench`; `perf` put the time on the
/// tail's batch copies in that frame). Each binds its job itself: a job
/// passed in by reference kept the tail from vector lanes (its parameters
/// reloaded from memory the output rows might alias: 2× the instructions).
pub fn run<M: Memory, S: Sink>(
    isa: Isa,
    engine: &mut TileEngine<M>,
    plan: &Plan,
    frames: &FramePair<'_>,
    pass: Pass<'_>,
    sink: &mut S,
) -> Result<(), Error> {
    let best = isa == Isa::Best;
    match pass {
        Pass::All if best => all_best(engine, plan, frames, sink),
        Pass::All => baseline(|| all(engine, plan, frames, sink)),
        Pass::Tile(index) if best => tile_best(engine, plan, frames, index, sink),
        Pass::Tile(index) => baseline(|| tile(engine, plan, frames, index, sink)),
        Pass::Represent(scaling, rgb) if best => {
            represent_best(engine, plan, frames, (scaling, rgb), sink)
        }
        Pass::Represent(scaling, rgb) => {
            baseline(|| represent(engine, plan, frames, (scaling, rgb), sink))
        }
    }
}

/// A pass compiled for the baseline, out of line: a function of its own
/// for each kind of pass (each closure is a type of its own). The best
/// targets' clones below cannot take a closure the same way (it stayed a
/// baseline call: `run` ran 3× the instructions), so each repeats its
/// pass's signature.
#[inline(never)]
fn baseline<R>(pass: impl FnOnce() -> R) -> R {
    pass()
}

/// Every tile of the plan (inlined into [`baseline`] and [`all_best`]).
#[inline(always)]
fn all<M: Memory, S: Sink>(
    engine: &mut TileEngine<M>,
    plan: &Plan,
    frames: &FramePair<'_>,
    sink: &mut S,
) -> Result<(), Error> {
    engine.run(&plan.bind(*frames)?, sink);
    Ok(())
}

/// Tile `index` of the plan ([`baseline`], [`tile_best`]).
#[inline(always)]
fn tile<M: Memory, S: Sink>(
    engine: &mut TileEngine<M>,
    plan: &Plan,
    frames: &FramePair<'_>,
    index: usize,
    sink: &mut S,
) -> Result<(), Error> {
    let tile = engine.run_tile(&plan.bind(*frames)?, index, sink);
    tile.map(|_| ()).ok_or(Error::TileOutOfFrame)
}

/// The core's `represent` in this scaling into this RGB frame
/// ([`baseline`], [`represent_best`]).
#[inline(always)]
fn represent<M: Memory, S: Sink>(
    engine: &mut TileEngine<M>,
    plan: &Plan,
    frames: &FramePair<'_>,
    (scaling, rgb): (Scaling, &mut [u8]),
    sink: &mut S,
) -> Result<(), Error> {
    reynoldsflow_core::represent(engine, &plan.bind(*frames)?, scaling, rgb, sink)
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
    fn all_best<M: Memory, S: Sink>(
        engine: &mut TileEngine<M>,
        plan: &Plan,
        frames: &FramePair<'_>,
        sink: &mut S,
    ) -> Result<(), Error> {
        all(engine, plan, frames, sink)
    }

    fn tile_best<M: Memory, S: Sink>(
        engine: &mut TileEngine<M>,
        plan: &Plan,
        frames: &FramePair<'_>,
        index: usize,
        sink: &mut S,
    ) -> Result<(), Error> {
        tile(engine, plan, frames, index, sink)
    }

    fn represent_best<M: Memory, S: Sink>(
        engine: &mut TileEngine<M>,
        plan: &Plan,
        frames: &FramePair<'_>,
        pass: (Scaling, &mut [u8]),
        sink: &mut S,
    ) -> Result<(), Error> {
        represent(engine, plan, frames, pass, sink)
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

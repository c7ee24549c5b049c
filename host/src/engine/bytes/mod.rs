//! The engine pass, compiled twice on x86-64: for the baseline (SSE2) and
//! for AVX2 (with BMI1/2, LZCNT, FMA), chosen at run time by CPU feature
//! detection (`multiversion`). The core's pass is `#[inline(always)]` down
//! to its row kernels, so the AVX2 copy is the whole pass. The core
//! computes only with integers, so both copies give the same bytes
//! (tested in `tests/tests/simd.rs`). Per-frame min–max's byte step, which
//! runs after the pass, is compiled the same two ways, and where the CPU has
//! AVX2 takes its lanes through intrinsics (`bytes/avx2.rs`; tested in
//! `engine::lane`). On aarch64 the pass has one compilation (NEON is in
//! every aarch64 target, and the core's NEON kernels are fixed at compile
//! time), and [`Isa::Best`]'s byte step takes NEON lanes (`bytes/neon.rs`).

use multiversion::multiversion;
use multiversion::target::match_target;
use reynoldsflow_core::{
    ByteScale, Error, FramePair, Job, Memory, Plan, Scaling, Sink, TileEngine,
};

use portable::bytes_from_kept;

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
mod neon;
mod portable;

/// Which compilation of the engine pass runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Isa {
    /// The widest instructions this CPU has (AVX2 where present; NEON on
    /// aarch64).
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
/// Each kind of pass is a type of its own (`Kind`), so each compiles as a
/// function of its own, in either compilation: a function holding all
/// three compiles one stack frame for all of them, and when the
/// `represent` path grew (its bytes in lanes), `run` with per-frame
/// min–max (the `All` path) ran 1.15× slower side by side for the same
/// instruction count (`farm-bench`; `perf` put the time on the tail's
/// batch copies in that frame).
pub fn run<M: Memory, S: Sink>(
    isa: Isa,
    engine: &mut TileEngine<M>,
    plan: &Plan,
    frames: &FramePair<'_>,
    pass: Pass<'_>,
    sink: &mut S,
) -> Result<(), Error> {
    match pass {
        Pass::All => compiled(isa, All, engine, plan, frames, sink),
        Pass::Tile(index) => compiled(isa, TileAt(index), engine, plan, frames, sink),
        Pass::Represent(scaling, rgb) => {
            let kind = RepresentInto(scaling, rgb);
            compiled(isa, kind, engine, plan, frames, sink)
        }
    }
}

/// One kind of pass over a bound job.
trait Kind {
    fn pass<M: Memory, S: Sink>(
        self,
        engine: &mut TileEngine<M>,
        job: &Job<'_>,
        sink: &mut S,
    ) -> Result<(), Error>;
}

/// Every tile of the plan.
struct All;

/// Tile `index` of the plan.
struct TileAt(usize);

/// The core's `represent` in this scaling into this RGB frame.
struct RepresentInto<'a>(Scaling, &'a mut [u8]);

impl Kind for All {
    #[inline(always)]
    fn pass<M: Memory, S: Sink>(
        self,
        engine: &mut TileEngine<M>,
        job: &Job<'_>,
        sink: &mut S,
    ) -> Result<(), Error> {
        engine.run(job, sink);
        Ok(())
    }
}

impl Kind for TileAt {
    #[inline(always)]
    fn pass<M: Memory, S: Sink>(
        self,
        engine: &mut TileEngine<M>,
        job: &Job<'_>,
        sink: &mut S,
    ) -> Result<(), Error> {
        let tile = engine.run_tile(job, self.0, sink);
        tile.map(|_| ()).ok_or(Error::TileOutOfFrame)
    }
}

impl Kind for RepresentInto<'_> {
    #[inline(always)]
    fn pass<M: Memory, S: Sink>(
        self,
        engine: &mut TileEngine<M>,
        job: &Job<'_>,
        sink: &mut S,
    ) -> Result<(), Error> {
        reynoldsflow_core::represent(engine, job, self.0, self.1, sink)
    }
}

/// `kind` compiled for `isa`.
#[inline(always)]
fn compiled<K: Kind, M: Memory, S: Sink>(
    isa: Isa,
    kind: K,
    engine: &mut TileEngine<M>,
    plan: &Plan,
    frames: &FramePair<'_>,
    sink: &mut S,
) -> Result<(), Error> {
    match isa {
        Isa::Best => best(kind, engine, plan, frames, sink),
        Isa::Portable => baseline(kind, engine, plan, frames, sink),
    }
}

/// `kind` compiled for the baseline, out of line; [`best`] inlines it into
/// its clones. The job is bound here, not passed in: a job behind a
/// reference kept the tail out of vector lanes (its parameters reloaded
/// from memory the output rows might alias: 2× the instructions).
#[inline(never)]
fn baseline<K: Kind, M: Memory, S: Sink>(
    kind: K,
    engine: &mut TileEngine<M>,
    plan: &Plan,
    frames: &FramePair<'_>,
    sink: &mut S,
) -> Result<(), Error> {
    kind.pass(engine, &plan.bind(*frames)?, sink)
}

/// The second step of per-frame min–max (`portable::bytes_from_kept`),
/// compiled for `isa` like the pass: its 64-bit multiplies and compares
/// take AVX2's lanes; on aarch64 [`Isa::Best`] takes NEON's.
pub fn kept_to_bytes(
    isa: Isa,
    kept: [&[f32]; 2],
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
    /// `kind` compiled for the best targets (a clone of [`baseline`]'s body:
    /// each clone must hold the code it runs).
    fn best<K: Kind, M: Memory, S: Sink>(
        kind: K,
        engine: &mut TileEngine<M>,
        plan: &Plan,
        frames: &FramePair<'_>,
        sink: &mut S,
    ) -> Result<(), Error> {
        let job = plan.bind(*frames)?;
        // Compiled for AVX2 and FMA, this clone can make the core's token
        // for its AVX2 kernels (`Avx2::new` needs those features).
        match_target! {
            "x86_64+avx2+fma" => kind.pass(engine, &job.with_avx2(reynoldsflow_core::Avx2::new()), sink),
            _ => kind.pass(engine, &job, sink),
        }
    }

    /// Where the CPU has AVX2, the step in its lanes (`avx2.rs`); on
    /// aarch64 in NEON's (`neon.rs`); elsewhere the portable step compiled
    /// for the clone's target.
    fn kept_to_bytes_best(
        kept: [&[f32]; 2],
        luma: &[u8],
        rgb: &mut [u8],
        scales: &[ByteScale; 2],
    ) {
        match_target! {
            "x86_64+avx2" => crate::engine::bytes::avx2::kept_to_bytes(kept, luma, rgb, scales),
            "aarch64+neon" => crate::engine::bytes::neon::kept_to_bytes(kept, luma, rgb, scales),
            _ => bytes_from_kept(kept, luma, rgb, scales),
        }
    }

    /// What [`Isa::Best`] runs on this CPU, for reports: the clone that
    /// dispatch selects names itself.
    pub fn best_name() -> &'static str {
        match_target! {
            "x86_64+avx2" => "avx2",
            "aarch64+neon" => "neon",
            _ => "portable",
        }
    }
}

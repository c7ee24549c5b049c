//! ReynoldsFlow (Chen, Lin, Huang, Wu) in `no_std`, no-alloc, fixed-point
//! Rust: from two consecutive 8-bit gray frames, the curl-free field `v_c`,
//! the divergence-free field `v_d`, their magnitudes, and the RGB8
//! representation `[|v_d|, |v_c|, fⁿ]`, as the project's SPEC defines them.
//!
//! ```
//! use reynoldsflow_core::{Config, FramePair, Params, Plan, Scaling, represent};
//! # fn main() -> Result<(), reynoldsflow_core::Error> {
//! let (w, h) = (32, 24);
//! let prev: Vec<u8> = (0..w * h).map(|i| (i * 7 % 251) as u8).collect();
//! let next: Vec<u8> = (0..w * h).map(|i| ((i + 1) * 7 % 251) as u8).collect();
//!
//! // Validate once: sizes and parameters, the tiling, the frames.
//! let config = Config::new(w, h, Params::DEFAULT)?;
//! type Engine = reynoldsflow_core::Engine<78>; // windows of 78 columns, 19 688 bytes
//! let plan = Plan::strips(config, Engine::MAX_TILE_WIDTH)?; // tiles as wide as it takes
//! let job = plan.bind(FramePair::packed(&config, &prev, &next)?)?;
//!
//! // Then compute: all working memory is the engine, and running cannot fail.
//! let mut engine = Engine::new();
//! let mut rgb = vec![0u8; w * h * 3];
//! represent(&mut engine, &job, Scaling::PerFrameMinMax, &mut rgb, ())?;
//! # Ok(()) }
//! ```
//!
//! # How it computes
//!
//! The computation is deterministic: every target gives the same bytes.
//! The stencils up to the residual and the structure sums `a, b, c` are
//! exact integers; the sums `p, q`, the 2×2 solve and the magnitudes are
//! IEEE binary32 (`f32`) operations in one fixed order, each correctly
//! rounded, so hardware floats (x86-64, aarch64, the M4F) and software
//! floats (M0, RV32) agree bit for bit. All working memory lives in one
//! engine: an [`Engine`] whose
//! size is a const generic (`COLS` window columns, about 252 bytes each), or
//! a [`SliceEngine`] in slices the caller sizes at run time ([`MemorySize`]).
//! Frames are cut into tiles ([`Plan`]); a tile wider than the engine's
//! `COLS − 14` columns runs as several windows, and every tiling gives the
//! same bytes. Each row loop has one portable form; a target's faster
//! forms (the M4F's assembly, x86-64's AVX2 lanes) are sets of overrides
//! of it that give the same values, chosen once per target or per job.
//! Sizes and parameters are checked once ([`Config`], [`Plan`],
//! [`FramePair`], [`Job`], the sinks); after that nothing fails or panics.
//! Other output goes through a [`Sink`], which sees each output row as
//! [`Pixels`], a row per quantity (or [`FlowPixel`]s one at a time): the
//! ready-made ones write field planes ([`FieldSink`]),
//! the bytes ([`RgbSink`]) or the extremes ([`ExtremesSink`]).
//!
//! # Stability
//!
//! The stable surface is what the example uses and what a firmware or
//! binding needs beside it: [`Engine`] and [`SliceEngine`] (with
//! [`MemorySize`]), [`Plan`], [`Job`], [`FramePair`],
//! [`Config`] and [`Params`], [`Sink`], [`Pixels`] and [`FlowPixel`], [`Error`] (the one
//! error type), and the scaling ([`Scaling`], [`ByteScale`], [`represent`]).
//! Changes to them follow semantic versioning; the bytes they produce change
//! only with a SPEC change, recorded in the repository's golden files.
#![no_std]
// `unsafe` is allowed only where it lives, all in `kernels/`, each block
// with its safety argument: in `fpu.rs`, the `f32` square root on x86-64
// (SSE) and aarch64 (NEON) through intrinsics, which vectorise where
// `libm`'s inline assembly does not, and on the M4F (`VSQRT.F32` in
// `asm!`; `core` has no `f32` root on stable, `libm`'s is software there),
// and the byte conversion of a clamped value, whose checked form kept the
// x86-64 byte loops scalar (193 instructions for 32 bytes against 57); in
// `m4.rs`, the M4F's and M7's hottest row loops in `asm!` (with
// `wide_products`, 443 → 306 instructions a pixel at 320×240), held equal
// to their portable twins by `kernel_check` on the emulated boards; in
// `avx2.rs`, the structure sums and the tail of x86-64 hosts that find
// AVX2 at run time in intrinsics (the `#[target_feature]` calls, which its
// token makes sound, and loads and stores of eight lanes within rows
// checked once a row), held equal to the portable pass by
// `tests/tests/simd.rs`; in `neon.rs`, the same on aarch64 in NEON lanes
// (loads and stores of four lanes within rows checked once a row), held
// equal to the portable sums and tail by `kernel_check` under
// `qemu-aarch64`.
#![deny(unsafe_code)]
#![deny(missing_docs)]

#[cfg(test)]
extern crate std;

mod engine;
mod error;
mod frames;
mod job;
mod kernels;
mod params;
mod pixels;
mod plan;
mod represent;
mod ring;
mod scale;
mod schedule;
mod sink;
mod stages;
mod stream;
mod tail;

/// Whether the compiler takes the row loops in vector lanes (`build.rs`):
/// there, forms that keep a loop branch-free with independent taps win; on
/// the scalar boards fewer loads, fewer 64-bit steps and fewer live
/// registers do (`stages`, `scale`).
const VECTOR_ROWS: bool = cfg!(vector_rows);

pub use engine::{
    Arrays, Engine, Memory, MemorySize, Sink, SliceEngine, Slices, TileEngine, working_bytes,
};
pub use error::Error;
pub use fixed;
pub use frames::{Frame, FramePair};
pub use job::Job;
#[cfg(target_arch = "x86_64")]
pub use kernels::avx2::Avx2;
#[cfg(feature = "kernel-check")]
#[doc(hidden)]
pub use kernels::kernel_check;
pub use params::{Config, IntensityScale, MAX_SIDE, Params};
pub use pixels::{Fields, FlowPixel, Pixels};
pub use plan::{Plan, Tile, first_stage_pixels};
pub use represent::{byte_scales, represent};
pub use scale::{ByteScale, Extremes, PreviousFrameMinMax, Scaling};
pub use schedule::HALO;
pub use sink::{ExtremesSink, FieldPlanes, FieldSink, RGB_BATCH, RgbSink, rgb, rgb_batch, rgb_row};
pub use stream::{EngineHandle, RowStream};

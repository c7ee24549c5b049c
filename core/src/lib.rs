//! ReynoldsFlow (Chen, Lin, Huang, Wu) in `no_std`, no-alloc, fixed-point
//! Rust: from two consecutive 8-bit gray frames, the curl-free field `v_c`,
//! the divergence-free field `v_d`, their magnitudes, and the RGB8
//! representation `[|v_d|, |v_c|, fⁿ]`, exactly as the project's SPEC
//! defines them.
//!
//! The computation is integer-only and deterministic: every target gives the
//! same bytes. All working memory lives in one [`Engine`] whose size is a
//! const generic (`COLS` window columns, about 316 bytes each), and frames
//! are cut into tiles of at most `COLS − 14` columns; every tiling gives the
//! same bytes. Sizes and parameters are checked once ([`Config`], [`Plan`],
//! [`FramePair`], the sinks); after that nothing fails or panics.
//!
//! ```
//! use reynoldsflow_core::{Config, Engine, FramePair, Params, Plan, Scaling, represent};
//! # fn main() -> Result<(), reynoldsflow_core::Error> {
//! let (w, h) = (32, 24);
//! let prev: Vec<u8> = (0..w * h).map(|i| (i * 7 % 251) as u8).collect();
//! let next: Vec<u8> = (0..w * h).map(|i| ((i + 1) * 7 % 251) as u8).collect();
//!
//! let config = Config::new(w, h, Params::DEFAULT)?;
//! let mut engine = Engine::<78>::new(); // tiles up to 64 columns wide
//! let plan = Plan::strips(config)?;
//! let frames = FramePair::packed(&config, &prev, &next)?;
//! let mut rgb = vec![0u8; w * h * 3];
//! represent(&mut engine, &plan, &frames, Scaling::PerFrameMinMax, &mut rgb, ())?;
//! # Ok(()) }
//! ```
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]

#[cfg(test)]
extern crate std;

mod engine;
mod error;
mod frames;
mod isqrt;
mod params;
mod plan;
mod reciprocal;
mod represent;
mod ring;
mod scale;
mod sink;
mod solve;
mod stages;
mod stream;

pub use engine::{Engine, FlowPixel, HALO, Sink, working_bytes};
pub use error::Error;
pub use fixed;
pub use frames::{Frame, FramePair};
pub use params::{Config, IntensityScale, MAX_SIDE, Params};
pub use plan::{Plan, Tile, first_stage_pixels};
pub use represent::{byte_scales, represent};
pub use scale::{ByteScale, Extremes, PreviousFrameMinMax, Scaling};
pub use sink::{ExtremesSink, FieldPlanes, FieldSink, RgbSink, rgb};
pub use stream::RowStream;

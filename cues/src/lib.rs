//! What a device does with ReynoldsFlow beyond the bytes: motion cues
//! (connected moving regions, found in the engine's pass) and display views
//! (RGB565 rows of the frame, the representation, a field's magnitude or its
//! direction wheel). Both are [`Sink`](reynoldsflow_core::Sink)s of
//! [`reynoldsflow_core`], so they compose with its RGB sink in one pass.
//!
//! The split follows embedded-graphics' `-core` crate: `reynoldsflow-core`
//! holds the bit-exact computation and changes rarely; this crate holds the
//! application helpers and their dependencies (`heapless`, `micromath`), so
//! a major release of either never forces one of the core.
//!
//! Beside them, [`resample`]: the integer resize of gray frames that the
//! host's `--resize` and `--short-side` apply before each pair, so a device
//! that shrinks its sensor's frames gives the host's bytes.
//!
//! `no_std`, no alloc, no `unsafe`; memory fixed at compile time.
//!
//! ```
//! use reynoldsflow_core::fixed::types::U32F32;
//! use reynoldsflow_core::{Config, Engine, FramePair, Params, Plan};
//! use reynoldsflow_cues::{CueParams, Field, MotionCues, Threshold};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let (w, h) = (48, 32);
//! // A dark 4×4 square moving 2 px right over flat gray.
//! let frame = |x0: usize| -> Vec<u8> {
//!     let square = |i: usize| (x0..x0 + 4).contains(&(i % w)) && (12..16).contains(&(i / w));
//!     (0..w * h).map(|i| if square(i) { 30 } else { 160 }).collect()
//! };
//! let config = Config::new(w, h, Params::DEFAULT)?;
//! let params = CueParams {
//!     field: Field::CurlFree,
//!     threshold: Threshold::Absolute(U32F32::from_num(1)),
//!     min_area: 1,
//!     smoothing: 0,
//! };
//! // 8-px cells on a 6 × 4 grid, the 4 strongest regions kept.
//! let mut cues = MotionCues::<8, 6, 4, 4>::new(&config, params)?;
//! let mut engine = Engine::<62>::new(); // one 48-px strip
//! let plan = Plan::strips(config, Engine::<62>::MAX_TILE_WIDTH)?;
//! let (prev, next) = (frame(20), frame(22));
//! engine.run(&plan.bind(FramePair::packed(&config, &prev, &next)?)?, &mut cues);
//! assert_eq!(cues.end_frame().len(), 1); // one moving region
//! # Ok(()) }
//! ```
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]

#[cfg(test)]
extern crate std;

mod cues;
mod display;
pub mod resample;
#[cfg(test)]
mod test_rows;

pub use cues::{CueError, CueParams, Field, FrameLevel, MotionCues, Region, Threshold, grid_cells};
pub use display::{HUE_STEPS, Rgb565Sink, View, direction_hue, hsv, rgb565};

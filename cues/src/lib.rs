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
//! `no_std`, no alloc, no `unsafe`; memory fixed at compile time.
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]

#[cfg(test)]
extern crate std;

mod cues;
mod display;
#[cfg(test)]
mod test_rows;

pub use cues::{CueError, CueParams, Field, FrameLevel, MotionCues, Region, Threshold, grid_cells};
pub use display::{HUE_STEPS, Rgb565Sink, View, direction_hue, hsv, rgb565};

//! The library every front end of ReynoldsFlow uses (the `reynoldsflow`
//! command line, the GStreamer element, the ROS 2 node, Python, the
//! evaluation): the fixed-point core run over whole frames, frames and
//! video in, files out, and datasets. Where to start:
//!
//! | you have | you want | start at |
//! |---|---|---|
//! | two frames | one pair's image, fields or cues | [`engine::PairEngine`] (from [`settings::Settings`]) |
//! | frames one by one (a stream) | pairs, with the first-frame policy and restarts | [`pair_stream::PairStream`] over a `PairEngine` |
//! | a video, a frame folder, Y4M or raw input | outputs in frame order, on every core | [`sequence::open`] → [`pipeline::process`] |
//! | a tree of videos and folders | a dataset, resumable item by item | [`dataset`] |
//! | two frames, in float64 | the SPEC's reference, the tests' oracle | [`reference`](mod@reference) |
//!
//! Every operation is given what bounds it: its [`settings::Settings`]
//! (checked once; a bad value is a [`HostError::Setting`] naming the
//! setting, which each front end renders as its own flag, property or
//! keyword), the [`limits::Limits`] of the frames it may read, and, where
//! it can be stopped, a [`stop::Stop`]. Files: [`io`] (images, `.npy`,
//! atomic writes) and [`outputs`] (what a run writes).
//!
//! ```
//! use reynoldsflow_host::{Gray, engine::PairEngine, settings::Settings};
//! # fn main() -> Result<(), reynoldsflow_host::HostError> {
//! let prev = Gray::new(8, 6, (0..48).map(|i| (i * 37 % 251) as u8).collect())?;
//! let next = Gray::new(8, 6, (0..48).map(|i| (i * 41 % 251) as u8).collect())?;
//! let mut engine = PairEngine::new(&Settings::default())?;
//! let rgb = engine.image_vec(&prev, &next)?; // [|v_d|, |v_c|, fⁿ] per pixel
//! assert_eq!(rgb.len(), 3 * 8 * 6);
//! # Ok(()) }
//! ```
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![deny(unreachable_pub)]

pub mod cues;
pub mod dataset;
pub mod driver;
pub mod engine;
mod error;
mod flow;
mod gray;
pub mod io;
pub mod limits;
pub mod outputs;
pub mod pair_stream;
pub mod pipeline;
pub mod reference;
pub mod sequence;
pub mod settings;
pub mod stop;
pub mod workers;

pub use io::decoder_guard::panic_message;

/// Reached by the benches and by other crates' tests (the fixed engine
/// without settings, per instruction set, as the oracle of the same-bytes
/// tests), not an interface: front ends hold [`engine::PairEngine`].
#[doc(hidden)]
pub mod internals {
    pub use crate::engine::bands::strip_width;
    /// The engine pass per instruction set.
    pub mod bytes {
        pub use crate::engine::bytes::{Isa, Pass, best_name, kept_to_bytes, run};
    }
    pub use crate::engine::lane::{FixedOutput, compute_fixed, compute_fixed_on, planes_of};
    pub use crate::engine::memory::HostEngine;
}
pub use error::{HostError, ImageProblem};
pub use flow::{Flow, FlowPlanes};
pub use gray::{Gray, luma_bt601};

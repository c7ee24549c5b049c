//! Host side of ReynoldsFlow: the float64 reference of the SPEC
//! ([`reference`](mod@reference)), the fixed-point core run over whole frames
//! ([`engine`]), frames, video, image and `.npy` I/O, the one
//! [`Settings`](settings::Settings) every front end maps its names onto,
//! the pipeline and datasets. The `reynoldsflow` command line
//! (`reynoldsflow-cli`) and the evaluation (`reynoldsflow-eval`) are crates
//! of their own over this one.
//!
//! ```
//! use reynoldsflow_host::{Gray, reference::{self, FloatParams, FloatScaling}};
//! # fn main() -> Result<(), reynoldsflow_host::HostError> {
//! let prev = Gray::new(8, 6, (0..48).map(|i| (i * 37 % 251) as u8).collect())?;
//! let next = Gray::new(8, 6, (0..48).map(|i| (i * 41 % 251) as u8).collect())?;
//! let flow = reference::compute(&prev, &next, &FloatParams::default())?;
//! let rgb = reference::representation(&flow, &prev, FloatScaling::PerFrameMinMax);
//! assert_eq!(rgb.len(), 3 * 8 * 6);
//! # Ok(()) }
//! ```
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod atomic;
pub mod content_hash;
pub mod cues;
pub mod dataset;
mod decoder_guard;
pub mod driver;
pub mod engine;
mod error;
pub mod flow;
pub mod gray;
pub mod image_io;
pub mod limits;
pub mod npy;
pub mod outputs;
pub mod page_buffer;
pub mod pair_stream;
pub mod pipeline;
pub mod reference;
pub mod sequence;
pub mod settings;
pub mod stop;
pub mod viz;
pub mod workers;

pub use decoder_guard::panic_message;
pub use error::{HostError, ImageProblem};
pub use flow::{Flow, FlowPlanes};
pub use gray::{Gray, luma_bt601};

//! Files in and out: image files (PNG, JPEG, PGM/PPM, …) to and from
//! frames ([`image_file`]), `.npy` arrays ([`npy`]), each file written
//! whole or not at all ([`atomic`]), files known by their content
//! ([`content_hash`]), and the guard that turns a decoder's panic into an
//! error (`decoder_guard`). Video and frame folders are sequences
//! ([`crate::sequence`]); the run's outputs are [`crate::outputs`].

pub mod atomic;
pub mod content_hash;
pub(crate) mod decoder_guard;
pub mod image_file;
pub mod npy;

//! GStreamer plugin `reynoldsflow`: the element of the same name turns a
//! camera's frames (GRAY8, I420 or NV12; the luma plane) into the
//! ReynoldsFlow representation (RGB, same size), one result per
//! consecutive frame pair, computed by the core (`reynoldsflow-core`)
//! exactly as `reynoldsflow run` computes it. See docs/companion-board.md's GStreamer
//! section.

use gst::glib;

pub mod cues;
mod reynoldsflow;

pub use reynoldsflow::{FirstFrameMode, ReynoldsFlow, ScaleMode, VariantMode, property};

fn plugin_init(plugin: &gst::Plugin) -> Result<(), glib::BoolError> {
    reynoldsflow::register(plugin)
}

gst::plugin_define!(
    reynoldsflow,
    env!("CARGO_PKG_DESCRIPTION"),
    plugin_init,
    env!("CARGO_PKG_VERSION"),
    // GStreamer's name for "MIT OR Apache-2.0" licensing.
    "MIT/X11",
    env!("CARGO_PKG_NAME"),
    env!("CARGO_PKG_NAME"),
    env!("CARGO_PKG_REPOSITORY"),
    "2026-11-30"
);

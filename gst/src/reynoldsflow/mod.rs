//! The `reynoldsflow` element (see [`imp`] for its behaviour).

use gst::glib;
use gst::prelude::*;

mod imp;

glib::wrapper! {
    /// The `reynoldsflow` element.
    pub struct ReynoldsFlow(ObjectSubclass<imp::ReynoldsFlow>)
        @extends gst_base::BaseTransform, gst::Element, gst::Object;
}

/// `first-frame`: what the first frame of a stream (after a start, a flush
/// or a caps change), which has no pair yet, gives.
#[derive(Debug, Eq, PartialEq, Ord, PartialOrd, Hash, Clone, Copy, Default, glib::Enum)]
#[repr(u32)]
#[enum_type(name = "GstReynoldsFlowFirstFrame")]
pub enum FirstFrame {
    /// Nothing: N frames give N − 1 outputs, result n stamped with frame n
    /// (SPEC §5), as `reynoldsflow run` labels it.
    #[default]
    #[enum_value(
        name = "Drop: N frames give N-1 outputs, each stamped with its first frame",
        nick = "drop"
    )]
    Drop,
    /// One output per frame with that frame's timestamps: frame n ≥ 1
    /// carries result n − 1 (the motion into it); frame 0 a copy of result 0.
    #[enum_value(
        name = "Repeat: one output per frame, the first a copy of the second",
        nick = "repeat"
    )]
    Repeat,
    /// One output per frame as `repeat`, frame 0 an all-zero (black) image.
    #[enum_value(name = "Black: one output per frame, the first black", nick = "black")]
    Black,
}

/// `scale`: how magnitudes become bytes (the CLI's `--scale`).
#[derive(Debug, Eq, PartialEq, Ord, PartialOrd, Hash, Clone, Copy, Default, glib::Enum)]
#[repr(u32)]
#[enum_type(name = "GstReynoldsFlowScale")]
pub enum ScaleMode {
    /// Per-frame min–max.
    #[default]
    #[enum_value(name = "Per-frame min-max", nick = "minmax")]
    MinMax,
    /// Constant gains `k-d` and `k-c`.
    #[enum_value(name = "Fixed gains k-d and k-c", nick = "fixed")]
    Fixed,
}

/// `variant`: which image (the CLI's `--variant`).
#[derive(Debug, Eq, PartialEq, Ord, PartialOrd, Hash, Clone, Copy, Default, glib::Enum)]
#[repr(u32)]
#[enum_type(name = "GstReynoldsFlowVariant")]
pub enum VariantMode {
    /// `[|v_d|, |v_c|, f]`, the ReynoldsFlow representation.
    #[default]
    #[enum_value(
        name = "[|v_d|, |v_c|, f]: the ReynoldsFlow representation",
        nick = "dc"
    )]
    Dc,
    /// `[|v_d|, 0, f]`.
    #[enum_value(name = "[|v_d|, 0, f]", nick = "dc0")]
    Dc0,
    /// `[|v_c|, |v_d|, f]`.
    #[enum_value(name = "[|v_c|, |v_d|, f]", nick = "cd")]
    Cd,
    /// Middlebury colour wheel of `v_R`.
    #[enum_value(name = "Colour wheel of v_R", nick = "hsv")]
    Hsv,
}

impl VariantMode {
    fn host(self) -> reynoldsflow_host::outputs::Variant {
        use reynoldsflow_host::outputs::Variant;
        match self {
            VariantMode::Dc => Variant::Dc,
            VariantMode::Dc0 => Variant::Dc0,
            VariantMode::Cd => Variant::Cd,
            VariantMode::Hsv => Variant::Hsv,
        }
    }
}

/// Register the element with `plugin`.
pub fn register(plugin: &gst::Plugin) -> Result<(), glib::BoolError> {
    gst::Element::register(
        Some(plugin),
        "reynoldsflow",
        gst::Rank::NONE,
        ReynoldsFlow::static_type(),
    )
}

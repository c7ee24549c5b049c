//! The `reynoldsflow` element (see [`imp`] for its behaviour).

use gst::glib;
use gst::prelude::*;
use reynoldsflow_host::HostError;
use reynoldsflow_host::outputs::Variant;
use reynoldsflow_host::settings::{FirstFrame, ScaleArg, Setting};

mod imp;
mod outbox;
mod pairs;
mod workers;

glib::wrapper! {
    /// The `reynoldsflow` element.
    pub struct ReynoldsFlow(ObjectSubclass<imp::ReynoldsFlow>)
        @extends gst_base::BaseTransform, gst::Element, gst::Object;
}

/// The values of the enum properties: the host's settings
/// ([`reynoldsflow_host::settings`]) as GObject enums, whose nicks are the
/// host's names (a test holds them to the host's lists).
///
/// `first-frame`: what the first frame of a stream (after a start, a
/// flush, a caps change, a gap or a timestamp going back), which has no
/// pair yet, gives ([`FirstFrame`]).
#[derive(Debug, Eq, PartialEq, Ord, PartialOrd, Hash, Clone, Copy, glib::Enum)]
#[repr(u32)]
#[enum_type(name = "GstReynoldsFlowFirstFrame")]
pub enum FirstFrameMode {
    /// [`FirstFrame::Drop`].
    #[enum_value(
        name = "Drop: N frames give N-1 outputs, each stamped with its first frame",
        nick = "drop"
    )]
    Drop,
    /// [`FirstFrame::Repeat`].
    #[enum_value(
        name = "Repeat: one output per frame, the first a copy of the second",
        nick = "repeat"
    )]
    Repeat,
    /// [`FirstFrame::Black`].
    #[enum_value(name = "Black: one output per frame, the first black", nick = "black")]
    Black,
}

impl From<FirstFrame> for FirstFrameMode {
    fn from(f: FirstFrame) -> Self {
        match f {
            FirstFrame::Drop => Self::Drop,
            FirstFrame::Repeat => Self::Repeat,
            FirstFrame::Black => Self::Black,
        }
    }
}

impl From<FirstFrameMode> for FirstFrame {
    fn from(f: FirstFrameMode) -> Self {
        match f {
            FirstFrameMode::Drop => Self::Drop,
            FirstFrameMode::Repeat => Self::Repeat,
            FirstFrameMode::Black => Self::Black,
        }
    }
}

/// `scale`: how magnitudes become bytes ([`ScaleArg`], its gains the
/// `k-d` and `k-c` properties).
#[derive(Debug, Eq, PartialEq, Ord, PartialOrd, Hash, Clone, Copy, glib::Enum)]
#[repr(u32)]
#[enum_type(name = "GstReynoldsFlowScale")]
pub enum ScaleMode {
    /// Per-frame min–max.
    #[enum_value(name = "Per-frame min-max", nick = "minmax")]
    MinMax,
    /// Constant gains `k-d` and `k-c`.
    #[enum_value(name = "Fixed gains k-d and k-c", nick = "fixed")]
    Fixed,
}

impl ScaleMode {
    /// The mode of `scale`.
    pub const fn of(scale: ScaleArg) -> Self {
        match scale {
            ScaleArg::MinMax => Self::MinMax,
            ScaleArg::Fixed { .. } => Self::Fixed,
        }
    }

    /// The host's scale, with gains `(k_d, k_c)` where fixed.
    pub fn host(self, (k_d, k_c): (f64, f64)) -> ScaleArg {
        match self {
            Self::MinMax => ScaleArg::MinMax,
            Self::Fixed => ScaleArg::Fixed { k_d, k_c },
        }
    }
}

/// `variant`: which image ([`Variant`]).
#[derive(Debug, Eq, PartialEq, Ord, PartialOrd, Hash, Clone, Copy, glib::Enum)]
#[repr(u32)]
#[enum_type(name = "GstReynoldsFlowVariant")]
pub enum VariantMode {
    /// [`Variant::Dc`].
    #[enum_value(
        name = "[|v_d|, |v_c|, f]: the ReynoldsFlow representation",
        nick = "dc"
    )]
    Dc,
    /// [`Variant::Dc0`].
    #[enum_value(name = "[|v_d|, 0, f]", nick = "dc0")]
    Dc0,
    /// [`Variant::Cd`].
    #[enum_value(name = "[|v_c|, |v_d|, f]", nick = "cd")]
    Cd,
    /// [`Variant::Hsv`].
    #[enum_value(name = "Colour wheel of v_R", nick = "hsv")]
    Hsv,
}

impl From<Variant> for VariantMode {
    fn from(v: Variant) -> Self {
        match v {
            Variant::Dc => Self::Dc,
            Variant::Dc0 => Self::Dc0,
            Variant::Cd => Self::Cd,
            Variant::Hsv => Self::Hsv,
        }
    }
}

impl From<VariantMode> for Variant {
    fn from(v: VariantMode) -> Self {
        match v {
            VariantMode::Dc => Self::Dc,
            VariantMode::Dc0 => Self::Dc0,
            VariantMode::Cd => Self::Cd,
            VariantMode::Hsv => Self::Hsv,
        }
    }
}

/// The element's name for a host setting: its property (the settings it
/// has no property for keep the host's names).
pub fn property(setting: Setting) -> &'static str {
    match setting {
        Setting::FirstFrame => "first-frame",
        Setting::Scale => "scale",
        Setting::Lambda => "lambda",
        Setting::IntensityScale => "intensity-scale",
        Setting::Variant => "variant",
        Setting::Threads => "threads",
        Setting::CueThreshold => "cue-threshold",
        Setting::CueMinArea => "cue-min-area",
        setting => setting.name(),
    }
}

/// A host error as the element says it: a setting named by its property.
pub(crate) fn message(e: &HostError) -> String {
    match e {
        HostError::Setting { setting, problem } => format!("{}: {problem}", property(*setting)),
        e => e.to_string(),
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

//! The configuration as C sets it (`rf_config`), and its validated form.

use fixed::types::{U16F16, U32F32};
use reynoldsflow_core::{ByteScale, Config, IntensityScale, Params, Plan};

use crate::status::*;

/// How the magnitudes become the representation's R and G bytes (SPEC §4).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum rf_scaling {
    /// `255 · (m − min) / (max − min)` over the pair's own frame: two engine
    /// passes per pair; not for row streaming.
    RF_SCALING_PER_FRAME_MINMAX = 0,
    /// The min-max of the frame before (the first frame uses `k_d`, `k_c`):
    /// one pass, streams.
    RF_SCALING_PREVIOUS_FRAME_MINMAX = 1,
    /// Constant gains `k_d` (R) and `k_c` (G): one pass, streams.
    RF_SCALING_FIXED = 2,
}

/// Which image the bytes are.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum rf_variant {
    /// `[|v_d|, |v_c|, f]`: the ReynoldsFlow representation.
    RF_VARIANT_DC = 0,
    /// `[|v_d|, 0, f]`: without the curl-free magnitude (ablation).
    RF_VARIANT_DC0 = 1,
    /// `[|v_c|, |v_d|, f]`: the two magnitudes' bytes swapped (ablation).
    RF_VARIANT_CD = 2,
}

/// `rf_config.flags`: row callbacks also carry `v_c` and `v_d` (costs the
/// fields' conversions and `16 · tile width` bytes of working memory).
pub const RF_FLAG_ROW_FIELDS: u32 = 1;

/// What to compute, set by `rf_config_init` and then changed field by
/// field. Checked in full by `rf_workspace_size` and `rf_init`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
#[allow(non_camel_case_types)]
pub struct rf_config {
    /// Frame width, px (1 to 65535).
    pub width: u32,
    /// Frame height, px (1 to 65535).
    pub height: u32,
    /// Intensity scale `s = scale_num / scale_den` (SPEC §1: `f = pixel · s`);
    /// default 1/255.
    pub scale_num: u32,
    /// See `scale_num`.
    pub scale_den: u32,
    /// Tikhonov term λ, in `f²` per px²; default 1e-4 (rounded to Q32.32
    /// as the command line does).
    pub lambda: f64,
    /// An `rf_scaling`; default `RF_SCALING_PER_FRAME_MINMAX`.
    pub scaling: u32,
    /// Gain of `|v_d|` for `RF_SCALING_FIXED` (and the first frame of
    /// `RF_SCALING_PREVIOUS_FRAME_MINMAX`), in `[0, 65536)`, rounded to
    /// Q16.16; default 8.
    pub k_d: f64,
    /// Gain of `|v_c|`, as `k_d`; default 32.
    pub k_c: f64,
    /// An `rf_variant`; default `RF_VARIANT_DC`.
    pub variant: u32,
    /// Widest tile the working memory holds, px; 0 (default) is the frame
    /// width. Narrower tiles need less memory (252 bytes a column plus a
    /// 14-column halo) and give the same bytes; streaming needs 0.
    pub tile_width: u32,
    /// `RF_FLAG_*` bits; default 0.
    pub flags: u32,
}

impl rf_config {
    /// The defaults for a frame size (what `rf_config_init` writes).
    pub const fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            scale_num: 1,
            scale_den: 255,
            lambda: 1e-4,
            scaling: rf_scaling::RF_SCALING_PER_FRAME_MINMAX as u32,
            k_d: 8.0,
            k_c: 32.0,
            variant: rf_variant::RF_VARIANT_DC as u32,
            tile_width: 0,
            flags: 0,
        }
    }
}

/// How the bytes are scaled, validated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Mode {
    PerFrameMinMax,
    PreviousFrameMinMax,
    Fixed,
}

/// Which image, validated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Variant {
    Dc,
    Dc0,
    Cd,
}

impl Variant {
    /// Turn a row of `[|v_d| byte, |v_c| byte, f]` into this variant.
    #[inline(always)]
    pub(crate) fn apply(self, rgb: &mut [[u8; 3]]) {
        match self {
            Variant::Dc => {}
            Variant::Dc0 => rgb.iter_mut().for_each(|p| p[1] = 0),
            Variant::Cd => rgb.iter_mut().for_each(|p| p.swap(0, 1)),
        }
    }
}

/// An `rf_config` checked in full, with the core's values built from it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Settings {
    pub(crate) config: Config,
    pub(crate) plan: Plan,
    pub(crate) mode: Mode,
    /// The fixed gains' byte maps (`Fixed`, and the first frame of
    /// `PreviousFrameMinMax`).
    pub(crate) gains: (ByteScale, ByteScale),
    pub(crate) variant: Variant,
    /// Row callbacks carry the fields.
    pub(crate) row_fields: bool,
    /// The widest tile the working memory holds.
    pub(crate) tile_width: usize,
}

/// A gain as the core's Q16.16, rounded to nearest as the command line's
/// `--scale fixed:KD,KC` (NaN and out of range refused).
fn gain(k: f64) -> Result<ByteScale, rf_status> {
    U16F16::checked_from_num(k)
        .map(ByteScale::fixed)
        .ok_or(RF_ERR_GAIN_OUT_OF_RANGE)
}

impl Settings {
    pub(crate) fn new(c: &rf_config) -> Result<Self, rf_status> {
        let scale = IntensityScale::new(c.scale_num, c.scale_den)?;
        let lambda = U32F32::checked_from_num(c.lambda).ok_or(RF_ERR_LAMBDA_OUT_OF_RANGE)?;
        let width = usize::try_from(c.width).map_err(|_| RF_ERR_FRAME_TOO_LARGE)?;
        let height = usize::try_from(c.height).map_err(|_| RF_ERR_FRAME_TOO_LARGE)?;
        let config = Config::new(width, height, Params { scale, lambda })?;
        let mode = match c.scaling {
            0 => Mode::PerFrameMinMax,
            1 => Mode::PreviousFrameMinMax,
            2 => Mode::Fixed,
            _ => return Err(RF_ERR_BAD_SCALING),
        };
        let gains = match mode {
            Mode::PerFrameMinMax => (ByteScale::min_max(0.0, 0.0), ByteScale::min_max(0.0, 0.0)),
            _ => (gain(c.k_d)?, gain(c.k_c)?),
        };
        let variant = match c.variant {
            0 => Variant::Dc,
            1 => Variant::Dc0,
            2 => Variant::Cd,
            _ => return Err(RF_ERR_BAD_VARIANT),
        };
        if c.flags & !RF_FLAG_ROW_FIELDS != 0 {
            return Err(RF_ERR_BAD_FLAGS);
        }
        let tile_width = match usize::try_from(c.tile_width) {
            Ok(0) => width,
            Ok(w) if w <= width => w,
            _ => return Err(RF_ERR_BAD_TILE_WIDTH),
        };
        let plan = Plan::strips(config, tile_width)?;
        Ok(Self {
            config,
            plan,
            mode,
            gains,
            variant,
            row_fields: c.flags & RF_FLAG_ROW_FIELDS != 0,
            tile_width,
        })
    }
}

//! The settings every front end shares: one [`Settings`], its defaults
//! defined once as `DEFAULT_*` constants, and the parsers of their textual
//! forms. Each front end maps its own names onto these (the CLI's flags,
//! the GStreamer element's properties, Python's keywords, the ROS 2 node's
//! parameters); an error names the [`Setting`] at fault, and each front end
//! prints that under its own name ([`HostError::Setting`](crate::HostError::Setting)).

use std::fmt;

use reynoldsflow_core::IntensityScale;

/// A setting's value drawn from a fixed list of names (an engine, a
/// variant): how front ends list and parse the choices without restating them.
pub trait Choice: Copy + Sized + 'static {
    /// Every value, in the order front ends list them.
    const ALL: &'static [Self];
    /// The value's name (`"fixed"`, `"dc0"`).
    fn name(self) -> &'static str;
    /// One line on what the value means.
    fn help(self) -> &'static str;
    /// The value named `name`, if any.
    fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|v| v.name() == name)
    }
    /// The names, for a message: `dc, dc0, cd, hsv`.
    fn names() -> String {
        let names: Vec<&str> = Self::ALL.iter().map(|v| v.name()).collect();
        names.join(", ")
    }
}

/// Implements [`Choice`] (and an inherent `name`) for an enum from one
/// table of its values' names and help lines.
macro_rules! choices {
    ($ty:ident { $($variant:ident => $name:literal, $help:literal;)+ }) => {
        impl $crate::settings::Choice for $ty {
            const ALL: &'static [Self] = &[$($ty::$variant),+];
            fn name(self) -> &'static str {
                match self { $($ty::$variant => $name),+ }
            }
            fn help(self) -> &'static str {
                match self { $($ty::$variant => $help),+ }
            }
        }

        impl $ty {
            /// The value's name, as every front end spells it.
            pub fn name(self) -> &'static str {
                <Self as $crate::settings::Choice>::name(self)
            }
        }
    };
}
pub(crate) use choices;

/// The value of `T` named `name`, or a message listing the names.
pub fn parse_choice<T: Choice>(name: &str) -> Result<T, String> {
    T::from_name(name).ok_or_else(|| format!("'{name}': expected one of {}", T::names()))
}

/// `engine`: which implementation computes the pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EngineKind {
    /// The float64 reference, the oracle.
    Float,
    /// The fixed-point core, bit for bit what embedded targets compute.
    Fixed,
}

/// The representation variants (the paper's ablation), and the colour wheel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Variant {
    /// [|v_d|, |v_c|, f]: the ReynoldsFlow representation (SPEC 4).
    #[default]
    Dc,
    /// [|v_d|, 0, f]: ablation without the curl-free magnitude.
    Dc0,
    /// [|v_c|, |v_d|, f]: ablation with the magnitudes swapped.
    Cd,
    /// Middlebury colour wheel of v_R = v_c + v_d.
    Hsv,
}

choices!(Variant {
    Dc => "dc", "[|v_d|, |v_c|, f]: the ReynoldsFlow representation (SPEC 4)";
    Dc0 => "dc0", "[|v_d|, 0, f]: ablation without the curl-free magnitude";
    Cd => "cd", "[|v_c|, |v_d|, f]: ablation with the magnitudes swapped";
    Hsv => "hsv", "Middlebury colour wheel of v_R = v_c + v_d";
});

choices!(EngineKind {
    Fixed => "fixed", "The fixed-point core, bit for bit what embedded targets compute";
    Float => "float", "The float64 reference, the oracle";
});

/// `scale`: how magnitudes become bytes (SPEC §4), gains as given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ScaleArg {
    /// `minmax`: per-frame min–max.
    MinMax,
    /// `fixed:KD,KC`: constant gains of `|v_d|` and `|v_c|`.
    Fixed {
        /// Gain of `|v_d|` (R).
        k_d: f64,
        /// Gain of `|v_c|` (G).
        k_c: f64,
    },
}

impl fmt::Display for ScaleArg {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ScaleArg::MinMax => f.write_str("minmax"),
            ScaleArg::Fixed { k_d, k_c } => write!(f, "fixed:{k_d},{k_c}"),
        }
    }
}

/// `tile`: tile width and height in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileSize {
    /// Columns, at least 1.
    pub width: usize,
    /// Rows, at least 1.
    pub height: usize,
}

/// `first_frame`: what a stream of frames makes of its first frame, which
/// has no pair of its own (SPEC §5 gives N − 1 results for N frames).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FirstFrame {
    /// Nothing: N frames give N − 1 outputs, result n labelled with frame n.
    #[default]
    Drop,
    /// One output per frame, labelled with it: frame n ≥ 1 carries result
    /// n − 1 (the motion into it), frame 0 a copy of result 0.
    Repeat,
    /// One output per frame as `Repeat`, frame 0 an all-zero (black) image.
    Black,
}

choices!(FirstFrame {
    Drop => "drop", "N frames give N-1 outputs, each labelled with its first frame";
    Repeat => "repeat", "one output per frame, the first a copy of the second";
    Black => "black", "one output per frame, the first black";
});

/// The engine when none is given: the fixed-point core.
pub const DEFAULT_ENGINE: EngineKind = EngineKind::Fixed;
/// Per-frame min–max scaling (SPEC §4), the reference's.
pub const DEFAULT_SCALE: ScaleArg = ScaleArg::MinMax;
/// The gains of `fixed` scaling where a front end asks for them apart
/// (`|v_d|`, `|v_c|`).
pub const DEFAULT_FIXED_GAINS: (f64, f64) = (8.0, 32.0);
/// `f = pixel / 255` (SPEC §1).
pub const DEFAULT_INTENSITY_SCALE: IntensityScale = IntensityScale::PER_255;
/// The SPEC's λ (§3).
pub const DEFAULT_LAMBDA: f64 = 1e-4;
/// `[|v_d|, |v_c|, f]`, the representation itself.
pub const DEFAULT_VARIANT: Variant = Variant::Dc;
/// The SPEC's sequence rule: N frames, N − 1 results.
pub const DEFAULT_FIRST_FRAME: FirstFrame = FirstFrame::Drop;
/// Cues: the least `|v_c|` (px per frame) a moving pixel has.
pub const DEFAULT_CUE_THRESHOLD: f64 = 1.0;
/// Cues: the fewest moving pixels a region must hold to be reported.
pub const DEFAULT_CUE_MIN_AREA: u32 = 4;

/// A setting, as an error names it; each front end prints it under its own
/// name (the CLI as `--lambda`, Python as `lam`, the element as `lambda`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Setting {
    /// Which engine.
    Engine,
    /// Magnitudes to bytes.
    Scale,
    /// `s` in `f = pixel · s`.
    IntensityScale,
    /// λ of the 2×2 solve.
    Lambda,
    /// The fixed engine's tile size.
    Tile,
    /// Worker threads.
    Threads,
    /// The image variant.
    Variant,
    /// The colour wheel's radius.
    HsvMax,
    /// What the first frame of a stream gives.
    FirstFrame,
    /// Whether the representation image is written.
    Rep,
    /// The `.npy` fields.
    Npy,
    /// The `.npy` element type.
    NpyDtype,
    /// The `.flo` fields.
    Flo,
    /// PNG or JPEG.
    ImageFormat,
    /// The JPEG quality.
    JpegQuality,
    /// Resize to a size.
    Resize,
    /// Resize to a shorter side.
    ShortSide,
    /// Every K-th frame.
    Step,
    /// Frames per second picked.
    Fps,
    /// Raw input frames' size.
    Raw,
    /// Dataset shard.
    Shard,
    /// Cues: the least `|v_c|` a moving pixel has.
    CueThreshold,
    /// Cues: the fewest moving pixels a region holds.
    CueMinArea,
    /// The most pixels an input frame may have ([`crate::limits`]).
    MaxPixels,
    /// A dataset's items listed, relative to its source folder.
    FilesFrom,
}

impl Setting {
    /// The library's own name (snake case), which messages use where no
    /// front end renames it.
    pub fn name(self) -> &'static str {
        match self {
            Setting::Engine => "engine",
            Setting::Scale => "scale",
            Setting::IntensityScale => "intensity_scale",
            Setting::Lambda => "lambda",
            Setting::Tile => "tile",
            Setting::Threads => "threads",
            Setting::Variant => "variant",
            Setting::HsvMax => "hsv_max",
            Setting::FirstFrame => "first_frame",
            Setting::Rep => "rep",
            Setting::Npy => "npy",
            Setting::NpyDtype => "npy_dtype",
            Setting::Flo => "flo",
            Setting::ImageFormat => "image_format",
            Setting::JpegQuality => "jpeg_quality",
            Setting::Resize => "resize",
            Setting::ShortSide => "short_side",
            Setting::Step => "step",
            Setting::Fps => "fps",
            Setting::Raw => "raw",
            Setting::Shard => "shard",
            Setting::CueThreshold => "cue_threshold",
            Setting::CueMinArea => "cue_min_area",
            Setting::MaxPixels => "max_pixels",
            Setting::FilesFrom => "files_from",
        }
    }
}

impl fmt::Display for Setting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What every front end sets about a pair's computation and its image.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// The engine.
    pub engine: EngineKind,
    /// Magnitudes to bytes.
    pub scale: ScaleArg,
    /// `s` in `f = pixel · s`.
    pub intensity_scale: IntensityScale,
    /// λ of the 2×2 solve.
    pub lambda: f64,
    /// The fixed engine's tiles [default: full-height strips].
    pub tile: Option<TileSize>,
    /// The image variant.
    pub variant: Variant,
    /// The colour wheel's radius in pixels [default: each frame's longest vector].
    pub hsv_max: Option<f64>,
    /// Worker threads [default: every core].
    pub threads: Option<usize>,
    /// What a stream's first frame gives.
    pub first_frame: FirstFrame,
    /// Cues: a pixel moves when `|v_c|` is above this, px.
    pub cue_threshold: f64,
    /// Cues: regions of fewer moving pixels are dropped.
    pub cue_min_area: u32,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            engine: DEFAULT_ENGINE,
            scale: DEFAULT_SCALE,
            intensity_scale: DEFAULT_INTENSITY_SCALE,
            lambda: DEFAULT_LAMBDA,
            tile: None,
            variant: DEFAULT_VARIANT,
            hsv_max: None,
            threads: None,
            first_frame: DEFAULT_FIRST_FRAME,
            cue_threshold: DEFAULT_CUE_THRESHOLD,
            cue_min_area: DEFAULT_CUE_MIN_AREA,
        }
    }
}

impl Settings {
    /// The worker threads: as set, or every core.
    pub fn threads(&self) -> usize {
        self.threads.unwrap_or_else(|| {
            std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
        })
    }
}

/// Parse `minmax` or `fixed:KD,KC` (gains finite and non-negative).
pub fn parse_scale(s: &str) -> Result<ScaleArg, String> {
    let usage = "expected 'minmax' or 'fixed:KD,KC' (e.g. fixed:8,32)";
    if s == "minmax" {
        return Ok(ScaleArg::MinMax);
    }
    let Some((k_d, k_c)) = s.strip_prefix("fixed:").and_then(|ks| ks.split_once(',')) else {
        return Err(usage.to_owned());
    };
    let gain = |k: &str| match k.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("gain '{k}' is not a non-negative number; {usage}")),
    };
    Ok(ScaleArg::Fixed {
        k_d: gain(k_d)?,
        k_c: gain(k_c)?,
    })
}

/// Parse `TWxTH`, both at least 1.
pub fn parse_tile(s: &str) -> Result<TileSize, String> {
    let side = |v: &str| v.trim().parse::<usize>().ok().filter(|&n| n > 0);
    match s.split_once(['x', 'X']).map(|(w, h)| (side(w), side(h))) {
        Some((Some(width), Some(height))) => Ok(TileSize { width, height }),
        _ => Err("expected TWxTH with both sides at least 1 (e.g. 64x32)".to_owned()),
    }
}

/// Parse `λ`: a positive finite number (e.g. `1e-4`).
pub fn parse_lambda(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err("expected a positive number (e.g. 1e-4)".to_owned()),
    }
}

/// Parse the intensity scale `s` as an exact ratio and check it against the
/// core's range, so both engines accept exactly the same values.
pub fn parse_intensity_scale(s: &str) -> Result<IntensityScale, String> {
    let (num, den) = parse_ratio(s)?;
    IntensityScale::new(num, den).map_err(|e| format!("{num}/{den}: {e}"))
}

fn gcd(mut a: u128, mut b: u128) -> u128 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// A non-negative decimal (`12`, `0.5`, `.25`) as an exact fraction.
fn parse_decimal(s: &str) -> Result<(u128, u128), String> {
    let t = s.trim();
    let (int, frac) = t.split_once('.').unwrap_or((t, ""));
    let digits = |d: &str| d.bytes().all(|b| b.is_ascii_digit());
    if int.is_empty() && frac.is_empty() || !digits(int) || !digits(frac) {
        return Err(format!(
            "'{s}' is not a decimal number; expected a ratio such as 1/255 or a decimal"
        ));
    }
    let frac = frac.trim_end_matches('0');
    let too_long = || format!("'{s}' has too many digits to be an exact ratio of 32-bit integers");
    let mut num = 0u128;
    for b in int.bytes().chain(frac.bytes()) {
        num = num
            .checked_mul(10)
            .and_then(|n| n.checked_add(u128::from(b - b'0')))
            .ok_or_else(too_long)?;
    }
    let den = u32::try_from(frac.len())
        .ok()
        .and_then(|k| 10u128.checked_pow(k))
        .ok_or_else(too_long)?;
    let g = gcd(num, den);
    Ok((num / g, den / g))
}

/// An exact, reduced ratio of 32-bit integers from `N/D` (each side a
/// decimal) or a decimal alone: `1/255`, `0.5`, `2.5/510`. A decimal that is
/// not such a ratio (e.g. `0.0039215686`) is refused, not rounded.
pub fn parse_ratio(s: &str) -> Result<(u32, u32), String> {
    let (num, den) = match s.split_once('/') {
        None => parse_decimal(s)?,
        Some((n, d)) => {
            let ((n1, d1), (n2, d2)) = (parse_decimal(n)?, parse_decimal(d)?);
            if n2 == 0 {
                return Err("the denominator is zero".to_owned());
            }
            let overflow = || "too large to be an exact ratio of 32-bit integers".to_owned();
            (
                n1.checked_mul(d2).ok_or_else(overflow)?,
                d1.checked_mul(n2).ok_or_else(overflow)?,
            )
        }
    };
    let g = gcd(num, den).max(1);
    let (num, den) = (num / g, den / g);
    match (u32::try_from(num), u32::try_from(den)) {
        (Ok(n), Ok(d)) => Ok((n, d)),
        _ => Err(format!(
            "exactly {num}/{den}, which does not fit a ratio of 32-bit integers; write it as one (e.g. 1/255)"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::HostError;

    #[test]
    fn ratios_are_exact_and_reduced() {
        let ok = [
            ("1/255", (1, 255)),
            ("2/510", (1, 255)),
            ("0.5", (1, 2)),
            (".25", (1, 4)),
            ("0.250000000000000000000000000000000000000000", (1, 4)),
            ("1", (1, 1)),
            ("1.5/3", (1, 2)),
            ("2.55/650.25", (1, 255)),
            ("0/7", (0, 1)),
            ("4294967295/1", (u32::MAX, 1)),
        ];
        for (text, expected) in ok {
            assert_eq!(parse_ratio(text), Ok(expected), "{text}");
        }
    }

    #[test]
    fn ratios_that_do_not_fit_or_parse_are_refused() {
        let refused = [
            ("0.0039215686", "does not fit"),
            ("1/4294967296", "does not fit"),
            ("1/0", "zero"),
            ("1/0.0", "zero"),
            ("abc", "not a decimal"),
            ("", "not a decimal"),
            ("-1/255", "not a decimal"),
            ("1e-3", "not a decimal"),
            ("1//2", "not a decimal"),
            (
                "99999999999999999999999999999999999999999",
                "too many digits",
            ),
            (
                "0.0000000000000000000000000000000000000001",
                "too many digits",
            ),
        ];
        for (text, problem) in refused {
            let err = parse_ratio(text).expect_err(text);
            assert!(err.contains(problem), "{text}: {err}");
        }
    }

    #[test]
    fn intensity_scale_is_checked_against_the_core_range() {
        assert_eq!(parse_intensity_scale("1/255"), Ok(IntensityScale::PER_255));
        assert_eq!(
            parse_intensity_scale("0.5").map(|s| (s.num(), s.den())),
            Ok((1, 2))
        );
        for bad in ["0", "2", "3/2", "1/1000000"] {
            let err = parse_intensity_scale(bad).expect_err(bad);
            assert!(err.contains("intensity scale must lie in"), "{bad}: {err}");
        }
    }

    #[test]
    fn scale_tile_and_lambda_flags() {
        assert_eq!(parse_scale("minmax"), Ok(ScaleArg::MinMax));
        assert_eq!(
            parse_scale("fixed:8,32"),
            Ok(ScaleArg::Fixed {
                k_d: 8.0,
                k_c: 32.0
            })
        );
        assert_eq!(
            parse_scale("fixed:0.5, 1e2"),
            Ok(ScaleArg::Fixed {
                k_d: 0.5,
                k_c: 100.0
            })
        );
        for bad in [
            "",
            "max",
            "fixed:8",
            "fixed:-1,2",
            "fixed:a,b",
            "fixed:nan,1",
            "fixed:inf,1",
        ] {
            assert!(
                parse_scale(bad).unwrap_err().contains("expected 'minmax'"),
                "{bad}"
            );
        }
        assert_eq!(
            parse_tile("64x32"),
            Ok(TileSize {
                width: 64,
                height: 32
            })
        );
        assert_eq!(
            parse_tile("1X1"),
            Ok(TileSize {
                width: 1,
                height: 1
            })
        );
        for bad in ["64", "0x4", "4x0", "ax4", "-1x4", "4x4x4"] {
            assert!(parse_tile(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_lambda("1e-4"), Ok(1e-4));
        for bad in ["0", "-1e-4", "nan", "inf", "x"] {
            assert!(parse_lambda(bad).is_err(), "{bad}");
        }
    }

    /// `number` (as the refusal writes it, e.g. `7.63e-6`) moved by one
    /// unit of its last digit, up or down.
    fn one_digit_away(number: &str, up: bool) -> f64 {
        let (mantissa, exponent) = number.split_once('e').expect("d.dde±x");
        let digits = mantissa.len() - mantissa.find('.').map_or(mantissa.len(), |i| i + 1);
        let units: i64 = mantissa.replace('.', "").parse().expect("digits");
        let units = if up { units + 1 } else { units - 1 };
        let exponent: i32 = exponent.parse().expect("exponent");
        units as f64 * 10f64.powi(exponent - digits as i32)
    }

    #[test]
    fn the_lambda_range_stated_is_the_range_taken() {
        let scales = [
            (1, 1),
            (1, 255),
            (1, 1024),
            (3, 7),
            (6144, u32::MAX),
            (1, 6),
        ];
        for (num, den) in scales {
            let intensity_scale = IntensityScale::new(num, den).expect("in range");
            let with = |lambda: f64| Settings {
                intensity_scale,
                lambda,
                ..Settings::default()
            };
            let message = with(1e9).compute().expect_err("out of range").to_string();
            let stated = message
                .split_once("(about ")
                .and_then(|(_, rest)| rest.split_once(')'))
                .map(|(range, _)| range)
                .unwrap_or_else(|| panic!("no range in: {message}"));
            let (low, high) = stated.split_once(" to ").expect("LOW to HIGH");
            let at = |text: &str| text.parse::<f64>().expect("a number");
            for inside in [at(low), at(high)] {
                assert!(
                    with(inside).compute().is_ok(),
                    "s = {num}/{den}: {inside} is in the stated range ({stated}) but refused"
                );
            }
            for outside in [one_digit_away(low, false), one_digit_away(high, true)] {
                assert!(
                    matches!(
                        with(outside).compute(),
                        Err(HostError::Setting {
                            setting: Setting::Lambda,
                            ..
                        })
                    ),
                    "s = {num}/{den}: {outside}, just outside the stated range ({stated}), is taken"
                );
            }
        }
    }

    #[test]
    fn settings_are_checked_once_for_both_engines() {
        for engine in [EngineKind::Fixed, EngineKind::Float] {
            for lambda in [0.0, -1e-4, f64::NAN] {
                let bad = Settings {
                    engine,
                    lambda,
                    ..Settings::default()
                };
                assert!(matches!(
                    bad.compute(),
                    Err(HostError::Setting {
                        setting: Setting::Lambda,
                        ..
                    })
                ));
            }
            let bad = Settings {
                engine,
                hsv_max: Some(0.0),
                ..Settings::default()
            };
            assert!(matches!(
                bad.compute(),
                Err(HostError::Setting {
                    setting: Setting::HsvMax,
                    ..
                })
            ));
            assert!(
                Settings {
                    engine,
                    ..Settings::default()
                }
                .compute()
                .is_ok()
            );
        }
    }
}

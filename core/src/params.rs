//! Parameters of the computation and the integer constants derived from them.
//!
//! The pipeline works on integer pixels `p ∈ [0, 255]`. With the intensity
//! scale `s` (SPEC §1: `f = p · s`), every SPEC quantity is an integer one
//! times a power of `s` (see `engine` for the stage formats):
//!
//! | SPEC | integer form | factor |
//! |---|---|---|
//! | `v_c` | `V` | `s / 768` |
//! | `D` (residual) | `Dn = −κ·d − (X·Vx + Y·Vy) − 4·p0·Q` | `s² / 6144`, with `κ = 6144 / s` |
//! | `D`, as summed | `Dn′ = round(Dn / 2^σ)` | `2^σ · s² / 6144` |
//! | `a, b, c` | `A = G256 ⋆ X²`, … | `s² / 16384` |
//! | `λ` | `Λ4 = 4 · λ · 16384 / s²` | `s² / 65536` |
//! | `p, q` (as summed, `f32`) | `P = G256 ⋆ (X · Dn′ · 2⁻²⁰)`, … | `2^(σ+20) · s³ / 12 582 912` |
//! | `v_d` | `N / det` (see `tail`) | `2^(σ+20) · s / 192` |
//!
//! Derived once in [`Config::new`], so the per-pixel path only multiplies
//! and shifts. Only the integer rounding of `κ` and `Λ4`, the shift `σ` and
//! the `f32` units of `v_c` and `v_d` depend on `s` and `λ`; at the default
//! `s = 1/255`, `κ = 1 566 720` is exact and `σ = 8`.

use fixed::types::U32F32;

use crate::Error;

/// Largest frame side accepted (rows and columns are counted in `u16`).
pub const MAX_SIDE: usize = u16::MAX as usize;

/// The intensity scale `s` as an exact ratio `num / den`, `0 < s ≤ 1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IntensityScale {
    num: u32,
    den: u32,
}

impl IntensityScale {
    /// The SPEC default, `f = p / 255`.
    pub const PER_255: Self = Self { num: 1, den: 255 };

    /// `s = num / den`. Refused unless `0 < s ≤ 1` and `κ = 6144 / s ≤ 2³²`
    /// (which keeps the residual `Dn` within 41 bits).
    pub const fn new(num: u32, den: u32) -> Result<Self, Error> {
        if num == 0 || den == 0 || num > den || kappa_of(num, den) > 1 << 32 {
            return Err(Error::ScaleOutOfRange);
        }
        Ok(Self { num, den })
    }

    /// Numerator of `s`.
    pub const fn num(self) -> u32 {
        self.num
    }

    /// Denominator of `s`.
    pub const fn den(self) -> u32 {
        self.den
    }
}

impl Default for IntensityScale {
    fn default() -> Self {
        Self::PER_255
    }
}

/// `round(6144 · den / num)`: the weight of the temporal difference in `Dn`.
const fn kappa_of(num: u32, den: u32) -> u64 {
    (2 * 6144 * den as u64 + num as u64) / (2 * num as u64)
}

/// The SPEC's parameters: intensity scale `s` and Tikhonov term `λ`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Params {
    /// `f = pixel · s`.
    pub scale: IntensityScale,
    /// `λ` in units of `f²` per px², as an unsigned Q32.32. [`Config::new`]
    /// needs `1 ≤ Λ4 < 2³⁰` for `Λ4 = round(65536 · λ / s²)`: at the
    /// default scale any λ from 2⁻³² up to 0.25; the upper end shrinks with
    /// `s²`, so very small scales need very small λ.
    pub lambda: U32F32,
}

impl Params {
    /// `λ = 1e-4` rounded to Q32.32 (`429 497 / 2³²`, relative error 6e-7).
    pub const DEFAULT_LAMBDA: U32F32 = U32F32::from_bits(429_497);

    /// SPEC defaults: `s = 1/255`, `λ = 1e-4`.
    pub const DEFAULT: Self = Self {
        scale: IntensityScale::PER_255,
        lambda: Self::DEFAULT_LAMBDA,
    };
}

impl Default for Params {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// A validated frame geometry and parameter set, with the integer constants
/// the per-pixel path uses. Building one is the only place the computation
/// can fail; everything downstream is infallible.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    width: u16,
    height: u16,
    params: Params,
    /// `κ = round(6144 / s) ∈ [6144, 2³²]`.
    pub(crate) kappa: i64,
    /// `Λ4 = round(65536 · λ / s²) ∈ [1, 2³⁰)`: λ in quarters of the `A` unit.
    pub(crate) lambda4: i32,
    /// `σ`: `Dn` is summed as `Dn′ = round(Dn / 2^σ)`, the smallest shift
    /// that keeps `|Dn′| ≤ 2²⁷` for every input ([`residual_shift`]).
    pub(crate) dn_shift: u32,
    /// The per-pixel tail's `f32` constants ([`Units`]), as bits (so the
    /// configuration stays `Eq`).
    units: [u32; 3],
}

/// The `f32` constants of the per-pixel tail (`tail.rs`), each the `f64`
/// quotient of exact integers rounded once to `f32` (so every target,
/// hardware or software floats, derives the same bits).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Units {
    /// Pixels per unit of `V`: `s / 768`.
    pub(crate) v_c: f32,
    /// Pixels per unit of `N / det`: `2^(σ+20) · s / 192`.
    pub(crate) v_d: f32,
    /// The least determinant, `Λ4²` (as `f32`, rounded): `det ≥ Λ4²` in
    /// exact arithmetic, and the tail clamps its rounded `det` to it.
    pub(crate) det_floor: f32,
}

impl Units {
    fn of(num: u32, den: u32, sigma: u32, lambda4: i32) -> Self {
        let (num, den) = (f64::from(num), f64::from(den));
        // `num · 2^(σ+20)` and `192 · den` are exact in f64 (σ ≤ 14).
        let v_d = num * (1u64 << (sigma + 20)) as f64 / (192.0 * den);
        let lambda4 = lambda4 as f32;
        Self {
            v_c: (num / (768.0 * den)) as f32,
            v_d: v_d as f32,
            det_floor: lambda4 * lambda4,
        }
    }
}

/// Largest `|X·Vx + Y·Vy| + |4·p0·Q|` over all inputs: `1020 · (2 · 6 854 400 +
/// 16 144 560)`, from the L1 norms of the linear maps `d → V` (each component
/// 255 · 26 880) and `d → Q` (255 · 63 312) and `|X|, |Y|, 4·p0 ≤ 1020`.
pub(crate) const DN_BOUND_WITHOUT_KAPPA: u64 = 1020 * (2 * 6_854_400 + 16_144_560);

/// `σ` for a given `κ`: the least shift with `|Dn| ≤ 255·κ + DN_BOUND_WITHOUT_KAPPA
/// < 2^(27 + σ)`, so `|Dn′| = |round(Dn / 2^σ)| ≤ 2²⁷`. It is 8 for every
/// `s ≥ 1/1024` and at most 14 (κ ≤ 2³²).
pub(crate) const fn residual_shift(kappa: u64) -> u32 {
    let bound = 255 * kappa + DN_BOUND_WITHOUT_KAPPA;
    (u64::BITS - bound.leading_zeros()).saturating_sub(27)
}

impl Config {
    /// Validate a frame size and parameters.
    pub fn new(width: usize, height: usize, params: Params) -> Result<Self, Error> {
        if width == 0 || height == 0 {
            return Err(Error::EmptyFrame);
        }
        let (Ok(w), Ok(h)) = (u16::try_from(width), u16::try_from(height)) else {
            return Err(Error::FrameTooLarge);
        };
        let IntensityScale { num, den } = params.scale;
        // `IntensityScale::new` checked the scale; a hand-built value cannot exist.
        let kappa = kappa_of(num, den) as i64;
        // Λ4 = round(λ_bits · 2⁻³² · 2¹⁶ · den² / num²) = round(λ_bits · den² / (2¹⁶ · num²)).
        let (num, den) = (num as u128, den as u128);
        let lambda_bits = params.lambda.to_bits() as u128;
        let lambda_den = (num * num) << 16;
        let lambda4 = (lambda_bits * den * den + lambda_den / 2) / lambda_den;
        // 4·A ≤ 1 065 369 600 < 2³⁰; 4·A + Λ4 must stay below 2³¹ (an i32).
        if lambda4 == 0 || lambda4 >= 1 << 30 {
            return Err(Error::LambdaOutOfRange);
        }
        let dn_shift = residual_shift(kappa as u64);
        let units = Units::of(params.scale.num, params.scale.den, dn_shift, lambda4 as i32);
        Ok(Self {
            width: w,
            height: h,
            params,
            kappa,
            lambda4: lambda4 as i32,
            dn_shift,
            units: [units.v_c, units.v_d, units.det_floor].map(f32::to_bits),
        })
    }

    /// The per-pixel tail's `f32` constants.
    #[inline(always)]
    pub(crate) fn units(&self) -> Units {
        let [v_c, v_d, det_floor] = self.units.map(f32::from_bits);
        Units {
            v_c,
            v_d,
            det_floor,
        }
    }

    /// `κ = κh·2^σ + κl` as `[κh, κl]`: `255·κh < 2²⁷`, `κl < 2^σ`.
    pub(crate) const fn kappa_split(&self) -> [i32; 2] {
        let low = (1i64 << self.dn_shift) - 1;
        [
            (self.kappa >> self.dn_shift) as i32,
            (self.kappa & low) as i32,
        ]
    }

    /// Frame width in pixels.
    pub const fn width(&self) -> usize {
        self.width as usize
    }

    /// Frame height in pixels.
    pub const fn height(&self) -> usize {
        self.height as usize
    }

    /// The parameters this configuration was built from.
    pub const fn params(&self) -> Params {
        self.params
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_constants_are_the_exact_integers() {
        let c = Config::new(4, 4, Params::DEFAULT).unwrap();
        assert_eq!(c.kappa, 6144 * 255);
        // 65536 · 1e-4 · 255² = 426 147.84; λ is 1e-4 to 6e-7.
        assert_eq!(c.lambda4, 426_148);
        assert_eq!(c.dn_shift, 8);
        let units = c.units();
        let want_d = 2f64.powi(28) / (192.0 * 255.0);
        for (got, want) in [(units.v_c, 1.0 / (768.0 * 255.0)), (units.v_d, want_d)] {
            assert!((f64::from(got) / want - 1.0).abs() < 2f64.powi(-24));
        }
        assert_eq!(units.det_floor, 426_148f32 * 426_148f32);
    }

    #[test]
    fn scale_and_lambda_limits_are_typed_errors() {
        assert_eq!(IntensityScale::new(0, 1), Err(Error::ScaleOutOfRange));
        assert_eq!(IntensityScale::new(2, 1), Err(Error::ScaleOutOfRange));
        assert_eq!(IntensityScale::new(1, 0), Err(Error::ScaleOutOfRange));
        assert_eq!(
            IntensityScale::new(1, 1_000_000),
            Err(Error::ScaleOutOfRange)
        );
        assert!(IntensityScale::new(1, 1).is_ok());
        let zero = Params {
            lambda: U32F32::ZERO,
            ..Params::DEFAULT
        };
        assert_eq!(Config::new(1, 1, zero), Err(Error::LambdaOutOfRange));
        let huge = Params {
            lambda: U32F32::from_num(1),
            ..Params::DEFAULT
        };
        assert_eq!(Config::new(1, 1, huge), Err(Error::LambdaOutOfRange));
        assert_eq!(Config::new(0, 1, Params::DEFAULT), Err(Error::EmptyFrame));
        assert_eq!(
            Config::new(1, 70_000, Params::DEFAULT),
            Err(Error::FrameTooLarge)
        );
    }

    #[test]
    fn every_admissible_scale_gives_normal_units() {
        for (num, den) in [(1, 1), (1, 255), (3, 7), (1, 699_050), (255, 256)] {
            let scale = IntensityScale::new(num, den).unwrap();
            // A λ whose Λ8 is about 1000 at this scale, or the smallest λ.
            let s = f64::from(num) / f64::from(den);
            let lambda = U32F32::from_num(1000.0 * s * s / 65_536.0).max(U32F32::DELTA);
            let c = Config::new(1, 1, Params { scale, lambda }).unwrap();
            let units = c.units();
            assert!(
                units.v_c.is_normal() && units.v_d.is_normal(),
                "{num}/{den}"
            );
            assert!(units.det_floor >= 1.0, "{num}/{den}");
            assert!((6144..=1 << 32).contains(&c.kappa), "{num}/{den}");
            assert!((8..=14).contains(&c.dn_shift), "{num}/{den}");
        }
    }
}

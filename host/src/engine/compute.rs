//! The checked computation of a pair: [`Settings`] to the engine and
//! parameters ([`Compute`]), each setting checked once, an error naming
//! the setting at fault. The float64 reference ([`crate::reference`]) is
//! the oracle the fixed engine is held to, reached from here for
//! `--engine float`; it is not a second engine of the host.

use fixed::types::{U16F16, U32F32};
use reynoldsflow_core::{Config, Error as CoreError, IntensityScale, Params, Scaling};

use super::PairEngine;
use super::image::{Image, PairFields};
use super::lane::Lane;
use crate::engine::page_buffer::ByteBuffer;
use crate::reference::{self, FloatParams, FloatScaling};
use crate::settings::{EngineKind, ScaleArg, Setting, Settings, TileSize};
use crate::{Gray, HostError};

impl Settings {
    /// The checked computation of a pair (engine, scale, intensity scale,
    /// λ, tile), or the setting at fault.
    pub fn compute(&self) -> Result<Compute, HostError> {
        if let Some(k) = self.hsv_max
            && !(k.is_finite() && k > 0.0)
        {
            return Err(HostError::setting(
                Setting::HsvMax,
                format!("{k}; expected a positive number of pixels"),
            ));
        }
        // Both engines: the float reference would refuse it only per pair.
        if !(self.lambda.is_finite() && self.lambda > 0.0) {
            return Err(HostError::setting(
                Setting::Lambda,
                format!("{}; expected a positive number (e.g. 1e-4)", self.lambda),
            ));
        }
        if self.threads == Some(0) {
            return Err(HostError::setting(
                Setting::Threads,
                "0; expected at least 1",
            ));
        }
        Compute::new(
            self.engine,
            self.scale,
            self.intensity_scale,
            self.lambda,
            self.tile,
        )
    }
}

/// The computation of one pair: engine and parameters, checked once.
#[derive(Clone, Debug)]
pub struct Compute {
    engine: EngineKind,
    scale: ScaleArg,
    intensity_scale: IntensityScale,
    lambda: f64,
    tile: Option<TileSize>,
    fixed: Option<(Params, Scaling)>,
}

impl Compute {
    /// Check the parameters the way `reynoldsflow pair` does, naming the
    /// flag at fault.
    pub fn new(
        engine: EngineKind,
        scale: ScaleArg,
        intensity_scale: IntensityScale,
        lambda: f64,
        tile: Option<TileSize>,
    ) -> Result<Self, HostError> {
        let mut compute = Self {
            engine,
            scale,
            intensity_scale,
            lambda,
            tile,
            fixed: None,
        };
        match engine {
            EngineKind::Float => {
                if tile.is_some() {
                    return Err(HostError::setting(
                        Setting::Tile,
                        "only the fixed engine works in tiles; leave the tile unset or use the fixed engine",
                    ));
                }
            }
            EngineKind::Fixed => {
                let params = core_params(intensity_scale, lambda)?;
                compute.fixed = Some((params, core_scaling(scale)?));
            }
        }
        Ok(compute)
    }

    /// The engine.
    pub fn engine(&self) -> EngineKind {
        self.engine
    }

    /// The fixed engine's parameters and scaling (none for the float engine).
    pub(crate) fn fixed(&self) -> Option<(Params, Scaling)> {
        self.fixed
    }

    /// The tile size, when set.
    pub(crate) fn tile(&self) -> Option<TileSize> {
        self.tile
    }

    /// One pair's fields and representation, exactly as `reynoldsflow
    /// pair` computes them: [`PairEngine::fields`] of a one-thread engine.
    pub fn pair(&self, prev: &Gray, next: &Gray) -> Result<PairFields, HostError> {
        PairEngine::with_pool(self.clone(), Image::default(), None, 0).fields(prev, next)
    }

    /// [`Self::pair`] with the reused buffers of `engine`.
    pub(crate) fn pair_with(
        &self,
        engine: &mut Lane,
        prev: &Gray,
        next: &Gray,
    ) -> Result<PairFields, HostError> {
        if prev.size() != next.size() {
            return Err(HostError::SizeMismatch {
                prev: prev.size(),
                next: next.size(),
            });
        }
        match self.fixed {
            None => float_pair(prev, next, self.intensity_scale, self.lambda, self.scale),
            Some((params, scaling)) => {
                let tile = self.tile.map(|t| (t.width, t.height));
                // One worker per pair already keeps the cores busy: each pair on one thread.
                let out = engine
                    .compute(prev, next, params, tile, scaling)
                    .map_err(tile_error)?;
                Ok(PairFields {
                    planes: out.planes,
                    rep: out.rep,
                })
            }
        }
    }

    /// The representation of one pair alone into `rgb`: the bytes of
    /// [`Self::pair`]'s `rep`, computed by the fixed engine with the reused
    /// buffers of `engine` and nothing else.
    pub(crate) fn representation(
        &self,
        engine: &mut Lane,
        prev: &Gray,
        next: &Gray,
        rgb: &mut impl ByteBuffer,
    ) -> Result<(), HostError> {
        match self.fixed {
            None => {
                let fields = self.pair_with(engine, prev, next)?;
                rgb.overwrite(fields.rep.len())?
                    .copy_from_slice(&fields.rep);
                Ok(())
            }
            Some((params, scaling)) => {
                let tile = self.tile.map(|t| (t.width, t.height));
                engine
                    .represent(prev, next, params, tile, scaling, rgb)
                    .map_err(tile_error)
            }
        }
    }
}

/// A tile the core refuses is the fault of the tile setting.
pub(crate) fn tile_error(e: HostError) -> HostError {
    match e {
        HostError::Core(c @ CoreError::TileOutOfFrame) => {
            HostError::setting(Setting::Tile, c.to_string())
        }
        e => e,
    }
}

/// The float reference on one pair, with the representation of `scale`.
pub(crate) fn float_pair(
    prev: &Gray,
    next: &Gray,
    intensity_scale: IntensityScale,
    lambda: f64,
    scale: ScaleArg,
) -> Result<PairFields, HostError> {
    let params = FloatParams {
        intensity_scale: f64::from(intensity_scale.num()) / f64::from(intensity_scale.den()),
        lambda,
    };
    let planes = reference::compute(prev, next, &params)?;
    let scaling = match scale {
        ScaleArg::MinMax => FloatScaling::PerFrameMinMax,
        ScaleArg::Fixed { k_d, k_c } => FloatScaling::Fixed { k_d, k_c },
    };
    let rep = reference::representation(&planes, prev, scaling);
    Ok(PairFields { planes, rep })
}

/// The core's parameters, λ rounded to its Q32.32 and within the core's
/// integer bounds at this intensity scale, or the λ setting's error
/// stating that range ([`lambda_range`]).
pub(crate) fn core_params(
    intensity_scale: IntensityScale,
    lambda: f64,
) -> Result<Params, HostError> {
    match fixed_params(intensity_scale, lambda) {
        Ok(Some(params)) => Ok(params),
        Ok(None) => Err(lambda_range(intensity_scale, lambda)),
        Err(e) => Err(HostError::setting(Setting::IntensityScale, e.to_string())),
    }
}

/// The check of λ for the fixed engine, the one both the refusal and the
/// range it states come from: λ as the core's Q32.32 (rounded to nearest),
/// then the core's own bounds on `Λ4 = round(65536 · λ / s²)`
/// (`Config::new` on a 1×1 frame: they do not depend on the frame size).
/// `Ok(None)` where λ is outside them; `Err` where the core refuses
/// something else (the intensity scale).
fn fixed_params(intensity_scale: IntensityScale, lambda: f64) -> Result<Option<Params>, CoreError> {
    let Some(lambda) = U32F32::checked_from_num(lambda) else {
        return Ok(None);
    };
    let params = Params {
        scale: intensity_scale,
        lambda,
    };
    match Config::new(1, 1, params) {
        Ok(_) => Ok(Some(params)),
        Err(CoreError::LambdaOutOfRange) => Ok(None),
        Err(e) => Err(e),
    }
}

/// The least and the greatest λ the fixed engine takes at this intensity
/// scale, found by [`fixed_params`] itself: the λ it takes form one
/// interval (`Λ4` grows with λ), so a bisection over the ordered bit
/// patterns of positive `f64`s finds each end exactly. `None` where it
/// takes none.
fn lambda_bounds(intensity_scale: IntensityScale) -> Option<(f64, f64)> {
    let takes = |bits: u64| {
        matches!(
            fixed_params(intensity_scale, f64::from_bits(bits)),
            Ok(Some(_))
        )
    };
    // One λ taken: Λ4 spans 2³⁰, so a power of two in every factor of 4 finds it.
    let inside = (-80..=40)
        .map(|e| 2f64.powi(e).to_bits())
        .find(|&b| takes(b))?;
    // The first bit pattern in `lo..hi` where `takes` turns to `to`, given
    // `takes(lo) != to` and `takes(hi) == to`.
    let turn = |mut lo: u64, mut hi: u64, to: bool| {
        while hi - lo > 1 {
            let mid = lo + (hi - lo) / 2;
            if takes(mid) == to {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        hi
    };
    let low = turn(0, inside, true);
    let high = turn(inside, f64::INFINITY.to_bits(), false) - 1;
    Some((f64::from_bits(low), f64::from_bits(high)))
}

/// `x` to three significant digits (`1.23e-4`), rounded up (`up`) or
/// down: the ends of a range written so that every number between them is
/// inside it.
fn three_digits(x: f64, up: bool) -> String {
    let nearest = format!("{x:.2e}");
    let (mantissa, exponent) = nearest
        .split_once('e')
        .expect("LowerExp writes an exponent");
    let (mut units, mut exponent): (i64, i32) = (
        mantissa.replace('.', "").parse().expect("d.dd"),
        exponent.parse().expect("an integer exponent"),
    );
    let value =
        |units: i64, exponent: i32| format!("{}.{:02}e{exponent}", units / 100, units % 100);
    let written: f64 = nearest.parse().expect("a number");
    if up && written < x {
        units += 1;
    } else if !up && written > x {
        units -= 1;
    }
    if units == 1000 {
        (units, exponent) = (100, exponent + 1);
    } else if units == 99 {
        (units, exponent) = (999, exponent - 1);
    }
    value(units, exponent)
}

/// The λ setting's refusal at this intensity scale, stating the range the
/// fixed engine takes there ([`lambda_bounds`]), its ends rounded inwards.
pub(crate) fn lambda_range(intensity_scale: IntensityScale, lambda: f64) -> HostError {
    let range = match lambda_bounds(intensity_scale) {
        Some((low, high)) => format!(
            "about {} to {}",
            three_digits(low, true),
            three_digits(high, false)
        ),
        None => "it takes none".to_owned(),
    };
    HostError::setting(
        Setting::Lambda,
        format!(
            "{lambda} is outside the fixed engine's range at this intensity scale ({range}); \
             use the float engine or another intensity scale"
        ),
    )
}

/// The scale setting for the core, gains as its Q16.16.
pub(crate) fn core_scaling(scale: ScaleArg) -> Result<Scaling, HostError> {
    Ok(match scale {
        ScaleArg::MinMax => Scaling::PerFrameMinMax,
        ScaleArg::Fixed { k_d, k_c } => Scaling::Fixed {
            k_d: core_gain("KD", k_d)?,
            k_c: core_gain("KC", k_c)?,
        },
    })
}

/// A gain as the core's Q16.16, rounded to nearest.
fn core_gain(which: &str, k: f64) -> Result<U16F16, HostError> {
    U16F16::checked_from_num(k).ok_or_else(|| {
        HostError::setting(
            Setting::Scale,
            format!("{which} = {k} is beyond the fixed engine's range [0, 65536)"),
        )
    })
}

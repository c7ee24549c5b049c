//! The float64 reference of SPEC §1–§4: the oracle every other engine is
//! checked against, written to be read next to the SPEC rather than to be
//! fast.
//!
//! Only the two input frames are clamped (SPEC §2); every later stage is
//! evaluated as if the frame extended without end. So each stage is a
//! `Plane` over a rectangle of *frame* coordinates that reaches outside
//! the frame: the inputs cover the frame plus the 7-px halo (SPEC §6), and
//! each stencil shrinks its plane by its radius, down to exactly the frame
//! for `v_d`. A read outside a plane's rectangle is a bug and panics.
//!
//! Correlations sum `K[j][i] · g(x + i − r, y + j − r)` in row-major kernel
//! order, from `0.0`, with the kernels as printed (`Kb` entries are `k / 3`).
//! This is the plain reading of the SPEC and reproduces the conformance
//! vectors' rounding residue bit for bit on the 1×1 case.

use crate::settings::Setting;
use crate::{Flow, FlowPlanes, Gray, HostError};

/// Radius of input one output pixel depends on (SPEC §6).
const HALO: isize = 7;

/// SPEC parameters in float.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FloatParams {
    /// `s` in `f = pixel · s`.
    pub intensity_scale: f64,
    /// Tikhonov term `λ` of the 2×2 solve, in units of `f²` per px².
    pub lambda: f64,
}

impl Default for FloatParams {
    /// SPEC defaults: `s = 1/255`, `λ = 1e-4`.
    fn default() -> Self {
        Self {
            intensity_scale: 1.0 / 255.0,
            lambda: 1e-4,
        }
    }
}

/// The two fields of a frame pair as the reference computes them.
pub type FloatFlow = FlowPlanes;

/// How magnitudes become bytes (SPEC §4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FloatScaling {
    /// `x = m − min(m)`, `k = 255 / (max(m) − min(m))` per frame and
    /// channel; all zero when the range is below [`FLAT_RANGE`].
    PerFrameMinMax,
    /// `x = m` with constant gains.
    Fixed {
        /// Gain of `|v_d|` (R).
        k_d: f64,
        /// Gain of `|v_c|` (G).
        k_c: f64,
    },
}

/// A per-frame min–max range below this many px is flat (SPEC §4): every
/// byte 0. Such a range is float rounding residue, not motion: a global +1
/// gives exact `v_c = 0`, which stages 1–4 in f64 leave as `|v_c|` ≈ 1e-15.
pub const FLAT_RANGE: f64 = 1e-9;

/// A float plane over the frame-coordinate rectangle
/// `[x0, x0 + width) × [y0, y0 + height)`.
struct Plane {
    x0: isize,
    y0: isize,
    width: usize,
    height: usize,
    data: Vec<f64>,
}

impl Plane {
    /// Evaluate `f(x, y)` over a rectangle.
    fn from_fn(
        x0: isize,
        y0: isize,
        width: usize,
        height: usize,
        f: impl Fn(isize, isize) -> f64,
    ) -> Self {
        let mut data = Vec::with_capacity(width * height);
        for y in y0..y0 + height as isize {
            for x in x0..x0 + width as isize {
                data.push(f(x, y));
            }
        }
        Self {
            x0,
            y0,
            width,
            height,
            data,
        }
    }

    /// `f` over this plane's rectangle shrunk by `r` on every side.
    fn inner(&self, r: usize, f: impl Fn(isize, isize) -> f64) -> Self {
        let r_i = r as isize;
        Self::from_fn(
            self.x0 + r_i,
            self.y0 + r_i,
            self.width - 2 * r,
            self.height - 2 * r,
            f,
        )
    }

    /// `f` of every value, same rectangle.
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        Self {
            data: self.data.into_iter().map(f).collect(),
            ..self
        }
    }

    /// The value at frame coordinates `(x, y)`.
    fn at(&self, x: isize, y: isize) -> f64 {
        let (i, j) = (x - self.x0, y - self.y0);
        assert!(
            (0..self.width as isize).contains(&i) && (0..self.height as isize).contains(&j),
            "read at ({x}, {y}) outside the plane; the halo bookkeeping is wrong"
        );
        self.data[j as usize * self.width + i as usize]
    }

    /// `K ⋆ self` (SPEC §2 correlation), valid on the rectangle shrunk by the
    /// kernel radius.
    fn correlate<const N: usize>(&self, k: &[[f64; N]; N]) -> Self {
        let r = N / 2;
        self.inner(r, |x, y| {
            let mut sum = 0.0;
            for (j, row) in k.iter().enumerate() {
                for (i, &w) in row.iter().enumerate() {
                    sum += w * self.at(x + i as isize - r as isize, y + j as isize - r as isize);
                }
            }
            sum
        })
    }

    /// The frame's pixels `[0, w) × [0, h)` as a row-major plane.
    fn frame(&self, width: usize, height: usize) -> Vec<f64> {
        let mut out = Vec::with_capacity(width * height);
        for y in 0..height as isize {
            for x in 0..width as isize {
                out.push(self.at(x, y));
            }
        }
        out
    }
}

const KBX: [[f64; 3]; 3] = [
    [-1.0 / 3.0, 0.0, 1.0 / 3.0],
    [-4.0 / 3.0, 0.0, 4.0 / 3.0],
    [-1.0 / 3.0, 0.0, 1.0 / 3.0],
];
const KBY: [[f64; 3]; 3] = [
    [-1.0 / 3.0, -4.0 / 3.0, -1.0 / 3.0],
    [0.0, 0.0, 0.0],
    [1.0 / 3.0, 4.0 / 3.0, 1.0 / 3.0],
];
const SOBX: [[f64; 3]; 3] = [[-1.0, 0.0, 1.0], [-2.0, 0.0, 2.0], [-1.0, 0.0, 1.0]];
const SOBY: [[f64; 3]; 3] = [[-1.0, -2.0, -1.0], [0.0, 0.0, 0.0], [1.0, 2.0, 1.0]];
const BOX: [[f64; 3]; 3] = [[1.0; 3]; 3];

/// `G = g gᵀ`, `g = [1 4 6 4 1] / 16`: every weight is exact in f64.
fn binomial5() -> [[f64; 5]; 5] {
    let g = [1.0, 4.0, 6.0, 4.0, 1.0].map(|v: f64| v / 16.0);
    g.map(|gj| g.map(|gi| gj * gi))
}

fn check_params(params: &FloatParams) -> Result<(), HostError> {
    let s = params.intensity_scale;
    if !(s.is_finite() && s > 0.0) {
        return Err(HostError::setting(
            Setting::IntensityScale,
            format!("{s} is not a positive number"),
        ));
    }
    let l = params.lambda;
    if !(l.is_finite() && l > 0.0) {
        return Err(HostError::setting(
            Setting::Lambda,
            format!("{l} is not a positive number"),
        ));
    }
    Ok(())
}

/// The fields `v_c` and `v_d` of the pair `(prev, next) = (fⁿ, fⁿ⁺¹)`
/// (SPEC §3 steps 1–9). Fails when the frames differ in size or a
/// parameter is not a positive finite number.
pub fn compute(prev: &Gray, next: &Gray, params: &FloatParams) -> Result<FloatFlow, HostError> {
    if prev.size() != next.size() {
        return Err(HostError::SizeMismatch {
            prev: prev.size(),
            next: next.size(),
        });
    }
    check_params(params)?;
    let (w, h) = prev.size();
    let (s, lambda) = (params.intensity_scale, params.lambda);
    let g = binomial5();

    // Inputs, clamped, over the frame plus the halo (SPEC §1, §2).
    let padded = |f: &dyn Fn(isize, isize) -> f64| {
        Plane::from_fn(
            -HALO,
            -HALO,
            w + 2 * HALO as usize,
            h + 2 * HALO as usize,
            f,
        )
    };
    let f0 = padded(&|x, y| f64::from(prev.clamped(x, y)) * s);
    let f1 = padded(&|x, y| f64::from(next.clamped(x, y)) * s);

    // 1. δf = f¹ − f⁰.
    let df = f0.inner(0, |x, y| f1.at(x, y) - f0.at(x, y));
    drop(f1);
    // Steps 2–4 in a block, so their planes are freed once v_c exists.
    let (vcx, vcy) = {
        // 2. Boundary terms (radius 1).
        let bx = df.correlate(&KBX);
        let by = df.correlate(&KBY);
        // 3. Domain terms (radius 1 + 1).
        let sx = df.correlate(&SOBX).correlate(&BOX);
        let sy = df.correlate(&SOBY).correlate(&BOX);
        // 4. v_c = G ⋆ (B − S) (radius 4).
        let vcx = sx.inner(0, |x, y| bx.at(x, y) - sx.at(x, y)).correlate(&g);
        let vcy = sy.inner(0, |x, y| by.at(x, y) - sy.at(x, y)).correlate(&g);
        (vcx, vcy)
    };
    // 5. Spatial gradient of fⁿ (radius 1 on the clamped input).
    let fx = f0.correlate(&SOBX).map(|v| v / 8.0);
    let fy = f0.correlate(&SOBY).map(|v| v / 8.0);
    // 6. div v_c, central differences (radius 5).
    let div = vcx.inner(1, |x, y| {
        (vcx.at(x + 1, y) - vcx.at(x - 1, y)) / 2.0 + (vcy.at(x, y + 1) - vcy.at(x, y - 1)) / 2.0
    });
    // 7. Residual D = −δf − (fx·v_cx + fy·v_cy) − f⁰·div.
    let d = div.inner(0, |x, y| {
        -df.at(x, y)
            - (fx.at(x, y) * vcx.at(x, y) + fy.at(x, y) * vcy.at(x, y))
            - f0.at(x, y) * div.at(x, y)
    });
    // 8. Structure sums (radius 7: exactly the frame).
    let product = |u: &Plane, v: &Plane| d.inner(0, |x, y| u.at(x, y) * v.at(x, y));
    let a = product(&fx, &fx).correlate(&g);
    let b = product(&fx, &fy).correlate(&g);
    let c = product(&fy, &fy).correlate(&g);
    let p = product(&fx, &d).correlate(&g);
    let q = product(&fy, &d).correlate(&g);
    // 9. [a+λ, b; b, c+λ] v_d = [p; q], solved exactly.
    let solve = |x: isize, y: isize| {
        let (a, b, c, p, q) = (
            a.at(x, y) + lambda,
            b.at(x, y),
            c.at(x, y) + lambda,
            p.at(x, y),
            q.at(x, y),
        );
        let det = a * c - b * b;
        ((c * p - b * q) / det, (a * q - b * p) / det)
    };
    let vdx = a.inner(0, |x, y| solve(x, y).0);
    let vdy = a.inner(0, |x, y| solve(x, y).1);

    Ok(FloatFlow {
        v_c: Flow::from_parts(w, h, vcx.frame(w, h), vcy.frame(w, h)),
        v_d: Flow::from_parts(w, h, vdx.frame(w, h), vdy.frame(w, h)),
    })
}

/// `min(255, ⌊x · k + ½⌋)` (SPEC §4); `x · k ≥ 0` here.
fn to_byte(x: f64, k: f64) -> u8 {
    (x * k + 0.5).floor().min(255.0) as u8
}

/// One channel's bytes under a scaling mode (`fixed_k` for `Fixed`).
fn channel(m: &[f64], scaling: FloatScaling, fixed_k: f64) -> Vec<u8> {
    match scaling {
        FloatScaling::Fixed { .. } => m.iter().map(|&v| to_byte(v, fixed_k)).collect(),
        FloatScaling::PerFrameMinMax => {
            let min = m.iter().copied().fold(f64::INFINITY, f64::min);
            let max = m.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            if max - min < FLAT_RANGE {
                return vec![0; m.len()];
            }
            let k = 255.0 / (max - min);
            m.iter().map(|&v| to_byte(v - min, k)).collect()
        }
    }
}

/// The representation `F_R = [|v_d|, |v_c|, fⁿ]` (SPEC §4): RGB8, row-major,
/// `3 · width · height` bytes.
///
/// # Panics
/// If `prev` is not of the flow's size (it must be the frame the flow was
/// computed from).
pub fn representation(flow: &FloatFlow, prev: &Gray, scaling: FloatScaling) -> Vec<u8> {
    assert_eq!(
        prev.size(),
        (flow.width(), flow.height()),
        "prev must be the flow's frame n"
    );
    let (k_d, k_c) = match scaling {
        FloatScaling::Fixed { k_d, k_c } => (k_d, k_c),
        FloatScaling::PerFrameMinMax => (0.0, 0.0),
    };
    let (m_d, m_c) = flow.magnitudes();
    let (r, g) = (channel(&m_d, scaling, k_d), channel(&m_c, scaling, k_c));
    let mut rgb = Vec::with_capacity(3 * prev.pixels.len());
    for ((r, g), b) in r.into_iter().zip(g).zip(&prev.pixels) {
        rgb.extend_from_slice(&[r, g, *b]);
    }
    rgb
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gray(width: usize, height: usize, f: impl Fn(usize, usize) -> u8) -> Gray {
        let pixels = (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .map(|(x, y)| f(x, y))
            .collect();
        Gray::new(width, height, pixels).unwrap()
    }

    #[test]
    fn identical_frames_give_zero_fields() {
        let f = gray(9, 7, |x, y| (x * 37 + y * 11) as u8);
        let flow = compute(&f, &f, &FloatParams::default()).unwrap();
        for plane in [&flow.v_c.u, &flow.v_c.v, &flow.v_d.u, &flow.v_d.v] {
            assert!(plane.iter().all(|&v| v == 0.0));
        }
        let rep = representation(&flow, &f, FloatScaling::PerFrameMinMax);
        assert!(rep.chunks(3).zip(&f.pixels).all(|(p, &b)| p == [0, 0, b]));
    }

    #[test]
    fn mirroring_x_negates_the_x_components() {
        // Correlation with antisymmetric x kernels: a mirrored scene moving the
        // mirrored way gives mirrored fields, x components negated.
        let (w, h) = (13, 9);
        let a = gray(w, h, |x, y| ((x * x * 7 + y * 13 + x * y * 5) % 256) as u8);
        let b = gray(w, h, |x, y| {
            ((x * x * 5 + y * 17 + x * y * 3 + 40) % 256) as u8
        });
        let mirror = |g: &Gray| gray(w, h, |x, y| g.pixels[y * w + (w - 1 - x)]);
        let flow = compute(&a, &b, &FloatParams::default()).unwrap();
        let flip = compute(&mirror(&a), &mirror(&b), &FloatParams::default()).unwrap();
        let scale = flow
            .v_d
            .u
            .iter()
            .chain(&flow.v_d.v)
            .fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(scale > 0.0);
        for y in 0..h {
            for x in 0..w {
                let (i, j) = (y * w + x, y * w + (w - 1 - x));
                assert!((flow.v_c.u[i] + flip.v_c.u[j]).abs() <= 1e-12 * scale);
                assert!((flow.v_c.v[i] - flip.v_c.v[j]).abs() <= 1e-12 * scale);
                assert!((flow.v_d.u[i] + flip.v_d.u[j]).abs() <= 1e-12 * scale);
                assert!((flow.v_d.v[i] - flip.v_d.v[j]).abs() <= 1e-12 * scale);
            }
        }
    }

    #[test]
    fn refuses_mismatched_sizes_and_bad_params() {
        let a = gray(4, 3, |_, _| 0);
        let b = gray(3, 4, |_, _| 0);
        assert!(matches!(
            compute(&a, &b, &FloatParams::default()),
            Err(HostError::SizeMismatch { .. })
        ));
        let zero = FloatParams {
            lambda: 0.0,
            ..FloatParams::default()
        };
        assert!(matches!(
            compute(&a, &a, &zero),
            Err(HostError::Setting {
                setting: Setting::Lambda,
                ..
            })
        ));
        let nan = FloatParams {
            intensity_scale: f64::NAN,
            ..FloatParams::default()
        };
        assert!(matches!(
            compute(&a, &a, &nan),
            Err(HostError::Setting {
                setting: Setting::IntensityScale,
                ..
            })
        ));
    }

    #[test]
    fn bytes_round_half_up_and_saturate() {
        assert_eq!(to_byte(0.5, 1.0), 1);
        assert_eq!(to_byte(0.49, 1.0), 0);
        assert_eq!(to_byte(254.5, 1.0), 255);
        assert_eq!(to_byte(1e9, 1.0), 255);
        assert_eq!(
            channel(&[2.0, 2.0], FloatScaling::PerFrameMinMax, 0.0),
            vec![0, 0]
        );
        assert_eq!(
            channel(&[1.0, 3.0, 2.0], FloatScaling::PerFrameMinMax, 0.0),
            vec![0, 255, 128]
        );
    }

    #[test]
    fn a_min_max_range_below_the_flat_limit_gives_zero_bytes() {
        let minmax = |m: &[f64]| channel(m, FloatScaling::PerFrameMinMax, 0.0);
        // Residue-sized ranges are flat, even when far from 0 ...
        assert_eq!(minmax(&[0.0, 1.2e-15, 6e-16]), vec![0, 0, 0]);
        assert_eq!(minmax(&[3.0, 3.0 + 0.9e-9]), vec![0, 0]);
        // ... a range at the limit is stretched as usual.
        assert_eq!(minmax(&[0.0, 1e-9, 0.41e-9]), vec![0, 255, 105]);
        // A global +1 on texture: exact v_c is 0, f64 leaves residue; G is flat.
        let f0 = gray(24, 16, |x, y| (40 + (x * 29 + y * 53) % 170) as u8);
        let f1 = gray(24, 16, |x, y| f0.pixels[y * 24 + x] + 1);
        let flow = compute(&f0, &f1, &FloatParams::default()).unwrap();
        let (_, m_c) = flow.magnitudes();
        let residue = m_c.iter().copied().fold(0.0, f64::max);
        assert!(
            residue > 0.0 && residue < FLAT_RANGE,
            "|v_c| residue {residue:e}"
        );
        let rep = representation(&flow, &f0, FloatScaling::PerFrameMinMax);
        assert!(rep.chunks(3).all(|p| p[1] == 0));
    }
}

//! An output row's per-pixel tail (SPEC §3 steps 9–11): the regularised
//! 2×2 solve, the magnitudes and, for sinks that read them, the fields, in
//! IEEE binary32.
//!
//! Every step is one correctly rounded `f32` operation (`+ − × ÷ √` and
//! conversions from `i32`), written in a fixed order: no fused
//! multiply-add (Rust never contracts `a * b + c`; the M4F's `VMLA`, `kernels/m4.rs`,
//! is the unfused form), no library function but the square root, which IEEE
//! rounds correctly too (`kernels::fpu::sqrt`). So the hardware floats of x86-64,
//! aarch64 and the M4F and the software floats of the M0 and RV32 give the
//! same bits, and the row loop takes vector lanes where the target has them
//! (eight pixels per AVX2 instruction, `vdivps`, `vsqrtps`:
//! `kernels/avx2.rs`).
//!
//! Formats and bounds (integer inputs exact, from `stages`):
//!
//! | quantity | form | bound |
//! |---|---|---|
//! | `a4 = 4A + Λ4`, `c4`; `b4 = 4B` | `i32`, then `f32` | `4 · 266 342 400 + 2³⁰ < 2³¹` |
//! | `p, q` (summed in `f32`, `stages`) | `f32` | `256 · 1020 · 2²⁷ · 2⁻²⁰ = 2²⁵`; multiples of 2⁻²⁰ |
//! | `det = a4·c4 − b4²`, at least `Λ4²` | `f32` | `[1, 2⁶²]` (`b² ≤ ac`, Cauchy–Schwarz) |
//! | `N = (c4·p − b4·q, a4·q − b4·p)` | `f32` | `< 2⁵⁷`, `N² < 2¹¹⁵`; 0 or `≥ 2⁻⁴³` |
//! | `V` | `i32`, exactly `f32` | `< 2²³` |
//!
//! So nothing overflows and no value is subnormal: results do not depend
//! on a target's flush-to-zero setting. The determinant's clamp at `Λ4²`
//! (true for the exact value) keeps a rounded `det` positive for any
//! admissible `λ`. Rounding the inputs to 24 bits costs `v_d` about
//! `2⁻²³ · cond` of its value (`cond ≤ 2³⁰ / Λ4`, largest on straight
//! oblique edges at full contrast): at the SPEC's default parameters and
//! at `s = 1/1024, λ = 1e-6` well inside the tolerances
//! (`tests/tests/accuracy.rs`).

use crate::kernels::fpu::sqrt;
use crate::params::Units;
use crate::stages::{cut_rows, opaque};

/// The rows the tail reads, each from the first output column: the
/// structure sums `a, b, c` (exact integers) and `p, q` (`f32`), and `V`.
pub struct TailRows<'a> {
    /// `G256 ⋆ X²`, `G256 ⋆ XY`, `G256 ⋆ Y²`.
    pub abc: [&'a [i32]; 3],
    /// `G256 ⋆ (X · Dn′)`, `G256 ⋆ (Y · Dn′)`, scaled by 2⁻²⁰.
    pub pq: [&'a [f32]; 2],
    /// `V` (x, y).
    pub v: [&'a [i32]; 2],
}

/// The rows the tail writes, as long as the output: the magnitudes
/// `[|v_d|, |v_c|]` and, for sinks that read them, the fields
/// `[v_c x, v_c y, v_d x, v_d y]`, all in pixels.
pub struct TailOut<'a> {
    /// `|v_d|`, `|v_c|`.
    pub m: [&'a mut [f32]; 2],
    /// `v_c`, `v_d`, or `None` when no sink reads them.
    pub fields: Option<[&'a mut [f32]; 4]>,
    /// Whether the caller takes the magnitudes' extremes from a set that
    /// finds them as it writes them (`kernels::SumRings::tail_row`), where
    /// no fields are written: a sink that keeps the magnitudes for a
    /// per-frame min–max does; the others are spared them.
    // Read by the sets that find them (`kernels::blocked`'s, on x86-64
    // and aarch64); elsewhere the engine finds them.
    #[cfg_attr(
        not(any(
            target_arch = "x86_64",
            all(target_arch = "aarch64", target_feature = "neon")
        )),
        allow(dead_code)
    )]
    pub extremes: bool,
}

/// What the tail needs of the configuration.
#[derive(Clone, Copy)]
pub struct TailConstants {
    /// `Λ4`.
    pub lambda4: i32,
    /// The `f32` units.
    pub units: Units,
}

/// One pixel's solve: the numerators `N` and `1/det` in the units of
/// `v_d` (`v_d = N · inv`).
#[derive(Clone, Copy)]
struct Solved {
    n: [f32; 2],
    inv: f32,
}

/// The regularised solve of one pixel (module table for the bounds).
#[inline(always)]
fn solve(k: &TailConstants, [a, b, c]: [i32; 3], [p, q]: [f32; 2]) -> Solved {
    let a4 = (4 * a + k.lambda4) as f32;
    let c4 = (4 * c + k.lambda4) as f32;
    let b4 = (4 * b) as f32;
    let det = a4 * c4 - b4 * b4;
    // A select, not `f32::max`: no NaN can occur, and the plain compare is
    // one vector instruction (`maxps` takes NaNs its own way).
    let det = if det > k.units.det_floor {
        det
    } else {
        k.units.det_floor
    };
    Solved {
        n: [c4 * p - b4 * q, a4 * q - b4 * p],
        inv: k.units.v_d / det,
    }
}

/// `|v_d|` of a solve.
#[inline(always)]
fn divergence_free_magnitude(s: &Solved) -> f32 {
    let [x, y] = s.n;
    sqrt(x * x + y * y) * s.inv
}

/// `|v_c|` from `V`.
#[inline(always)]
fn curl_free_magnitude(k: &TailConstants, [x, y]: [f32; 2]) -> f32 {
    sqrt(x * x + y * y) * k.units.v_c
}

/// The tail of every pixel of `out`, the portable kernel (a kernel set
/// may override it, `kernels::KernelSet::tail_row`). Every row is as long
/// as `m_d` (the engine's are); should one be shorter, nothing is written.
#[inline(always)]
pub(crate) fn tail_row(k: &TailConstants, rows: &TailRows<'_>, out: TailOut<'_>) {
    let TailRows {
        abc: [a, b, c],
        pq: [p, q],
        v: [vx, vy],
    } = *rows;
    let (vx, vy) = (opaque(vx), opaque(vy));
    let TailOut {
        m: [m_d, m_c],
        fields,
        ..
    } = out;
    match fields {
        // Two instances, so that the magnitudes' loop writes nothing else.
        None => pixels_of::<false>(
            k,
            a,
            b,
            c,
            p,
            q,
            vx,
            vy,
            m_d,
            m_c,
            &mut [],
            &mut [],
            &mut [],
            &mut [],
        ),
        Some([v_c_x, v_c_y, v_d_x, v_d_y]) => pixels_of::<true>(
            k, a, b, c, p, q, vx, vy, m_d, m_c, v_c_x, v_c_y, v_d_x, v_d_y,
        ),
    }
}

/// The row loop: the magnitudes and, when `FIELDS`, the fields
/// `[v_c x, v_c y, v_d x, v_d y]` (empty otherwise).
///
/// Every row it writes is a `&mut` parameter of its own (in an array the
/// compiler loses their `noalias`), so it knows them apart once it inlines
/// this: no runtime alias checks, which would outnumber LLVM's limit and
/// keep the loop scalar (0 `vsqrtps` on x86-64 when the rows came as
/// arrays).
/// And every row is cut to one length here, in the function that indexes
/// it, so no index is bounds-checked on any target (`scripts/embedded-check`
/// walks the call graph for panics).
#[cfg_attr(dispatched_pass, inline(always))]
#[cfg_attr(not(dispatched_pass), inline(never))]
#[allow(clippy::too_many_arguments)]
fn pixels_of<const FIELDS: bool>(
    k: &TailConstants,
    a: &[i32],
    b: &[i32],
    c: &[i32],
    p: &[f32],
    q: &[f32],
    vx: &[i32],
    vy: &[i32],
    m_d: &mut [f32],
    m_c: &mut [f32],
    v_c_x: &mut [f32],
    v_c_y: &mut [f32],
    v_d_x: &mut [f32],
    v_d_y: &mut [f32],
) {
    let n = m_d.len();
    let f = if FIELDS { n } else { 0 };
    cut_rows!(n => a, b, c, vx, vy, p, q; mut m_c);
    cut_rows!(f => ; mut v_c_x, v_c_y, v_d_x, v_d_y);
    for i in 0..n {
        let solved = solve(k, [a[i], b[i], c[i]], [p[i], q[i]]);
        let v = [vx[i] as f32, vy[i] as f32];
        m_d[i] = divergence_free_magnitude(&solved);
        m_c[i] = curl_free_magnitude(k, v);
        if FIELDS {
            v_c_x[i] = v[0] * k.units.v_c;
            v_c_y[i] = v[1] * k.units.v_c;
            v_d_x[i] = solved.n[0] * solved.inv;
            v_d_y[i] = solved.n[1] * solved.inv;
        }
    }
}

#[cfg(test)]
mod tests {
    use std::vec::Vec;

    use super::*;
    use crate::{Config, IntensityScale, Params};
    use fixed::types::U32F32;

    fn constants(params: Params) -> TailConstants {
        let config = Config::new(8, 8, params).unwrap();
        TailConstants {
            lambda4: config.lambda4,
            units: config.units(),
        }
    }

    fn small_scale() -> Params {
        let scale = IntensityScale::new(1, 1024).unwrap();
        let lambda = U32F32::from_num(1e-6);
        Params { scale, lambda }
    }

    /// The f64 oracle of the solve in the SPEC's own units, with λ as the
    /// configuration rounded it (`Λ4`), so only the arithmetic is tested.
    fn oracle(params: Params, k: &TailConstants, abc: [i32; 3], pq: [f64; 2]) -> [f64; 2] {
        let s = f64::from(params.scale.num()) / f64::from(params.scale.den());
        let dn_shift = 8;
        let ua = s * s / 16384.0;
        let up = 2f64.powi(dn_shift + 20) * s * s * s / (8.0 * 6144.0 * 256.0);
        let lambda = f64::from(k.lambda4) / 4.0 * ua;
        let [a, b, c] = abc.map(f64::from);
        let (a, b, c) = (a * ua + lambda, b * ua, c * ua + lambda);
        let (p, q) = (pq[0] * up, pq[1] * up);
        let det = a * c - b * b;
        [(c * p - b * q) / det, (a * q - b * p) / det]
    }

    /// Sums built from 25 pixels of gradients and residuals, as the engine
    /// builds them (so `b² ≤ ac` holds and every value is in range).
    fn pixel_sums(seed: &mut u64, gmax: i64, dmax: i64) -> ([i32; 3], [f64; 2]) {
        let g = [1i64, 4, 6, 4, 1];
        let mut next = |range: i64| {
            *seed ^= *seed << 13;
            *seed ^= *seed >> 7;
            *seed ^= *seed << 17;
            (*seed % (2 * range as u64 + 1)) as i64 - range
        };
        let (mut abc, mut pq) = ([0i64; 3], [0i64; 2]);
        for j in 0..25 {
            let w = g[j / 5] * g[j % 5];
            let (x, y, dn) = (next(gmax), next(gmax), next(dmax));
            abc[0] += w * x * x;
            abc[1] += w * x * y;
            abc[2] += w * y * y;
            pq[0] += w * x * dn;
            pq[1] += w * y * dn;
        }
        let scaled = |v: i64| v as f64 * 2f64.powi(-20);
        (abc.map(|v| v as i32), pq.map(scaled))
    }

    /// The `f32` solve is the oracle's to a few units of 2⁻²⁴ of the
    /// oracle's own size, times the condition of the system (which the
    /// rounding of its inputs multiplies), on sums from flat to the largest
    /// gradients and residuals, at both parameter sets of the tolerances.
    #[test]
    fn solve_is_the_oracle_to_the_rounding_of_its_inputs() {
        for params in [Params::DEFAULT, small_scale()] {
            let k = constants(params);
            let mut seed = 0x2545_f491_4f6c_dd1du64;
            let mut worst = 0.0f64;
            for case in 0..20_000 {
                let (gmax, dmax) = [
                    (1020, 1i64 << 27),
                    (30, 1 << 20),
                    (3, 1 << 27),
                    (1020, 1000),
                    (0, 1 << 27),
                    (1, 1),
                ][case % 6];
                let (abc, pq) = pixel_sums(&mut seed, gmax, dmax);
                let solved = solve(&k, abc, pq.map(|v| v as f32));
                let got = solved.n.map(|n| f64::from(n * solved.inv));
                let want = oracle(params, &k, abc, pq);
                // The condition: largest over least eigenvalue of the system.
                let [a, b, c] = abc.map(|v| 4.0 * f64::from(v));
                let l = f64::from(k.lambda4);
                let (mean, half) = ((a + c) / 2.0, ((a - c).powi(2) / 4.0 + b * b).sqrt());
                let cond = (mean + half + l) / (mean - half + l);
                let norm = want[0].hypot(want[1]);
                let err = (got[0] - want[0]).hypot(got[1] - want[1]);
                let bound = 8.0 * 2f64.powi(-24) * cond * norm;
                assert!(
                    err <= bound + f64::MIN_POSITIVE,
                    "{abc:?} {pq:?}: error {err:e} of |v| {norm:e}, cond {cond:e}"
                );
                worst = worst.max(err / (2f64.powi(-24) * cond * norm).max(f64::MIN_POSITIVE));
                let m = f64::from(divergence_free_magnitude(&solved));
                assert!((m - got[0].hypot(got[1])).abs() <= 4.0 * 2f64.powi(-24) * m);
            }
            std::println!("solve: worst error {worst:.2} · 2⁻²⁴ · cond · |v|");
        }
    }

    /// Extreme sums stay finite and positive, with the clamp holding `det`
    /// at `Λ4²` where rounding would take it lower, at the smallest `λ`.
    #[test]
    fn extreme_sums_stay_finite() {
        // Λ4 = 1, the least the configuration admits.
        let tiny = Params {
            lambda: U32F32::from_bits(1 << 16),
            scale: IntensityScale::new(1, 1).unwrap(),
        };
        for params in [Params::DEFAULT, small_scale(), tiny] {
            let k = constants(params);
            let amax = 266_342_400i32;
            let pmax = 2f32.powi(25);
            for a in [0, 1, 1000, amax] {
                for c in [0, 7, amax] {
                    let bmax = ((f64::from(a) * f64::from(c)).sqrt()) as i32;
                    for b in [-bmax, 0, bmax / 2, bmax] {
                        for pq in [[-pmax, pmax], [0.0, 0.0], [pmax, 1.0], [2e-20, -pmax]] {
                            let solved = solve(&k, [a, b, c], pq);
                            let m = divergence_free_magnitude(&solved);
                            assert!(m.is_finite() && m >= 0.0, "{a} {b} {c} {pq:?}: {m}");
                            assert!(solved.inv > 0.0 && solved.inv.is_finite());
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn solve_is_odd_in_the_right_hand_side() {
        let k = constants(Params::DEFAULT);
        let (abc, pq) = ([5000, -1200, 900], [7535.25f32, -60.5]);
        let s = solve(&k, abc, pq);
        let neg = solve(&k, abc, pq.map(|v| -v));
        assert_eq!(neg.n, s.n.map(|n| -n));
        assert!(s.n[0] != 0.0 && s.n[1] != 0.0);
    }

    #[test]
    fn curl_free_magnitude_is_the_norm() {
        let k = constants(Params::DEFAULT);
        let unit = 1.0 / (768.0 * 255.0);
        assert_eq!(curl_free_magnitude(&k, [0.0, 0.0]), 0.0);
        let mut s = 12345u64;
        for case in 0..100_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let x = (s as i32 >> (case % 23 + 9)).clamp(-6_854_400, 6_854_400);
            let y = ((s >> 32) as i32 >> (case % 17 + 9)).clamp(-6_854_400, 6_854_400);
            let want = f64::from(x).hypot(f64::from(y)) * unit;
            let got = f64::from(curl_free_magnitude(&k, [x as f32, y as f32]));
            assert!((got - want).abs() <= want * 2f64.powi(-22), "{x} {y}");
        }
    }

    /// The row gives each pixel's values, fields only when asked for, for
    /// every length around the vector widths.
    #[test]
    fn a_row_is_its_pixels() {
        let k = constants(Params::DEFAULT);
        let mut seed = 0x0DDB_1A5E_5BAD_5EEDu64;
        for width in 0..=33 {
            let sums: Vec<_> = (0..width)
                .map(|_| pixel_sums(&mut seed, 1020, 1 << 20))
                .collect();
            let abc: [Vec<i32>; 3] =
                core::array::from_fn(|j| sums.iter().map(|s| s.0[j]).collect());
            let pq: [Vec<f32>; 2] =
                core::array::from_fn(|j| sums.iter().map(|s| s.1[j] as f32).collect());
            let v: [Vec<i32>; 2] = core::array::from_fn(|j| {
                (0..width as i32)
                    .map(|i| (i * 7919 + j as i32 * 104_729) % 6_854_400 - 3_000_000)
                    .collect()
            });
            let rows = TailRows {
                abc: abc.each_ref().map(|r| &r[..]),
                pq: pq.each_ref().map(|r| &r[..]),
                v: v.each_ref().map(|r| &r[..]),
            };
            for with_fields in [false, true] {
                let mut m: [Vec<f32>; 2] = core::array::from_fn(|_| std::vec![-1.0; width]);
                let mut f: [Vec<f32>; 4] = core::array::from_fn(|_| std::vec![-1.0; width]);
                let [f0, f1, f2, f3] = f.each_mut().map(|r| &mut r[..]);
                let out = TailOut {
                    m: m.each_mut().map(|r| &mut r[..]),
                    fields: with_fields.then_some([f0, f1, f2, f3]),
                    extremes: false,
                };
                tail_row(&k, &rows, out);
                for i in 0..width {
                    let s = solve(&k, sums[i].0, sums[i].1.map(|v| v as f32));
                    let vc = [v[0][i] as f32, v[1][i] as f32];
                    assert_eq!(m[0][i], divergence_free_magnitude(&s));
                    assert_eq!(m[1][i], curl_free_magnitude(&k, vc));
                    let want = if with_fields {
                        [
                            vc[0] * k.units.v_c,
                            vc[1] * k.units.v_c,
                            s.n[0] * s.inv,
                            s.n[1] * s.inv,
                        ]
                    } else {
                        [-1.0; 4]
                    };
                    assert_eq!([f[0][i], f[1][i], f[2][i], f[3][i]], want);
                }
            }
        }
    }
}

//! Error and agreement measures between an estimated flow and the ground
//! truth, taken over a set of pixels (sparse points or the dense interior).
//! Every function takes the vectors already gathered at those pixels.
//!
//! - **AEPE**, average endpoint error: `mean |w − w_gt|`, px.
//! - **AAE**, average angular error (Baker et al. 2011): the mean angle
//!   between the space-time vectors `(u, v, 1)` and `(u_gt, v_gt, 1)`,
//!   degrees.
//! - **R** (radial correlation; `R_sp` at sparse points): the Pearson
//!   correlation, over the points, between the radial component of the
//!   estimate `w · r̂` and that of the truth `w_gt · r̂`, with `r̂` the unit
//!   vector from the frame centre to the point. Scale-free, so it also
//!   grades fields that are not in pixels (`v_c`). Undefined (`None`) when
//!   the true radial component does not vary (its standard deviation is
//!   below 1 % of the mean true magnitude: rotation, still scenes) or the
//!   estimate's does not vary at all.
//! - **ACS**, angular cosine similarity: the mean over points with a
//!   non-zero true vector of `cos∠(w, w_gt) = w · w_gt / (|w| |w_gt|)`,
//!   counting 0 where the estimate is exactly zero (no direction given).
//!   `None` when no point moves.
//!
//! The paper names R_sp and ACS without formulas available to us; these are
//! our reading of them.

/// Average endpoint error, px. `NaN` for no points.
pub fn aepe(est: &[[f64; 2]], gt: &[[f64; 2]]) -> f64 {
    assert_eq!(est.len(), gt.len());
    let sum: f64 = est
        .iter()
        .zip(gt)
        .map(|(e, g)| (e[0] - g[0]).hypot(e[1] - g[1]))
        .sum();
    sum / est.len() as f64
}

/// Average angular error of `(u, v, 1)` against `(u_gt, v_gt, 1)`, degrees.
pub fn aae_degrees(est: &[[f64; 2]], gt: &[[f64; 2]]) -> f64 {
    assert_eq!(est.len(), gt.len());
    let sum: f64 = est
        .iter()
        .zip(gt)
        .map(|(e, g)| {
            let dot = e[0] * g[0] + e[1] * g[1] + 1.0;
            let ne = (e[0] * e[0] + e[1] * e[1] + 1.0).sqrt();
            let ng = (g[0] * g[0] + g[1] * g[1] + 1.0).sqrt();
            (dot / (ne * ng)).clamp(-1.0, 1.0).acos().to_degrees()
        })
        .sum();
    sum / est.len() as f64
}

/// Pearson correlation of two samples; `None` when either is constant.
pub fn pearson(a: &[f64], b: &[f64]) -> Option<f64> {
    assert_eq!(a.len(), b.len());
    let n = a.len() as f64;
    if a.len() < 2 {
        return None;
    }
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        let (dx, dy) = (x - ma, y - mb);
        sab += dx * dy;
        saa += dx * dx;
        sbb += dy * dy;
    }
    if saa <= 0.0 || sbb <= 0.0 {
        return None;
    }
    Some((sab / (saa.sqrt() * sbb.sqrt())).clamp(-1.0, 1.0))
}

/// Radial correlation R of the estimate with the truth at points whose
/// offsets from the frame centre are `offsets` (see the module doc).
pub fn radial_correlation(est: &[[f64; 2]], gt: &[[f64; 2]], offsets: &[[f64; 2]]) -> Option<f64> {
    assert!(est.len() == gt.len() && gt.len() == offsets.len());
    let (mut re, mut rg, mut mag) = (Vec::new(), Vec::new(), 0.0);
    for ((e, g), o) in est.iter().zip(gt).zip(offsets) {
        let r = o[0].hypot(o[1]);
        if r < 1e-9 {
            continue;
        }
        let (ux, uy) = (o[0] / r, o[1] / r);
        re.push(e[0] * ux + e[1] * uy);
        rg.push(g[0] * ux + g[1] * uy);
        mag += g[0].hypot(g[1]);
    }
    if rg.is_empty() {
        return None;
    }
    let n = rg.len() as f64;
    let mean = rg.iter().sum::<f64>() / n;
    let sd = (rg.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    if sd <= 0.01 * mag / n {
        return None;
    }
    pearson(&re, &rg)
}

/// Angular cosine similarity (see the module doc).
pub fn acs(est: &[[f64; 2]], gt: &[[f64; 2]]) -> Option<f64> {
    assert_eq!(est.len(), gt.len());
    let (mut sum, mut n) = (0.0, 0usize);
    for (e, g) in est.iter().zip(gt) {
        let ng = g[0].hypot(g[1]);
        if ng <= 1e-12 {
            continue;
        }
        n += 1;
        let ne = e[0].hypot(e[1]);
        if ne > 0.0 {
            sum += (e[0] * g[0] + e[1] * g[1]) / (ne * ng);
        }
    }
    (n > 0).then(|| sum / n as f64)
}

/// Mean Euclidean magnitude of the vectors.
pub fn mean_magnitude(w: &[[f64; 2]]) -> f64 {
    w.iter().map(|v| v[0].hypot(v[1])).sum::<f64>() / w.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    #[test]
    fn endpoint_error_of_known_vectors() {
        // |(3,4)−0| = 5, |(1,1)−(1,1)| = 0, |(0,−2)−(0,1)| = 3: mean 8/3.
        let est = [[3.0, 4.0], [1.0, 1.0], [0.0, -2.0]];
        let gt = [[0.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        assert!(close(aepe(&est, &gt), 8.0 / 3.0));
        assert!(close(aepe(&gt, &gt), 0.0));
    }

    #[test]
    fn angular_error_of_known_vectors() {
        // (1,0,1) against (0,0,1): 45°. (−1,0,1) against (1,0,1): 90°.
        assert!(close(aae_degrees(&[[1.0, 0.0]], &[[0.0, 0.0]]), 45.0));
        assert!(close(aae_degrees(&[[-1.0, 0.0]], &[[1.0, 0.0]]), 90.0));
        assert!(close(
            aae_degrees(&[[1.0, 0.0], [-1.0, 0.0]], &[[0.0, 0.0], [1.0, 0.0]]),
            67.5
        ));
        assert!(close(aae_degrees(&[[2.0, -3.0]], &[[2.0, -3.0]]), 0.0));
        // (0,1,1)·(1,0,1) = 1 over 2: 60°.
        assert!((aae_degrees(&[[0.0, 1.0]], &[[1.0, 0.0]]) - 60.0).abs() < 1e-9);
    }

    /// Offsets on a ring-and-spokes pattern and a zoom field on them.
    fn radial_points() -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
        let mut offsets = Vec::new();
        for r in [5.0, 10.0, 20.0, 40.0] {
            for k in 0..8 {
                let t = k as f64 * std::f64::consts::FRAC_PI_4;
                offsets.push([r * t.cos(), r * t.sin()]);
            }
        }
        let zoom = offsets.iter().map(|o| [0.02 * o[0], 0.02 * o[1]]).collect();
        (offsets, zoom)
    }

    #[test]
    fn radial_correlation_of_radial_fields() {
        let (offsets, zoom) = radial_points();
        // Perfect, and perfect up to a positive scale: 1.
        assert!(close(
            radial_correlation(&zoom, &zoom, &offsets).unwrap(),
            1.0
        ));
        let big: Vec<_> = zoom.iter().map(|w| [7.0 * w[0], 7.0 * w[1]]).collect();
        assert!(close(
            radial_correlation(&big, &zoom, &offsets).unwrap(),
            1.0
        ));
        // Zoom out against zoom in: −1.
        let neg: Vec<_> = zoom.iter().map(|w| [-w[0], -w[1]]).collect();
        assert!(close(
            radial_correlation(&neg, &zoom, &offsets).unwrap(),
            -1.0
        ));
        // A rotation has no radial part to correlate with: undefined.
        let rot: Vec<_> = offsets
            .iter()
            .map(|o| [-0.02 * o[1], 0.02 * o[0]])
            .collect();
        assert_eq!(radial_correlation(&zoom, &rot, &offsets), None);
        // A constant estimate correlates with nothing: undefined.
        let flat = vec![[1.0, 0.0]; offsets.len()];
        let radial_of_flat = radial_correlation(&flat, &zoom, &offsets);
        assert!(radial_of_flat.is_some_and(|r| r.abs() < 1e-12));
        let zero = vec![[0.0, 0.0]; offsets.len()];
        assert_eq!(radial_correlation(&zero, &zoom, &offsets), None);
    }

    #[test]
    fn cosine_similarity_of_identical_opposite_and_orthogonal_fields() {
        let (_, zoom) = radial_points();
        assert!(close(acs(&zoom, &zoom).unwrap(), 1.0));
        let neg: Vec<_> = zoom.iter().map(|w| [-3.0 * w[0], -3.0 * w[1]]).collect();
        assert!(close(acs(&neg, &zoom).unwrap(), -1.0));
        let ortho: Vec<_> = zoom.iter().map(|w| [-w[1], w[0]]).collect();
        assert!(acs(&ortho, &zoom).unwrap().abs() < 1e-12);
        // Zero estimates count 0; still truth gives no value.
        assert!(close(
            acs(&[[0.0, 0.0], [1.0, 0.0]], &[[1.0, 0.0], [1.0, 0.0]]).unwrap(),
            0.5
        ));
        assert_eq!(acs(&[[1.0, 0.0]], &[[0.0, 0.0]]), None);
        assert!(close(mean_magnitude(&[[3.0, 4.0], [0.0, 1.0]]), 3.0));
    }

    #[test]
    fn pearson_of_lines() {
        assert!(close(
            pearson(&[1.0, 2.0, 3.0], &[2.0, 4.0, 6.5 - 0.5]).unwrap(),
            1.0
        ));
        assert!(close(
            pearson(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]).unwrap(),
            -1.0
        ));
        assert_eq!(pearson(&[1.0, 1.0], &[1.0, 2.0]), None);
    }
}

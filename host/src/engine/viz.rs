//! The classic optical-flow colour coding (Middlebury, Baker et al. 2011,
//! `flowToColor`): hue is the direction of a flow vector, saturation its
//! length relative to a maximum radius. Right is red, down is green-yellow,
//! left is cyan, up is blue-violet (image coordinates, y down); zero flow is
//! white; vectors longer than the radius are drawn at 75 % brightness.

/// Segment lengths of the colour wheel: red–yellow, yellow–green,
/// green–cyan, cyan–blue, blue–magenta, magenta–red (55 colours).
const SEGMENTS: [usize; 6] = [15, 6, 4, 11, 13, 6];

/// The 55 colours of the Middlebury wheel, as its reference code builds
/// them (integer steps).
pub(crate) fn color_wheel() -> Vec<[u8; 3]> {
    let [ry, yg, gc, cb, bm, mr] = SEGMENTS;
    let step = |i: usize, n: usize| (255 * i / n) as u8;
    let mut wheel = Vec::with_capacity(SEGMENTS.iter().sum());
    wheel.extend((0..ry).map(|i| [255, step(i, ry), 0]));
    wheel.extend((0..yg).map(|i| [255 - step(i, yg), 255, 0]));
    wheel.extend((0..gc).map(|i| [0, 255, step(i, gc)]));
    wheel.extend((0..cb).map(|i| [0, 255 - step(i, cb), 255]));
    wheel.extend((0..bm).map(|i| [step(i, bm), 0, 255]));
    wheel.extend((0..mr).map(|i| [255, 0, 255 - step(i, mr)]));
    wheel
}

/// The colour of flow `(u, v)` already divided by the maximum radius.
fn color(wheel: &[[u8; 3]], u: f64, v: f64) -> [u8; 3] {
    let n = wheel.len();
    let rad = u.hypot(v);
    let a = (-v).atan2(-u) / std::f64::consts::PI;
    let fk = (a + 1.0) / 2.0 * (n - 1) as f64;
    let k0 = (fk.floor() as usize).min(n - 1);
    let k1 = (k0 + 1) % n;
    let f = fk - k0 as f64;
    std::array::from_fn(|b| {
        let c0 = f64::from(wheel[k0][b]) / 255.0;
        let c1 = f64::from(wheel[k1][b]) / 255.0;
        let mut c = (1.0 - f) * c0 + f * c1;
        if rad <= 1.0 {
            c = 1.0 - rad * (1.0 - c);
        } else {
            c *= 0.75;
        }
        (255.0 * c) as u8
    })
}

/// RGB8 colour coding of the flow planes `(u, v)`, normalised by
/// `max_radius` when given (the same scale for every frame of a video) or
/// else by the largest vector length of this frame (Middlebury's default).
/// Non-finite vectors are drawn black.
///
/// # Panics
/// If `u` and `v` differ in length.
pub(crate) fn flow_to_rgb(u: &[f64], v: &[f64], max_radius: Option<f64>) -> Vec<u8> {
    assert_eq!(u.len(), v.len(), "u and v must be planes of one size");
    let wheel = color_wheel();
    let max_rad = max_radius.unwrap_or_else(|| {
        u.iter()
            .zip(v)
            .map(|(a, b)| a.hypot(*b))
            .filter(|r| r.is_finite())
            .fold(0.0, f64::max)
    });
    let scale = if max_rad > 0.0 { 1.0 / max_rad } else { 0.0 };
    u.iter()
        .zip(v)
        .flat_map(|(&a, &b)| {
            if a.is_finite() && b.is_finite() {
                color(&wheel, a * scale, b * scale)
            } else {
                [0, 0, 0]
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wheel_directions_match_middlebury() {
        let wheel = color_wheel();
        assert_eq!(wheel.len(), 55);
        assert_eq!(wheel[0], [255, 0, 0]);
        let rgb = flow_to_rgb(
            &[1.0, 0.0, -1.0, 0.0, 0.0, 0.5, 2.0],
            &[0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 0.0],
            Some(1.0),
        );
        let px: Vec<&[u8]> = rgb.chunks(3).collect();
        // Right: red (atan2(-0, -1) = -pi: the wheel's first colour, as in the reference code).
        assert_eq!(px[0], [255, 0, 0]);
        // Down (y grows downward): green-yellow; left: cyan; up: blue-violet.
        assert!(px[1][1] > 200 && px[1][2] < 60, "{:?}", px[1]);
        assert!(
            px[2][0] < 20 && px[2][1] > 150 && px[2][2] == 255,
            "{:?}",
            px[2]
        );
        assert!(px[3][2] == 255 && px[3][1] < 20, "{:?}", px[3]);
        // No motion is white; half length is half saturated; beyond the radius is dimmed.
        assert_eq!(px[4], [255, 255, 255]);
        assert_eq!(px[5], [255, 127, 127]);
        assert_eq!(px[6], [191, 0, 0]);
        // Per-frame normalisation: the longest vector reaches full saturation.
        let auto = flow_to_rgb(&[3.0, 0.0], &[0.0, 0.0], None);
        assert_eq!(&auto[..3], [255, 0, 0]);
        assert_eq!(&auto[3..], [255, 255, 255]);
        assert_eq!(flow_to_rgb(&[0.0], &[0.0], None), [255, 255, 255]);
        assert_eq!(flow_to_rgb(&[f64::NAN], &[0.0], None), [0, 0, 0]);
    }
}

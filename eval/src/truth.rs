//! Exact ground truth: the camera pose of every frame as a similarity
//! transform of the scene plane, the analytic displacement of every pixel
//! between two poses, and the pixels the metrics are taken at (sparse
//! points and the dense interior).

use reynoldsflow_host::Flow;

/// Where the scene plane lands in frame n: `x = c + s·R(θ)·(p − c) + t`,
/// with `c` the frame centre, `s` the zoom, `θ` the rotation (positive turns
/// x towards y, i.e. clockwise on screen with y down) and `t` a shift.
/// Scene coordinates equal image coordinates at the identity pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Zoom factor `s` about the centre.
    pub scale: f64,
    /// Rotation `θ` about the centre, radians.
    pub angle: f64,
    /// Shift `t` in pixels.
    pub shift: [f64; 2],
    /// Centre `c` (the frame centre `((W−1)/2, (H−1)/2)`).
    pub centre: [f64; 2],
}

impl Pose {
    /// The identity pose about `centre`.
    pub fn identity(centre: [f64; 2]) -> Self {
        Self {
            scale: 1.0,
            angle: 0.0,
            shift: [0.0, 0.0],
            centre,
        }
    }

    /// Image position of scene point `p`.
    pub fn to_image(&self, p: [f64; 2]) -> [f64; 2] {
        let (s, c) = (self.angle.sin(), self.angle.cos());
        let (dx, dy) = (p[0] - self.centre[0], p[1] - self.centre[1]);
        [
            self.centre[0] + self.scale * (c * dx - s * dy) + self.shift[0],
            self.centre[1] + self.scale * (s * dx + c * dy) + self.shift[1],
        ]
    }

    /// Scene point seen at image position `x` (the inverse of
    /// [`to_image`](Self::to_image)).
    pub fn to_scene(&self, x: [f64; 2]) -> [f64; 2] {
        let (s, c) = (self.angle.sin(), self.angle.cos());
        let dx = (x[0] - self.shift[0] - self.centre[0]) / self.scale;
        let dy = (x[1] - self.shift[1] - self.centre[1]) / self.scale;
        [
            self.centre[0] + c * dx + s * dy,
            self.centre[1] - s * dx + c * dy,
        ]
    }
}

/// The true displacement of every pixel of a frame at pose `a` to the
/// frame at pose `b`: `u(x) = b(a⁻¹(x)) − x`. For a zoom by `k` about the
/// centre this is `(k − 1)(x − c)`; for a shift, the shift.
pub fn flow_between(a: &Pose, b: &Pose, width: usize, height: usize) -> Flow {
    let mut flow = Flow::zeros(width, height);
    for y in 0..height {
        for x in 0..width {
            let p = [x as f64, y as f64];
            let q = b.to_image(a.to_scene(p));
            let i = y * width + x;
            flow.u[i] = q[0] - p[0];
            flow.v[i] = q[1] - p[1];
        }
    }
    flow
}

/// Border, in pixels, that the dense metrics leave out (at least 8, and
/// beyond ReynoldsFlow's 7-px halo and the Lucas–Kanade window).
pub const BORDER: usize = 10;

/// Is pixel `(x, y)` at least [`BORDER`] px inside a `width × height` frame?
pub fn in_interior(x: f64, y: f64, width: usize, height: usize) -> bool {
    let b = BORDER as f64;
    x >= b && y >= b && x <= (width - 1) as f64 - b && y <= (height - 1) as f64 - b
}

/// Row-major indices of the dense interior.
pub fn interior(width: usize, height: usize) -> Vec<usize> {
    (BORDER..height.saturating_sub(BORDER))
        .flat_map(|y| (BORDER..width.saturating_sub(BORDER)).map(move |x| y * width + x))
        .collect()
}

/// Sparse points of a frame: the given image positions rounded to the
/// nearest pixel, kept when inside the interior, deduplicated.
pub fn sparse_pixels(positions: &[[f64; 2]], width: usize, height: usize) -> Vec<usize> {
    let mut out: Vec<usize> = positions
        .iter()
        .map(|p| [p[0].round(), p[1].round()])
        .filter(|p| in_interior(p[0], p[1], width, height))
        .map(|p| p[1] as usize * width + p[0] as usize)
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// A regular `nx × ny` grid of positions spread over the interior (the
/// sparse points of scenes without corners).
pub fn grid_positions(nx: usize, ny: usize, width: usize, height: usize) -> Vec<[f64; 2]> {
    let b = BORDER as f64;
    let span = |n: usize, len: usize, i: usize| {
        let inner = (len - 1) as f64 - 2.0 * b;
        b + inner * (i as f64 + 0.5) / n as f64
    };
    (0..ny)
        .flat_map(|j| (0..nx).map(move |i| [span(nx, width, i), span(ny, height, j)]))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zoom_flow_is_radial_and_linear() {
        let c = [9.5, 7.0];
        let a = Pose {
            scale: 1.1,
            ..Pose::identity(c)
        };
        let b = Pose {
            scale: 1.1 * 1.02,
            ..Pose::identity(c)
        };
        let f = flow_between(&a, &b, 20, 15);
        for y in 0..15 {
            for x in 0..20 {
                let i = y * 20 + x;
                assert!((f.u[i] - 0.02 * (x as f64 - c[0])).abs() < 1e-12);
                assert!((f.v[i] - 0.02 * (y as f64 - c[1])).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn poses_invert_and_rotation_turns_x_towards_y() {
        let pose = Pose {
            scale: 0.9,
            angle: 0.3,
            shift: [1.5, -2.0],
            centre: [10.0, 8.0],
        };
        let p = [3.0, 17.0];
        let back = pose.to_scene(pose.to_image(p));
        assert!((back[0] - p[0]).abs() < 1e-12 && (back[1] - p[1]).abs() < 1e-12);
        let quarter = Pose {
            angle: std::f64::consts::FRAC_PI_2,
            ..Pose::identity([0.0, 0.0])
        };
        let q = quarter.to_image([1.0, 0.0]);
        assert!(q[0].abs() < 1e-12 && (q[1] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn sparse_points_stay_inside() {
        let pts = sparse_pixels(
            &[[0.0, 0.0], [10.4, 10.6], [10.0, 11.0], [50.0, 50.0]],
            40,
            30,
        );
        assert_eq!(pts, vec![11 * 40 + 10]);
        assert_eq!(interior(30, 25).len(), 10 * 5);
        let grid = grid_positions(3, 2, 40, 30);
        assert_eq!(grid.len(), 6);
        assert!(grid.iter().all(|p| in_interior(p[0], p[1], 40, 30)));
    }
}

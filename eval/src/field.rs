//! Dense float planes and flow fields, and the few image operations the
//! baselines share (Sobel gradient, window sums, bilinear reads). Borders
//! replicate, as the SPEC's input clamp does.

use reynoldsflow_host::Gray;

/// A row-major float plane of `width · height` values.
#[derive(Clone, Debug, PartialEq)]
pub struct Plane {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Values, row `y` at `y · width`.
    pub data: Vec<f64>,
}

impl Plane {
    /// `f(x, y)` over `width × height`.
    pub fn from_fn(width: usize, height: usize, mut f: impl FnMut(usize, usize) -> f64) -> Self {
        let mut data = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                data.push(f(x, y));
            }
        }
        Self {
            width,
            height,
            data,
        }
    }

    /// A frame's pixels as gray levels `0.0 ..= 255.0`.
    pub fn from_gray(g: &Gray) -> Self {
        Self {
            width: g.width,
            height: g.height,
            data: g.pixels.iter().map(|&p| f64::from(p)).collect(),
        }
    }

    /// The value at `(x, y)`, or at the nearest pixel inside the plane.
    pub fn clamped(&self, x: isize, y: isize) -> f64 {
        let x = x.clamp(0, self.width as isize - 1) as usize;
        let y = y.clamp(0, self.height as isize - 1) as usize;
        self.data[y * self.width + x]
    }

    /// Bilinear interpolation at `(x, y)` (pixel centres at integers), with
    /// replicated borders.
    pub fn bilinear(&self, x: f64, y: f64) -> f64 {
        let (x0, y0) = (x.floor(), y.floor());
        let (ax, ay) = (x - x0, y - y0);
        let (xi, yi) = (x0 as isize, y0 as isize);
        let top = (1.0 - ax) * self.clamped(xi, yi) + ax * self.clamped(xi + 1, yi);
        let bottom = (1.0 - ax) * self.clamped(xi, yi + 1) + ax * self.clamped(xi + 1, yi + 1);
        (1.0 - ay) * top + ay * bottom
    }

    /// `f` of every value.
    pub fn map(&self, f: impl Fn(f64) -> f64) -> Self {
        Self {
            data: self.data.iter().map(|&v| f(v)).collect(),
            ..*self
        }
    }

    /// `f(a, b)` of the values at the same pixel of two planes of one size.
    pub fn zip(&self, other: &Self, f: impl Fn(f64, f64) -> f64) -> Self {
        assert_eq!(
            (self.width, self.height),
            (other.width, other.height),
            "planes of different sizes"
        );
        Self {
            data: self
                .data
                .iter()
                .zip(&other.data)
                .map(|(&a, &b)| f(a, b))
                .collect(),
            ..*self
        }
    }

    /// Sum over the `(2r + 1)²` window centred on each pixel, borders
    /// replicated; separable running sums, `O(width · height)`.
    pub fn box_sum(&self, r: usize) -> Self {
        let (w, h) = (self.width, self.height);
        let ri = r as isize;
        let mut rows = vec![0.0; w * h];
        for y in 0..h {
            let at = |x: isize| self.clamped(x, y as isize);
            let mut sum: f64 = (-ri..=ri).map(at).sum();
            for x in 0..w {
                rows[y * w + x] = sum;
                let xi = x as isize;
                sum += at(xi + ri + 1) - at(xi - ri);
            }
        }
        let rows = Self {
            width: w,
            height: h,
            data: rows,
        };
        let mut out = vec![0.0; w * h];
        for x in 0..w {
            let at = |y: isize| rows.clamped(x as isize, y);
            let mut sum: f64 = (-ri..=ri).map(at).sum();
            for y in 0..h {
                out[y * w + x] = sum;
                let yi = y as isize;
                sum += at(yi + ri + 1) - at(yi - ri);
            }
        }
        Self {
            width: w,
            height: h,
            data: out,
        }
    }

    /// `(∂x, ∂y)` as Sobel / 8 (SPEC §3 step 5), borders replicated.
    pub fn sobel_gradient(&self) -> (Self, Self) {
        let p = |x: usize, y: usize, dx: isize, dy: isize| {
            self.clamped(x as isize + dx, y as isize + dy)
        };
        let gx = Self::from_fn(self.width, self.height, |x, y| {
            (p(x, y, 1, -1) + 2.0 * p(x, y, 1, 0) + p(x, y, 1, 1)
                - p(x, y, -1, -1)
                - 2.0 * p(x, y, -1, 0)
                - p(x, y, -1, 1))
                / 8.0
        });
        let gy = Self::from_fn(self.width, self.height, |x, y| {
            (p(x, y, -1, 1) + 2.0 * p(x, y, 0, 1) + p(x, y, 1, 1)
                - p(x, y, -1, -1)
                - 2.0 * p(x, y, 0, -1)
                - p(x, y, 1, -1))
                / 8.0
        });
        (gx, gy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_sums_match_a_direct_sum() {
        let p = Plane::from_fn(7, 5, |x, y| (x * 3 + y * 7 % 5) as f64);
        let s = p.box_sum(2);
        for y in 0..5isize {
            for x in 0..7isize {
                let mut direct = 0.0;
                for j in -2..=2 {
                    for i in -2..=2 {
                        direct += p.clamped(x + i, y + j);
                    }
                }
                assert!((s.data[y as usize * 7 + x as usize] - direct).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn gradient_of_a_ramp_and_bilinear_reads() {
        let p = Plane::from_fn(6, 6, |x, y| 2.0 * x as f64 - 3.0 * y as f64);
        let (gx, gy) = p.sobel_gradient();
        // Interior pixels see the exact slope.
        assert_eq!(gx.data[2 * 6 + 2], 2.0);
        assert_eq!(gy.data[2 * 6 + 2], -3.0);
        assert!((p.bilinear(2.5, 1.25) - (5.0 - 3.75)).abs() < 1e-12);
        // Outside: replicated border.
        assert_eq!(p.bilinear(-4.0, 0.0), 0.0);
    }
}

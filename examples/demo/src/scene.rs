//! The synthetic scene: a sky gradient with drifting clouds, seen by a
//! shaking camera, with a small dark drone crossing it; and a static
//! textured scene under changing light, for counting false motion cues.
//!
//! Everything is a continuous function of world coordinates, sampled at
//! pixel centres after the camera's (sub-pixel) shake, so the drone's true
//! pixel box in every frame follows analytically ([`Scene::drone_box`]).

/// A pixel box, inclusive on every side (like the core's `Region`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelBox {
    /// Leftmost column.
    pub x_min: i32,
    /// Top row.
    pub y_min: i32,
    /// Rightmost column (inclusive).
    pub x_max: i32,
    /// Bottom row (inclusive).
    pub y_max: i32,
}

impl PixelBox {
    /// The smallest box holding both.
    pub fn union(self, other: PixelBox) -> PixelBox {
        PixelBox {
            x_min: self.x_min.min(other.x_min),
            y_min: self.y_min.min(other.y_min),
            x_max: self.x_max.max(other.x_max),
            y_max: self.y_max.max(other.y_max),
        }
    }

    /// The largest distance between corresponding sides, px.
    pub fn max_side_error(self, other: PixelBox) -> i32 {
        [
            self.x_min - other.x_min,
            self.y_min - other.y_min,
            self.x_max - other.x_max,
            self.y_max - other.y_max,
        ]
        .into_iter()
        .map(i32::abs)
        .max()
        .unwrap_or(0)
    }

    /// Whether the box lies inside a `w × h` frame, `margin` px from its edges.
    pub fn inside(self, w: usize, h: usize, margin: i32) -> bool {
        self.x_min >= margin
            && self.y_min >= margin
            && self.x_max < w as i32 - margin
            && self.y_max < h as i32 - margin
    }
}

/// A tiny counter-based generator: the same numbers on every platform.
fn hash(mut x: u64) -> u64 {
    x ^= x >> 33;
    x = x.wrapping_mul(0xff51_afd7_ed55_8ccd);
    x ^= x >> 33;
    x = x.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    x ^ (x >> 33)
}

/// Uniform in [−1, 1) from a counter.
fn unit(x: u64) -> f64 {
    (hash(x) >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// The drone scene. Defaults: 160 × 120 px (a quarter of a 320 × 240
/// screen), a 5 × 3 px drone at gray 40 crossing the sky at 2.2 px/frame.
#[derive(Clone, Copy, Debug)]
pub struct Scene {
    /// Frame width, px.
    pub width: usize,
    /// Frame height, px.
    pub height: usize,
    /// Peak camera shake along each axis, px (sub-pixel, per frame).
    pub shake: f64,
    /// Sensor noise, uniform ± this many gray levels, new every frame.
    pub noise: f64,
    /// Drone size, px.
    pub drone_size: (f64, f64),
    /// Drone gray level.
    pub drone_gray: f64,
    /// Drone speed in the world, px/frame (x).
    pub drone_speed: f64,
}

impl Default for Scene {
    fn default() -> Self {
        Self {
            width: 160,
            height: 120,
            shake: 2.0,
            noise: 1.5,
            drone_size: (5.0, 3.0),
            drone_gray: 40.0,
            drone_speed: 2.2,
        }
    }
}

/// Cloud puffs: (centre x, centre y, σx, σy, brightness), world px.
const CLOUDS: [(f64, f64, f64, f64, f64); 9] = [
    (20.0, 22.0, 14.0, 6.0, 34.0),
    (36.0, 18.0, 10.0, 7.0, 30.0),
    (50.0, 24.0, 12.0, 5.0, 26.0),
    (96.0, 70.0, 18.0, 7.0, 32.0),
    (116.0, 64.0, 12.0, 8.0, 36.0),
    (132.0, 72.0, 10.0, 5.0, 24.0),
    (150.0, 30.0, 16.0, 6.0, 28.0),
    (60.0, 96.0, 20.0, 6.0, 22.0),
    (176.0, 100.0, 14.0, 6.0, 30.0),
];

impl Scene {
    /// The camera's offset in frame `n` (world = screen + offset), px: two
    /// incommensurate sines per axis, so the shake never repeats exactly.
    pub fn camera(&self, n: usize) -> (f64, f64) {
        let t = n as f64;
        (
            self.shake * (0.6 * (0.9 * t).sin() + 0.4 * (2.3 * t + 1.0).sin()),
            self.shake * (0.6 * (1.3 * t + 0.5).sin() + 0.4 * (3.1 * t).sin()),
        )
    }

    /// The drone's top-left corner in world coordinates in frame `n`: it
    /// enters at the left edge and bobs gently up and down.
    pub fn drone_world(&self, n: usize) -> (f64, f64) {
        let t = n as f64;
        (
            -8.0 + self.drone_speed * t,
            0.35 * self.height as f64 + 5.0 * (0.15 * t).sin(),
        )
    }

    /// The drone's rectangle on screen in frame `n`: `[x0, x1) × [y0, y1)`.
    fn drone_rect(&self, n: usize) -> (f64, f64, f64, f64) {
        let (cx, cy) = self.camera(n);
        let (wx, wy) = self.drone_world(n);
        let (x0, y0) = (wx - cx, wy - cy);
        (x0, y0, x0 + self.drone_size.0, y0 + self.drone_size.1)
    }

    /// The pixels the drone covers (any part of) in frame `n`.
    pub fn drone_box(&self, n: usize) -> PixelBox {
        let (x0, y0, x1, y1) = self.drone_rect(n);
        PixelBox {
            x_min: x0.floor() as i32,
            y_min: y0.floor() as i32,
            x_max: x1.ceil() as i32 - 1,
            y_max: y1.ceil() as i32 - 1,
        }
    }

    /// The true box of the drone's motion between frames `n` and `n + 1`:
    /// every pixel whose value the drone changes, i.e. the union of its
    /// boxes in both frames.
    pub fn motion_box(&self, n: usize) -> PixelBox {
        self.drone_box(n).union(self.drone_box(n + 1))
    }

    /// Whether the drone is fully on screen, `margin` px from the edges, in
    /// both frames of pair `n`.
    pub fn drone_visible(&self, n: usize, margin: i32) -> bool {
        self.drone_box(n).inside(self.width, self.height, margin)
            && self
                .drone_box(n + 1)
                .inside(self.width, self.height, margin)
    }

    /// The sky at world point `(x, y)`: a vertical gradient and soft clouds
    /// drifting right at 0.4 px/frame.
    fn sky(&self, x: f64, y: f64, n: usize) -> f64 {
        let h = self.height as f64;
        let mut v = 120.0 + 80.0 * (y / h);
        let drift = 0.4 * n as f64;
        for (cx, cy, sx, sy, b) in CLOUDS {
            // Wrap the drift around a strip wider than the frame.
            let span = self.width as f64 + 60.0;
            let cx = (cx + drift + 30.0).rem_euclid(span) - 30.0;
            let (dx, dy) = ((x - cx) / sx, (y - cy) / sy);
            v += b * (-0.5 * (dx * dx + dy * dy)).exp();
        }
        v
    }

    /// Frame `n`, row-major 8-bit gray.
    pub fn frame(&self, n: usize) -> Vec<u8> {
        let (w, h) = (self.width, self.height);
        let (cx, cy) = self.camera(n);
        let (x0, y0, x1, y1) = self.drone_rect(n);
        let overlap = |a: f64, b: f64, lo: f64, hi: f64| (b.min(hi) - a.max(lo)).max(0.0);
        let mut out = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                let (xf, yf) = (x as f64, y as f64);
                let sky = self.sky(xf + 0.5 + cx, yf + 0.5 + cy, n);
                // Area of the pixel the drone covers.
                let cover = overlap(xf, xf + 1.0, x0, x1) * overlap(yf, yf + 1.0, y0, y1);
                let v = sky * (1.0 - cover) + self.drone_gray * cover;
                let noise = self.noise * unit((n * w * h + y * w + x) as u64 ^ 0x5eed);
                out.push((v + noise).round().clamp(0.0, 255.0) as u8);
            }
        }
        out
    }
}

/// How the light changes over the static scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lighting {
    /// Nothing changes (only sensor noise).
    Constant,
    /// A global gain ramp: frame `n` is `1 + rate · n` times as bright.
    Gain {
        /// Relative change per frame (e.g. 0.02 for 2 %).
        rate: f64,
    },
    /// A bright Gaussian spot (a moving light or a sun glint) added to the
    /// texture, moving right at `speed` px/frame.
    MovingLight {
        /// Added gray level at the spot's centre.
        peak: f64,
        /// Spot σ, px.
        sigma: f64,
        /// px/frame.
        speed: f64,
    },
}

/// Frame `n` of a static textured scene (no object moves, the camera is
/// still) under `lighting`: a blend of gradients and mid-frequency texture
/// around gray 110, with the same sensor noise as [`Scene`].
pub fn static_frame(w: usize, h: usize, n: usize, lighting: Lighting, noise: f64) -> Vec<u8> {
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let (xf, yf) = (x as f64, y as f64);
            let texture = 110.0
                + 30.0 * (xf * 0.21 + 0.7 * (yf * 0.09).sin()).sin()
                + 20.0 * (yf * 0.17 + xf * 0.05).cos()
                + 12.0 * unit((y * 977 + x) as u64).signum() * (xf * 0.5).sin().abs();
            let lit = match lighting {
                Lighting::Constant => texture,
                Lighting::Gain { rate } => texture * (1.0 + rate * n as f64),
                Lighting::MovingLight { peak, sigma, speed } => {
                    let cx = 20.0 + speed * n as f64;
                    let cy = 0.5 * h as f64;
                    let d2 = ((xf - cx).powi(2) + (yf - cy).powi(2)) / (sigma * sigma);
                    texture + peak * (-0.5 * d2).exp()
                }
            };
            let noise = noise * unit((n * w * h + y * w + x) as u64 ^ 0x11);
            out.push((lit + noise).round().clamp(0.0, 255.0) as u8);
        }
    }
    out
}

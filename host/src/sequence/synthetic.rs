//! The built-in demo sequence: what `reynoldsflow run` shows with no
//! input. A 320×240 outdoor-like scene (sky with clouds, hills, a textured
//! field with furrows) seen by a camera that pans slowly right and down,
//! with a shaded, textured ball rolling across it faster and a dark box
//! sliding the other way, plus a little sensor noise. Every pixel is a pure
//! function of `(x, y, t)`, so the frames are the same on every machine.

use super::{Frame, FrameSource, index_stem};
use crate::Gray;

/// Demo frame width.
pub const WIDTH: usize = 320;
/// Demo frame height.
pub const HEIGHT: usize = 240;
/// Demo frames.
pub const FRAMES: usize = 24;

/// A 32-bit integer hash (lowbias32), for lattice noise.
fn hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// Value at an integer lattice point, in `[0, 1)`.
fn lattice(ix: i64, iy: i64, seed: u32) -> f64 {
    let h = hash((ix as u32) ^ hash((iy as u32) ^ hash(seed)));
    f64::from(h >> 8) / f64::from(1u32 << 24)
}

/// Smooth value noise in `[0, 1)`.
fn noise(x: f64, y: f64, seed: u32) -> f64 {
    let (fx, fy) = (x.floor(), y.floor());
    let (ix, iy) = (fx as i64, fy as i64);
    let s = |t: f64| t * t * (3.0 - 2.0 * t);
    let (tx, ty) = (s(x - fx), s(y - fy));
    let a = lattice(ix, iy, seed) * (1.0 - tx) + lattice(ix + 1, iy, seed) * tx;
    let b = lattice(ix, iy + 1, seed) * (1.0 - tx) + lattice(ix + 1, iy + 1, seed) * tx;
    a * (1.0 - ty) + b * ty
}

/// Fractal noise: `octaves` layers of halving amplitude, in `[0, 1)`.
fn fbm(x: f64, y: f64, seed: u32, octaves: u32) -> f64 {
    let (mut sum, mut amp, mut freq, mut norm) = (0.0, 1.0, 1.0, 0.0);
    for o in 0..octaves {
        sum += amp * noise(x * freq, y * freq, seed.wrapping_add(o));
        norm += amp;
        amp *= 0.5;
        freq *= 2.0;
    }
    sum / norm
}

/// The static world at world coordinates `(u, v)`: sky, hills, field.
fn world(u: f64, v: f64) -> f64 {
    let hills = 95.0 + 18.0 * fbm(u / 90.0, 0.5, 11, 3) + 6.0 * (u / 37.0).sin();
    if v < hills {
        // Sky: brighter towards the horizon, with soft clouds.
        let cloud = fbm(u / 60.0, v / 25.0, 3, 5);
        let cloud = ((cloud - 0.45) * 3.0).clamp(0.0, 1.0);
        return 150.0 + 0.35 * v + 70.0 * cloud;
    }
    // Ground: furrows converging in perspective, grassy texture, darker near.
    let depth = (v - hills + 8.0).max(1.0);
    let furrow = (0.5 + 0.5 * ((u - 160.0) / depth * 9.0).sin()).powf(2.0);
    let grass = fbm(u / 7.0, v / 5.0, 7, 4);
    let patches = fbm(u / 45.0, v / 30.0, 5, 3);
    55.0 + 70.0 * grass + 30.0 * furrow + 40.0 * patches - 0.12 * (v - hills)
}

/// Coverage of a disk edge at signed distance `d` (pixels outside is > 0).
fn coverage(d: f64) -> f64 {
    (0.5 - d).clamp(0.0, 1.0)
}

/// Camera pan per frame: the view slides right and down over the world.
const PAN: (f64, f64) = (0.8, 0.25);

/// The static world rendered once at integer points, sampled bilinearly
/// (as a camera's pixels integrate the scene) for sub-pixel pans.
struct World {
    width: usize,
    values: Vec<f32>,
}

impl World {
    fn new() -> Self {
        let width = WIDTH + (PAN.0 * FRAMES as f64).ceil() as usize + 2;
        let height = HEIGHT + (PAN.1 * FRAMES as f64).ceil() as usize + 2;
        let values = (0..height)
            .flat_map(|v| (0..width).map(move |u| world(u as f64, v as f64) as f32))
            .collect();
        Self { width, values }
    }

    fn sample(&self, u: f64, v: f64) -> f64 {
        let (fu, fv) = (u.floor(), v.floor());
        let (i, j) = (fu as usize, fv as usize);
        let (a, b) = (u - fu, v - fv);
        let at = |i: usize, j: usize| f64::from(self.values[j * self.width + i]);
        let top = at(i, j) * (1.0 - a) + at(i + 1, j) * a;
        let bottom = at(i, j + 1) * (1.0 - a) + at(i + 1, j + 1) * a;
        top * (1.0 - b) + bottom * b
    }
}

/// The pixel value at frame coordinates `(x, y)` of frame `t`.
fn pixel(world: &World, x: f64, y: f64, t: f64) -> u8 {
    let (pan_x, pan_y) = (PAN.0 * t, PAN.1 * t);
    let mut value = world.sample(x + pan_x, y + pan_y);

    // A box sliding left, in world coordinates (so the pan moves it too).
    let (bx, by) = (250.0 - 1.5 * t, 120.0);
    let (du, dv) = ((x + pan_x - bx).abs() - 24.0, (y + pan_y - by).abs() - 15.0);
    let box_alpha = if du.max(dv) < 1.0 {
        coverage(du.max(dv))
    } else {
        0.0
    };
    if box_alpha > 0.0 {
        let lx = x + pan_x - bx;
        let stripes = if (lx / 6.0).floor() as i64 % 2 == 0 {
            0.0
        } else {
            18.0
        };
        let shade = 45.0 + stripes + 25.0 * fbm(lx / 5.0, (y + pan_y) / 5.0, 21, 3);
        value = value * (1.0 - box_alpha) + shade * box_alpha;
    }

    // A ball rolling right and bouncing gently, in frame coordinates.
    let (cx, cy, r) = (40.0 + 7.0 * t, 170.0 - 28.0 * (t / 7.0).sin().abs(), 26.0);
    let (dx, dy) = (x - cx, y - cy);
    let dist = (dx * dx + dy * dy).sqrt();
    let alpha = coverage(dist - r);
    if alpha > 0.0 {
        // Lambert shading from the upper left, texture rotating with the roll.
        let nz = (1.0 - (dist / r).min(1.0).powi(2)).sqrt();
        let light = (0.25 + 0.75 * ((-0.5 * dx - 0.6 * dy) / r + 0.6 * nz).max(0.0)).min(1.2);
        let angle = -7.0 * t / r;
        let (s, c) = angle.sin_cos();
        let (tx, ty) = (c * dx - s * dy, s * dx + c * dy);
        let texture = fbm(tx / 6.0, ty / 6.0, 31, 3);
        let ball = (210.0 * light) * (0.7 + 0.45 * texture);
        value = value * (1.0 - alpha) + ball * alpha;
    }

    // Sensor noise of about ±2 levels, different in every frame.
    let n = lattice(x as i64 * 7919 + y as i64, t as i64, 97) - 0.5;
    (value + 4.0 * n).round().clamp(0.0, 255.0) as u8
}

fn render(world: &World, t: usize) -> Gray {
    let pixels = (0..HEIGHT)
        .flat_map(|y| (0..WIDTH).map(move |x| pixel(world, x as f64, y as f64, t as f64)))
        .collect();
    Gray::new(WIDTH, HEIGHT, pixels).expect("the demo size is valid")
}

/// Frame `t` (below [`FRAMES`]) of the demo.
pub fn frame(t: usize) -> Gray {
    render(&World::new(), t)
}

/// The demo as a frame source: frames are generated as they are asked for.
pub struct Demo {
    world: World,
    next: usize,
}

impl Demo {
    /// The sequence from its first frame.
    pub fn new() -> Self {
        Self {
            world: World::new(),
            next: 0,
        }
    }
}

impl Default for Demo {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameSource for Demo {
    fn next_frame(&mut self) -> Result<Option<Frame>, crate::HostError> {
        if self.next == FRAMES {
            return Ok(None);
        }
        let t = self.next;
        self.next += 1;
        Ok(Some(Frame {
            gray: render(&self.world, t),
            stem: index_stem(t),
            index: t,
        }))
    }

    fn frame_count_hint(&self) -> Option<usize> {
        Some(FRAMES)
    }

    fn frame_rate(&self) -> Option<(u32, u32)> {
        Some((12, 1))
    }
}

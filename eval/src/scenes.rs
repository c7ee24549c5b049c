//! The controlled scenes of the evaluation: two patterns on the scene
//! plane (the paper's 13 × 12 checkerboard target and a smooth multi-octave
//! noise texture), six scenarios (zoom in, zoom out, rotation, horizontal
//! translation, a global gain ramp and a moving light), and the camera that
//! renders them.
//!
//! Camera model, per frame: the scene plane seen through the frame's
//! [`Pose`], integrated over each pixel's area by `S × S` supersampling
//! (4 × 4 for the checkerboard's hard edges, 2 × 2 for the smooth texture),
//! blurred by a Gaussian point-spread function (σ = 0.8 px, as a lens
//! would), multiplied by the gain, plus additive Gaussian sensor noise, and
//! rounded to 8 bits. The blur acts in image coordinates, so the true
//! displacement of every pixel is exactly the pose's (see [`super::truth`]).

use super::truth::Pose;
use reynoldsflow_host::Gray;

/// What is on the scene plane.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Pattern {
    /// 13 × 12 squares (dark 40, light 210) on a uniform background (125),
    /// centred in the frame; squares of `height / 17` px.
    Checkerboard,
    /// Smooth value noise of four octaves (lattice steps 32, 16, 8 and 4 px,
    /// amplitudes 1, 0.7, 0.5, 0.35), mapped to about 30 ..= 225.
    Texture,
}

impl Pattern {
    /// Both patterns.
    pub const ALL: [Self; 2] = [Self::Checkerboard, Self::Texture];

    /// Short name (file names, tables).
    pub fn name(self) -> &'static str {
        match self {
            Self::Checkerboard => "checkerboard",
            Self::Texture => "texture",
        }
    }
}

/// The paper's four controlled tests, illumination split in two.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Scenario {
    /// Zoom in about the centre by `1 + level` per frame (divergence > 0).
    ZoomIn,
    /// Zoom out about the centre by `1 / (1 + level)` per frame.
    ZoomOut,
    /// Rotation about the centre by `level` degrees per frame (clockwise on
    /// screen: x turns towards y, y down).
    Rotation,
    /// Horizontal translation by `level` px per frame, to the right.
    Translation,
    /// No motion; global gain `1 + level · (n − (N − 1)/2)` on frame n.
    Gain,
    /// No motion; a broad light spot (σ = height / 4, peak +0.6) sweeping
    /// right by `level` px per frame over a 0.5 ambient level.
    MovingLight,
}

impl Scenario {
    /// Every scenario, in report order.
    pub const ALL: [Self; 6] = [
        Self::ZoomIn,
        Self::ZoomOut,
        Self::Rotation,
        Self::Translation,
        Self::Gain,
        Self::MovingLight,
    ];

    /// Short name (file names, tables).
    pub fn name(self) -> &'static str {
        match self {
            Self::ZoomIn => "zoom-in",
            Self::ZoomOut => "zoom-out",
            Self::Rotation => "rotation",
            Self::Translation => "translation",
            Self::Gain => "gain",
            Self::MovingLight => "moving-light",
        }
    }

    /// Does the scene move (a non-zero ground truth)?
    pub fn moves(self) -> bool {
        !matches!(self, Self::Gain | Self::MovingLight)
    }

    /// The magnitudes evaluated, smallest first; the second is the
    /// reference level of the tables (about 1 px/frame at 320 × 240).
    pub fn levels(self) -> [f64; 4] {
        match self {
            Self::ZoomIn | Self::ZoomOut => [0.005, 0.01, 0.02, 0.03],
            Self::Rotation => [0.25, 0.5, 1.0, 1.5],
            Self::Translation => [0.5, 1.0, 2.0, 3.0],
            Self::Gain => [0.01, 0.02, 0.04, 0.08],
            Self::MovingLight => [2.0, 4.0, 8.0, 16.0],
        }
    }

    /// The level with its unit, e.g. `1 %/frame`.
    pub fn level_label(self, level: f64) -> String {
        match self {
            Self::ZoomIn | Self::ZoomOut => format!("{} %/frame", level * 100.0),
            Self::Rotation => format!("{level}°/frame"),
            Self::Translation => format!("{level} px/frame"),
            Self::Gain => format!("gain {} %/frame", level * 100.0),
            Self::MovingLight => format!("light {level} px/frame"),
        }
    }

    /// The level's unit for plot axes.
    pub fn level_unit(self) -> &'static str {
        match self {
            Self::ZoomIn | Self::ZoomOut => "zoom step (%/frame)",
            Self::Rotation => "rotation (deg/frame)",
            Self::Translation => "shift (px/frame)",
            Self::Gain => "gain step (%/frame)",
            Self::MovingLight => "light speed (px/frame)",
        }
    }

    /// The level as plotted (percent for zoom and gain).
    pub fn level_axis_value(self, level: f64) -> f64 {
        match self {
            Self::ZoomIn | Self::ZoomOut | Self::Gain => level * 100.0,
            _ => level,
        }
    }

    /// Camera pose of frame `n`.
    pub fn pose(self, level: f64, n: usize, centre: [f64; 2]) -> Pose {
        let n_f = n as f64;
        let id = Pose::identity(centre);
        match self {
            Self::ZoomIn => Pose {
                scale: (1.0 + level).powf(n_f),
                ..id
            },
            Self::ZoomOut => Pose {
                scale: (1.0 + level).powf(-n_f),
                ..id
            },
            Self::Rotation => Pose {
                angle: (level * n_f).to_radians(),
                ..id
            },
            Self::Translation => Pose {
                shift: [level * n_f, 0.0],
                ..id
            },
            Self::Gain | Self::MovingLight => id,
        }
    }
}

/// One sequence to render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneSpec {
    /// The scene plane's pattern.
    pub pattern: Pattern,
    /// The motion or lighting change.
    pub scenario: Scenario,
    /// The scenario's magnitude (see [`Scenario::levels`]).
    pub level: f64,
    /// Standard deviation of the additive sensor noise, gray levels.
    pub noise_sigma: f64,
    /// Frames in the sequence.
    pub frames: usize,
    /// Frame width.
    pub width: usize,
    /// Frame height.
    pub height: usize,
}

/// A rendered sequence with the poses of its frames.
#[derive(Clone, Debug)]
pub struct Sequence {
    /// What was rendered.
    pub spec: SceneSpec,
    /// The frames.
    pub frames: Vec<Gray>,
    /// Pose of each frame.
    pub poses: Vec<Pose>,
}

impl SceneSpec {
    /// The frame centre `((W − 1)/2, (H − 1)/2)`, centre of zoom and rotation.
    pub fn centre(&self) -> [f64; 2] {
        [
            (self.width - 1) as f64 / 2.0,
            (self.height - 1) as f64 / 2.0,
        ]
    }

    /// Side of a checkerboard square, px.
    fn square(&self) -> f64 {
        (self.height / 17).max(4) as f64
    }

    /// Top-left corner of the checkerboard on the scene plane.
    fn board_origin(&self) -> [f64; 2] {
        let (c, q) = (self.centre(), self.square());
        [c[0] - 6.5 * q, c[1] - 6.0 * q]
    }

    /// The checkerboard's 12 × 11 inner corners (where four squares meet),
    /// scene coordinates.
    pub fn board_corners(&self) -> Vec<[f64; 2]> {
        let (o, q) = (self.board_origin(), self.square());
        (1..12)
            .flat_map(|j| (1..13).map(move |i| [o[0] + i as f64 * q, o[1] + j as f64 * q]))
            .collect()
    }

    /// Scene radiance at `p`, gray levels.
    fn radiance(&self, p: [f64; 2]) -> f64 {
        match self.pattern {
            Pattern::Checkerboard => {
                let (o, q) = (self.board_origin(), self.square());
                let (i, j) = (((p[0] - o[0]) / q).floor(), ((p[1] - o[1]) / q).floor());
                if (0.0..13.0).contains(&i) && (0.0..12.0).contains(&j) {
                    if (i + j) as i64 % 2 == 0 { 210.0 } else { 40.0 }
                } else {
                    125.0
                }
            }
            Pattern::Texture => {
                let octaves = [(32.0, 1.0), (16.0, 0.7), (8.0, 0.5), (4.0, 0.35)];
                let mut sum = 0.0;
                for (k, (wavelength, amplitude)) in octaves.into_iter().enumerate() {
                    sum += amplitude * value_noise(p[0] / wavelength, p[1] / wavelength, k as u64);
                }
                // sum lies within ±2.55, mostly within ±1.3.
                (127.5 + 75.0 * sum).clamp(0.0, 255.0)
            }
        }
    }

    /// Illumination of scene point `p` in frame `n` (1 when unlit scenarios).
    fn light(&self, p: [f64; 2], n: usize) -> f64 {
        if self.scenario != Scenario::MovingLight {
            return 1.0;
        }
        let c = self.centre();
        let mid = (self.frames - 1) as f64 / 2.0;
        let lx = c[0] + (n as f64 - mid) * self.level;
        let sigma = self.height as f64 / 4.0;
        let r2 = (p[0] - lx).powi(2) + (p[1] - c[1]).powi(2);
        0.5 + 0.6 * (-r2 / (2.0 * sigma * sigma)).exp()
    }

    /// Camera gain of frame `n`.
    fn gain(&self, n: usize) -> f64 {
        if self.scenario != Scenario::Gain {
            return 1.0;
        }
        let mid = (self.frames - 1) as f64 / 2.0;
        1.0 + self.level * (n as f64 - mid)
    }

    /// Render frame `n` (deterministic: the noise is seeded by `seed` and `n`).
    pub fn render_frame(&self, n: usize, seed: u64) -> Gray {
        const MARGIN: usize = 3;
        let pose = self.scenario.pose(self.level, n, self.centre());
        let ss = match self.pattern {
            Pattern::Checkerboard => 4,
            Pattern::Texture => 2,
        };
        let (w, h) = (self.width + 2 * MARGIN, self.height + 2 * MARGIN);
        let mut img = vec![0.0; w * h];
        for y in 0..h {
            for x in 0..w {
                let mut acc = 0.0;
                for sy in 0..ss {
                    for sx in 0..ss {
                        let ox = (sx as f64 + 0.5) / ss as f64 - 0.5;
                        let oy = (sy as f64 + 0.5) / ss as f64 - 0.5;
                        let ix = x as f64 - MARGIN as f64 + ox;
                        let iy = y as f64 - MARGIN as f64 + oy;
                        let p = pose.to_scene([ix, iy]);
                        acc += self.radiance(p) * self.light(p, n);
                    }
                }
                img[y * w + x] = acc / (ss * ss) as f64;
            }
        }
        let blurred = gaussian_blur(&img, w, h, 0.8, MARGIN);
        let gain = self.gain(n);
        let mut rng = SplitMix::new(seed ^ (n as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        let mut pixels = Vec::with_capacity(self.width * self.height);
        for y in 0..self.height {
            for x in 0..self.width {
                let v = blurred[(y + MARGIN) * w + x + MARGIN] * gain;
                let noise = if self.noise_sigma > 0.0 {
                    self.noise_sigma * rng.gaussian()
                } else {
                    0.0
                };
                pixels.push((v + noise).round().clamp(0.0, 255.0) as u8);
            }
        }
        Gray::new(self.width, self.height, pixels).expect("sizes are consistent")
    }

    /// Render the whole sequence.
    pub fn render(&self, seed: u64) -> Sequence {
        let centre = self.centre();
        Sequence {
            spec: *self,
            frames: (0..self.frames)
                .map(|n| self.render_frame(n, seed))
                .collect(),
            poses: (0..self.frames)
                .map(|n| self.scenario.pose(self.level, n, centre))
                .collect(),
        }
    }
}

/// Separable Gaussian blur of a `w × h` image with radius `r`; the outer
/// `r` px use whatever is there (the caller crops them away).
fn gaussian_blur(img: &[f64], w: usize, h: usize, sigma: f64, r: usize) -> Vec<f64> {
    let taps: Vec<f64> = (0..=2 * r)
        .map(|i| {
            let d = i as f64 - r as f64;
            (-d * d / (2.0 * sigma * sigma)).exp()
        })
        .collect();
    let norm: f64 = taps.iter().sum();
    let taps: Vec<f64> = taps.iter().map(|t| t / norm).collect();
    let clamp = |v: isize, n: usize| v.clamp(0, n as isize - 1) as usize;
    let mut tmp = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            tmp[y * w + x] = taps
                .iter()
                .enumerate()
                .map(|(i, t)| t * img[y * w + clamp(x as isize + i as isize - r as isize, w)])
                .sum();
        }
    }
    let mut out = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            out[y * w + x] = taps
                .iter()
                .enumerate()
                .map(|(i, t)| t * tmp[clamp(y as isize + i as isize - r as isize, h) * w + x])
                .sum();
        }
    }
    out
}

/// A 64-bit hash of a lattice point (SplitMix64's finaliser).
fn hash(ix: i64, iy: i64, octave: u64) -> u64 {
    let mut z = (ix as u64)
        .wrapping_mul(0x9e37_79b9_7f4a_7c15)
        .wrapping_add((iy as u64).wrapping_mul(0xc2b2_ae3d_27d4_eb4f))
        .wrapping_add(octave.wrapping_mul(0x1656_67b1_9e37_79f9));
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Value noise in `[−1, 1]` with a quintic fade: smooth (C²) between
/// lattice points one unit apart.
fn value_noise(x: f64, y: f64, octave: u64) -> f64 {
    let (x0, y0) = (x.floor(), y.floor());
    let fade = |t: f64| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    let (tx, ty) = (fade(x - x0), fade(y - y0));
    let (ix, iy) = (x0 as i64, y0 as i64);
    let v =
        |i: i64, j: i64| (hash(ix + i, iy + j, octave) >> 11) as f64 / (1u64 << 52) as f64 - 1.0;
    let top = v(0, 0) + tx * (v(1, 0) - v(0, 0));
    let bottom = v(0, 1) + tx * (v(1, 1) - v(0, 1));
    top + ty * (bottom - top)
}

/// SplitMix64 with Box–Muller Gaussians: deterministic sensor noise.
struct SplitMix {
    state: u64,
    spare: Option<f64>,
}

impl SplitMix {
    fn new(seed: u64) -> Self {
        Self {
            state: seed,
            spare: None,
        }
    }

    fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `(0, 1]`.
    fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) + 1) as f64 / (1u64 << 53) as f64
    }

    fn gaussian(&mut self) -> f64 {
        if let Some(s) = self.spare.take() {
            return s;
        }
        let (u1, u2) = (self.uniform(), self.uniform());
        let r = (-2.0 * u1.ln()).sqrt();
        let t = std::f64::consts::TAU * u2;
        self.spare = Some(r * t.sin());
        r * t.cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(pattern: Pattern, scenario: Scenario, level: f64) -> SceneSpec {
        SceneSpec {
            pattern,
            scenario,
            level,
            noise_sigma: 0.0,
            frames: 3,
            width: 64,
            height: 48,
        }
    }

    #[test]
    fn an_integer_shift_moves_the_picture_by_that_many_pixels() {
        let s = spec(Pattern::Texture, Scenario::Translation, 2.0);
        let (a, b) = (s.render_frame(0, 1), s.render_frame(1, 1));
        for y in 0..48 {
            for x in 0..60 {
                assert_eq!(a.pixels[y * 64 + x], b.pixels[y * 64 + x + 2], "({x}, {y})");
            }
        }
    }

    #[test]
    fn patterns_have_contrast_and_noise_has_its_sigma() {
        for pattern in Pattern::ALL {
            let g = spec(pattern, Scenario::Gain, 0.0).render_frame(0, 0);
            let (lo, hi) = g
                .pixels
                .iter()
                .fold((255, 0), |(l, h), &p| (p.min(l), p.max(h)));
            assert!(hi - lo > 100, "{pattern:?}: {lo}..{hi}");
        }
        let mut rng = SplitMix::new(7);
        let n = 20_000;
        let xs: Vec<f64> = (0..n).map(|_| rng.gaussian()).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(
            mean.abs() < 0.03 && (var - 1.0).abs() < 0.05,
            "{mean} {var}"
        );
    }

    #[test]
    fn board_has_132_inner_corners_inside_the_frame() {
        let s = spec(Pattern::Checkerboard, Scenario::ZoomIn, 0.01);
        let corners = s.board_corners();
        assert_eq!(corners.len(), 132);
        assert!(
            corners
                .iter()
                .all(|p| p[0] > 0.0 && p[1] > 0.0 && p[0] < 63.0 && p[1] < 47.0)
        );
    }
}

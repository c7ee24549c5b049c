//! Shared helpers of the integration tests: frame generators and whole-frame
//! runs of the fixed core that collect every output pixel.

pub mod corpus;

use reynoldsflow_core::{Config, Engine, FlowPixel, FramePair, Pixels, Plan, RowStream, Sink};

/// Columns of the test engine: tiles up to 200 px wide.
pub const COLS: usize = 214;

/// The engine the tests use (boxed: about 65 KiB).
pub fn engine() -> Box<Engine<COLS>> {
    Box::new(Engine::new())
}

/// Every output pixel of a frame, row-major.
pub struct PixelPlane {
    pub width: usize,
    pub pixels: Vec<FlowPixel>,
    /// Output rows in the order they arrived: (y, x, len).
    pub rows: Vec<(usize, usize, usize)>,
}

impl PixelPlane {
    pub fn new(config: &Config) -> Self {
        let n = config.width() * config.height();
        Self {
            width: config.width(),
            pixels: vec![FlowPixel::default(); n],
            rows: Vec::new(),
        }
    }
}

impl Sink for PixelPlane {
    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        let start = y * self.width + x;
        let out = &mut self.pixels[start..start + pixels.len()];
        for (dst, px) in out.iter_mut().zip(pixels.iter()) {
            *dst = px;
        }
        self.rows.push((y, x, pixels.len()));
    }
}

/// The whole frame computed with tiles of `tile` (width, height).
pub fn run_tiled(config: &Config, prev: &[u8], next: &[u8], tile: (usize, usize)) -> PixelPlane {
    let plan = Plan::new(*config, tile.0, tile.1).expect("a tile of at least one pixel");
    let frames = FramePair::packed(config, prev, next).expect("frames of the config's size");
    let job = plan.bind(frames).expect("frames of the plan's size");
    let mut out = PixelPlane::new(config);
    engine().run(&job, &mut out);
    out
}

/// The whole frame fed row by row through column strips of `strip` px.
pub fn run_streamed(config: &Config, prev: &[u8], next: &[u8], strip: usize) -> PixelPlane {
    let (w, h) = (config.width(), config.height());
    let mut out = PixelPlane::new(config);
    let starts: Vec<usize> = (0..w).step_by(strip).collect();
    let mut engines: Vec<_> = starts.iter().map(|_| engine()).collect();
    let mut streams: Vec<_> = engines
        .iter_mut()
        .zip(&starts)
        .map(|(e, &x)| RowStream::new(e, *config, x, strip.min(w - x)).expect("strip fits"))
        .collect();
    for y in 0..h {
        for s in &mut streams {
            s.push(
                &prev[y * w..(y + 1) * w],
                &next[y * w..(y + 1) * w],
                &mut out,
            )
            .expect("row accepted");
        }
    }
    assert!(streams.iter().all(|s| s.is_finished()));
    out
}

/// Kinds of frame pairs the property tests draw from.
#[derive(Clone, Copy, Debug)]
pub enum Pattern {
    /// Independent uniform noise in both frames.
    Random,
    /// A smooth texture moving by a fraction of a pixel.
    Smooth,
    /// Noise shifted by one pixel right and down.
    Shifted,
    /// Both frames black.
    AllZero,
    /// Both frames white.
    AllFull,
    /// A 0/255 step edge moving by two pixels, touching the frame's border.
    SaturatedEdge,
}

impl Pattern {
    pub const ALL: [Pattern; 6] = [
        Pattern::Random,
        Pattern::Smooth,
        Pattern::Shifted,
        Pattern::AllZero,
        Pattern::AllFull,
        Pattern::SaturatedEdge,
    ];
}

/// xorshift64*: a fixed, seedable generator for test frames.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    pub fn byte(&mut self) -> u8 {
        (self.next_u64() >> 56) as u8
    }

    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A frame pair of `w × h` of the given pattern.
pub fn frame_pair(pattern: Pattern, w: usize, h: usize, seed: u64) -> (Vec<u8>, Vec<u8>) {
    let mut rng = Rng::new(seed);
    let n = w * h;
    match pattern {
        Pattern::Random => (
            (0..n).map(|_| rng.byte()).collect(),
            (0..n).map(|_| rng.byte()).collect(),
        ),
        Pattern::Smooth => {
            let (fx, fy, phase) = (
                0.05 + 0.3 * rng.unit(),
                0.05 + 0.3 * rng.unit(),
                6.0 * rng.unit(),
            );
            let (dx, dy) = (rng.unit() - 0.5, rng.unit() - 0.5);
            let texture = |x: f64, y: f64| {
                let v = 127.5 + 60.0 * (fx * x + phase).sin() + 60.0 * (fy * y - phase).cos();
                v.round().clamp(0.0, 255.0) as u8
            };
            let frame = |sx: f64, sy: f64| -> Vec<u8> {
                (0..n)
                    .map(|i| texture((i % w) as f64 - sx, (i / w) as f64 - sy))
                    .collect()
            };
            (frame(0.0, 0.0), frame(dx, dy))
        }
        Pattern::Shifted => {
            let (bw, bh) = (w + 1, h + 1);
            let big: Vec<u8> = (0..bw * bh).map(|_| rng.byte()).collect();
            let crop = |ox: usize, oy: usize| -> Vec<u8> {
                (0..n)
                    .map(|i| big[(i / w + oy) * bw + i % w + ox])
                    .collect()
            };
            (crop(1, 1), crop(0, 0))
        }
        Pattern::AllZero => (vec![0; n], vec![0; n]),
        Pattern::AllFull => (vec![255; n], vec![255; n]),
        Pattern::SaturatedEdge => {
            let edge = (rng.next_u64() % (w as u64 + 1)) as usize;
            let step =
                |e: usize| -> Vec<u8> { (0..n).map(|i| if i % w < e { 255 } else { 0 }).collect() };
            (step(edge), step((edge + 2).min(w)))
        }
    }
}

/// Where the conformance vectors live (copied from the SPEC's independent
/// float64 implementation).
pub fn vectors_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("vectors")
}

/// Names of the vector cases, sorted.
pub fn vector_cases() -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(vectors_dir())
        .expect("tests/vectors exists")
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_dir())
        .filter_map(|e| e.file_name().into_string().ok())
        .collect();
    names.sort();
    names
}

/// Error statistics of one field (two components) against a reference.
#[derive(Clone, Copy, Debug, Default)]
pub struct FieldError {
    /// Largest reference magnitude over the frame.
    pub max_ref: f64,
    /// Largest per-pixel error (max over both components).
    pub max_err: f64,
    /// The 99.9th percentile of the per-pixel error: at most 0.1 % of
    /// pixels (⌊n/1000⌋ of n) have a larger one. So `p999_err ≤ t` exactly
    /// when no more than 0.1 % of pixels are beyond `t`.
    pub p999_err: f64,
    /// Root mean square of the per-pixel error.
    pub rms_err: f64,
    pub pixels: usize,
}

impl FieldError {
    /// Compare `(x, y)` against `(rx, ry)`.
    pub fn measure(x: &[f64], y: &[f64], rx: &[f64], ry: &[f64]) -> Self {
        assert!(
            x.len() == rx.len() && y.len() == ry.len() && x.len() == y.len(),
            "fields of different sizes"
        );
        let max_ref = rx
            .iter()
            .zip(ry)
            .map(|(a, b)| a.hypot(*b))
            .fold(0.0, f64::max);
        let mut errs: Vec<f64> = (0..x.len())
            .map(|i| (x[i] - rx[i]).abs().max((y[i] - ry[i]).abs()))
            .collect();
        errs.sort_unstable_by(|a, b| b.total_cmp(a));
        Self {
            max_ref,
            max_err: errs.first().copied().unwrap_or(0.0),
            p999_err: errs.get(errs.len() / 1000).copied().unwrap_or(0.0),
            rms_err: (errs.iter().map(|e| e * e).sum::<f64>() / errs.len().max(1) as f64).sqrt(),
            pixels: errs.len(),
        }
    }
}

/// Comparison of two RGB8 representations.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ByteDiff {
    /// Largest difference of any byte.
    pub max: u8,
    /// Pixels with at least one differing byte.
    pub differing_pixels: usize,
    pub pixels: usize,
}

/// Byte comparison of two RGB8 representations: largest difference and how
/// many pixels differ.
pub fn byte_diff(a: &[u8], b: &[u8]) -> ByteDiff {
    assert_eq!(a.len(), b.len(), "representations of different sizes");
    assert_eq!(a.len() % 3, 0, "not RGB8");
    let (a, b) = (a.chunks_exact(3), b.chunks_exact(3));
    let pairs = || a.clone().zip(b.clone());
    ByteDiff {
        max: pairs()
            .flat_map(|(p, q)| p.iter().zip(q).map(|(x, y)| x.abs_diff(*y)))
            .max()
            .unwrap_or(0),
        differing_pixels: pairs().filter(|(p, q)| p != q).count(),
        pixels: a.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn p999_is_exceeded_by_at_most_a_thousandth_of_pixels() {
        // 2000 pixels: two errors may lie above p99.9, a third may not.
        let zeros = vec![0.0; 2000];
        let mut x = zeros.clone();
        (x[5], x[9], x[700]) = (3.0, 2.0, 1.0);
        let e = FieldError::measure(&x, &zeros, &zeros, &zeros);
        assert_eq!((e.max_err, e.p999_err, e.pixels), (3.0, 1.0, 2000));
        let z = &zeros[..1999];
        let e = FieldError::measure(z, &x[..1999], z, z);
        assert_eq!(e.p999_err, 2.0, "1999 pixels: one may lie above");
    }

    #[test]
    fn byte_diff_counts_pixels_not_bytes() {
        let a = [10, 20, 30, 10, 20, 30, 0, 0, 0];
        let b = [11, 19, 30, 10, 20, 30, 0, 0, 3];
        let d = byte_diff(&a, &b);
        assert_eq!(
            d,
            ByteDiff {
                max: 3,
                differing_pixels: 2,
                pixels: 3
            }
        );
    }
}

//! Shared by the benches: the frame sizes, a textured moving pair, and the
//! core's `represent` ready to time. Stages are profiled inside the engine
//! as it ships (`scripts/profile-stages`), not mirrored.
#![allow(dead_code)]

use std::hint::black_box;

use reynoldsflow_core::fixed::types::U16F16;
use reynoldsflow_core::{Config, Engine, FramePair, Params, Plan, Scaling};
use reynoldsflow_host::internals::bytes::{self, Isa, Pass};
use reynoldsflow_host::limits::Limits;
/// Output columns of the strips of the compile-time engine the benches
/// time (`Engine<COLS>`, arrays in a box, as a board would hold them);
/// `reynoldsflow run` takes the host's wider strips
/// (`internals::strip_width`).
pub const STRIPS: usize = 128;

/// Window columns of those strips.
pub const COLS: usize = STRIPS + 14;

/// The frame sizes every bench covers.
pub const SIZES: [(usize, usize); 4] = [(160, 120), (320, 240), (640, 480), (1280, 720)];

/// Constant gains 8 for both magnitudes: one engine pass, as when streaming.
pub const FIXED: Scaling = Scaling::Fixed {
    k_d: U16F16::lit("8"),
    k_c: U16F16::lit("8"),
};

/// The core's `represent` with an engine of `N` columns over `tile` tiles
/// (`None`: full-height strips), compiled for `isa`, one call per run of
/// the closure.
pub fn core_engine<const N: usize>(
    isa: Isa,
    prev: &[u8],
    next: &[u8],
    (w, h): (usize, usize),
    tile: Option<(usize, usize)>,
    scaling: Scaling,
) -> impl FnMut() + use<N> {
    let config = Config::new(w, h, Params::DEFAULT).unwrap();
    let plan = match tile {
        None => Plan::strips(config, Engine::<N>::MAX_TILE_WIDTH).unwrap(),
        Some((tw, th)) => Plan::new(config, tw, th).unwrap(),
    };
    let (prev, next) = (prev.to_vec(), next.to_vec());
    let mut engine = Box::new(Engine::<N>::new());
    let mut rgb = vec![0u8; 3 * w * h];
    move || {
        let frames = FramePair::packed(&config, &prev, &next).unwrap();
        let pass = Pass::Represent(scaling, black_box(&mut rgb));
        bytes::run(isa, &mut engine, &plan, &frames, pass, &mut ()).unwrap();
    }
}

/// A small integer hash (lowbias32).
fn hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// Value noise on a lattice of `cell` px, bilinear between lattice points, in [0, 1).
fn value_noise(x: f64, y: f64, cell: f64, seed: u32) -> f64 {
    let (u, v) = (x / cell, y / cell);
    let (iu, iv) = (u.floor(), v.floor());
    let (fu, fv) = (u - iu, v - iv);
    let at = |i: f64, j: f64| {
        let k = (i as i64 as u32).wrapping_mul(0x9e37_79b9)
            ^ (j as i64 as u32).wrapping_mul(0x85eb_ca6b);
        f64::from(hash(k ^ seed)) / 4_294_967_296.0
    };
    let (s, t) = (fu * fu * (3.0 - 2.0 * fu), fv * fv * (3.0 - 2.0 * fv));
    let top = at(iu, iv) * (1.0 - s) + at(iu + 1.0, iv) * s;
    let bottom = at(iu, iv + 1.0) * (1.0 - s) + at(iu + 1.0, iv + 1.0) * s;
    top * (1.0 - t) + bottom * t
}

/// A textured frame: four octaves of value noise (cells of 48 down to 3 px)
/// seen through a translation by `(dx, dy)` px, plus ±2 levels of
/// per-frame sensor noise. Frames `(0, 0, 0)` and `(1.5, 0.75, 1)` are a
/// pair with a sub-pixel motion everywhere and texture at every scale.
pub fn textured(w: usize, h: usize, dx: f64, dy: f64, frame: u32) -> Vec<u8> {
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64 - dx, (i / w) as f64 - dy);
            let mut v = 0.0;
            for (k, (cell, weight)) in [(48.0, 0.45), (17.0, 0.3), (7.0, 0.17), (3.0, 0.08)]
                .into_iter()
                .enumerate()
            {
                v += weight * value_noise(x, y, cell, 0x51ed_270b ^ k as u32);
            }
            let noise = f64::from(hash(i as u32 ^ frame.wrapping_mul(0x2c1b_3c6d)) % 5) - 2.0;
            (20.0 + 215.0 * v + noise).clamp(0.0, 255.0) as u8
        })
        .collect()
}

/// The textured moving pair of a size: `(fⁿ, fⁿ⁺¹)`.
pub fn moving_pair(w: usize, h: usize) -> (Vec<u8>, Vec<u8>) {
    (textured(w, h, 0.0, 0.0, 0), textured(w, h, 1.5, 0.75, 1))
}

/// A gray image file (PGM, PNG, …) as `(width, height, pixels)`.
pub fn read_gray(path: &str) -> (usize, usize, Vec<u8>) {
    let gray =
        reynoldsflow_host::io::image_file::read_gray(std::path::Path::new(path), Limits::default())
            .unwrap_or_else(|e| panic!("{path}: {e}"));
    (gray.width, gray.height, gray.pixels)
}

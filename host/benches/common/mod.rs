//! Shared by the benches: the frame sizes, a textured moving pair, the
//! core's `represent` ready to time, and a
//! stage-by-stage mirror of the engine's schedule (through
//! `reynoldsflow_core::internals`) that records every stage's real inputs
//! for one strip, so each kernel can be timed or profiled on its own over
//! exactly the calls the engine makes for a frame.
//!
//! The mirror is checked against the engine (`Strip::record` asserts that
//! its pixels equal `Engine::run`'s), so the kernels are timed on the values
//! they really see.
#![allow(dead_code)]

use std::hint::black_box;

use reynoldsflow_core::fixed::types::{I16F16, U16F16, U32F32};
use reynoldsflow_core::internals::{
    Products, ResidualInputs, StructureSums, boundary_minus_domain, curl_free_q32,
    divergence_free_q32, magnitude_q32, q16, smooth, structure_row, vertical_binomial,
};
use reynoldsflow_core::{
    Config, Engine, FlowPixel, FramePair, HALO, Params, Plan, Scaling, Sink, Tile,
};
use reynoldsflow_host::dispatch::{self, Isa, Pass};
use reynoldsflow_host::fixed_engine::ENGINE_COLS;

/// Window columns of the host engine (strips of 128 output columns).
pub const COLS: usize = ENGINE_COLS;

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
        None => Plan::<N>::strips(config).unwrap(),
        Some((tw, th)) => Plan::<N>::new(config, tw, th).unwrap(),
    };
    let (prev, next) = (prev.to_vec(), next.to_vec());
    let mut engine = Box::new(Engine::<N>::new());
    let mut rgb = vec![0u8; 3 * w * h];
    move || {
        let frames = FramePair::packed(&config, &prev, &next).unwrap();
        let pass = Pass::Represent(scaling, black_box(&mut rgb));
        dispatch::run(isa, &mut engine, &plan, &frames, pass, &mut ()).unwrap();
    }
}

/// `κ = 6144 / s` for the default intensity scale `s = 1/255` (SPEC §1):
/// the residual's constant (`Config` keeps its own copy private; the
/// engine check in [`Strip::record`] would catch a mismatch).
pub const KAPPA: i64 = 6144 * 255;

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

/// Rows of one plane, indexed by window row.
type Rows<T> = Vec<[T; COLS]>;

fn rows<T: Copy + Default>(count: usize) -> Rows<T> {
    vec![[T::default(); COLS]; count]
}

/// Every stage's rows for one full-height strip of a frame, window row by
/// window row (`t ∈ [0, h + 14)`), as the engine computes them.
pub struct Strip {
    /// The frame's configuration (default parameters).
    pub config: Config,
    /// Frame width and height.
    pub width: usize,
    /// Frame height (= the strip's output rows).
    pub height: usize,
    /// First output column of the recorded strip.
    pub x0: usize,
    /// Window columns of the recorded strip (`128 + 14`, or the frame's width + 14).
    pub n: usize,
    /// `p0` and `d` of each window row.
    pub p0: Rows<u8>,
    /// `d = p1 − p0`.
    pub d: Rows<i16>,
    /// `E` (x, y).
    pub e: [Rows<i32>; 2],
    /// `V` (x, y).
    pub v: [Rows<i32>; 2],
    /// Horizontally `G`-filtered products `X², XY, Y²`.
    pub small: [Rows<i32>; 3],
    /// Horizontally `G`-filtered products `X·Dn, Y·Dn`.
    pub wide: [Rows<i64>; 2],
    /// The structure sums `a, b, c` at each output row (vertical `G`).
    pub abc: [Rows<i32>; 3],
    /// The structure sums `p, q`.
    pub pq: [Rows<i64>; 2],
    /// `v_c`, `v_d` in Q32.32 at each output row.
    pub v_c: Rows<[i64; 2]>,
    /// `v_d` in Q32.32.
    pub v_d: Rows<[i64; 2]>,
}

/// All output pixels of a frame, from the engine.
struct Capture {
    width: usize,
    pixels: Vec<FlowPixel>,
}

impl Sink for Capture {
    fn row(&mut self, y: usize, x: usize, pixels: &[FlowPixel]) {
        let start = y * self.width + x;
        self.pixels[start..start + pixels.len()].copy_from_slice(pixels);
    }
}

/// Window columns `[x_first, x_first + n)` of a frame row, clamped (SPEC §2).
fn clamped(row: &[u8], x_first: isize, n: usize) -> impl Iterator<Item = u8> + '_ {
    let last = row.len() as isize - 1;
    (0..n as isize).map(move |i| row[(x_first + i).clamp(0, last) as usize])
}

impl Strip {
    /// Run the stages of the engine over the middle strip of `(prev, next)`
    /// (or the whole frame when it is narrower than a strip), keeping every
    /// row, and check the result against `Engine::run`.
    pub fn record(width: usize, height: usize, prev: &[u8], next: &[u8]) -> Box<Self> {
        let config = Config::new(width, height, Params::DEFAULT).unwrap();
        let tile_width = width.min(COLS - 2 * HALO);
        let x0 = (width - tile_width) / 2;
        let n = tile_width + 2 * HALO;
        let count = height + 2 * HALO;
        let mut s = Box::new(Strip {
            config,
            width,
            height,
            x0,
            n,
            p0: rows(count),
            d: rows(count),
            e: [rows(count), rows(count)],
            v: [rows(count), rows(count)],
            small: [rows(count), rows(count), rows(count)],
            wide: [rows(count), rows(count)],
            abc: [rows(count), rows(count), rows(count)],
            pq: [rows(count), rows(count)],
            v_c: rows(count),
            v_d: rows(count),
        });
        let frames = FramePair::packed(&config, prev, next).unwrap();
        let mut scratch = Scratch::new();
        let x_first = x0 as isize - HALO as isize;
        for t in 0..count {
            let y = t as isize - HALO as isize;
            let (rp, rn) = (frames.prev().clamped_row(y), frames.next().clamped_row(y));
            for ((p, d), (a, b)) in s.p0[t]
                .iter_mut()
                .zip(s.d[t].iter_mut())
                .zip(clamped(rp, x_first, n).zip(clamped(rn, x_first, n)))
            {
                *p = a;
                *d = i16::from(b) - i16::from(a);
            }
            let Strip {
                d,
                e,
                v,
                small,
                wide,
                abc,
                pq,
                p0,
                v_c,
                v_d,
                ..
            } = &mut *s;
            if t >= 4 {
                let [ex, ey] = e;
                boundary_minus_domain(
                    five(d, t - 4),
                    &mut scratch.vert_d,
                    (&mut ex[t - 2], &mut ey[t - 2]),
                    n,
                );
            }
            if t >= 8 {
                let [vx, vy] = v;
                smooth(
                    [five(&e[0], t - 6), five(&e[1], t - 6)],
                    &mut scratch.vert_e,
                    (&mut vx[t - 4], &mut vy[t - 4]),
                    n,
                );
            }
            if t >= 10 {
                let j = t - 5;
                let [sa, sb, sc] = small;
                let [sp, sq] = wide;
                structure_row(
                    &residual_inputs(v, p0, d, j),
                    &mut scratch.products,
                    [&mut sa[j], &mut sb[j], &mut sc[j]],
                    [&mut sp[j], &mut sq[j]],
                    n,
                );
            }
            if t >= 2 * HALO {
                let o = t - HALO;
                for (ring, out) in small.iter().zip(abc.iter_mut()) {
                    vertical_binomial(five(ring, o - 2), &mut out[o], n, HALO);
                }
                for (ring, out) in wide.iter().zip(pq.iter_mut()) {
                    vertical_binomial(five(ring, o - 2), &mut out[o], n, HALO);
                }
                for i in HALO..n - HALO {
                    v_c[o][i] = [
                        curl_free_q32(&config, v[0][o][i]),
                        curl_free_q32(&config, v[1][o][i]),
                    ];
                    v_d[o][i] = divergence_free_q32(&config, sums(abc, pq, o, i));
                }
            }
        }
        s.check_against_engine(&frames);
        s
    }

    /// The mirror's pixels must be the engine's.
    fn check_against_engine(&self, frames: &FramePair<'_>) {
        let mut engine = Box::new(Engine::<COLS>::new());
        let plan = Plan::<COLS>::strips(self.config).unwrap();
        let mut capture = Capture {
            width: self.width,
            pixels: vec![FlowPixel::default(); self.width * self.height],
        };
        engine.run(&plan, frames, &mut capture).unwrap();
        let mut moving = 0;
        for y in 0..self.height {
            for i in HALO..self.n - HALO {
                let px = &capture.pixels[y * self.width + self.x0 + i - HALO];
                let (v_c, v_d) = (self.v_c[y + HALO][i], self.v_d[y + HALO][i]);
                let ours = (
                    v_c.map(q16),
                    v_d.map(q16),
                    magnitude_q32(v_c),
                    magnitude_q32(v_d),
                );
                let theirs = (
                    px.v_c.map(I16F16::to_bits),
                    px.v_d.map(I16F16::to_bits),
                    px.m_c.to_bits(),
                    px.m_d.to_bits(),
                );
                assert_eq!(ours, theirs, "mirror differs from the engine at ({i}, {y})");
                moving += usize::from(px.m_d > U32F32::ZERO && px.m_c > U32F32::ZERO);
            }
        }
        assert!(
            moving * 2 > (self.n - 2 * HALO) * self.height,
            "the pair barely moves"
        );
    }

    /// The strips the engine cuts this frame into (`Plan::strips`).
    pub fn tiles(&self) -> Vec<Tile> {
        let plan = Plan::<COLS>::strips(self.config).unwrap();
        (0..plan.tile_count())
            .filter_map(|i| plan.tile(i))
            .collect()
    }

    /// Pixels of the frame.
    pub fn pixels(&self) -> usize {
        self.width * self.height
    }
}

/// Rows `first .. first + 5` of a plane.
fn five<T>(plane: &[[T; COLS]], first: usize) -> [&[T; COLS]; 5] {
    std::array::from_fn(|k| &plane[first + k])
}

/// The rows one residual row `j` reads.
fn residual_inputs<'a>(
    v: &'a [Rows<i32>; 2],
    p0: &'a Rows<u8>,
    d: &'a Rows<i16>,
    j: usize,
) -> ResidualInputs<'a, COLS> {
    ResidualInputs {
        vx: &v[0][j],
        vy: [&v[1][j - 1], &v[1][j], &v[1][j + 1]],
        p0: [&p0[j - 1], &p0[j], &p0[j + 1]],
        d: &d[j],
        kappa: KAPPA,
    }
}

#[inline(always)]
fn sums(abc: &[Rows<i32>; 3], pq: &[Rows<i64>; 2], o: usize, i: usize) -> StructureSums {
    StructureSums {
        a: abc[0][o][i],
        b: abc[1][o][i],
        c: abc[2][o][i],
        p: pq[0][o][i],
        q: pq[1][o][i],
    }
}

/// Where the timed kernels write: rings as deep as the engine's, so the
/// outputs stay in cache as they do in the engine.
pub struct Scratch {
    vert_d: [[i16; COLS]; 4],
    vert_e: [[i32; COLS]; 2],
    e: [[[i32; COLS]; 5]; 2],
    v: [[[i32; COLS]; 4]; 2],
    products: Products<COLS>,
    small: [[[i32; COLS]; 5]; 3],
    wide: [[[i64; COLS]; 5]; 2],
    abc: [[i32; COLS]; 3],
    pq: [[i64; COLS]; 2],
    fields: [[[i64; 2]; COLS]; 2],
    mags: [[u64; COLS]; 2],
    out: [FlowPixel; COLS],
}

impl Scratch {
    /// Zeroed, on the heap.
    pub fn new() -> Box<Self> {
        Box::new(Scratch {
            vert_d: [[0; COLS]; 4],
            vert_e: [[0; COLS]; 2],
            e: [[[0; COLS]; 5]; 2],
            v: [[[0; COLS]; 4]; 2],
            products: Products {
                wide: [[0; COLS]; 2],
                small: [[0; COLS]; 3],
            },
            small: [[[0; COLS]; 5]; 3],
            wide: [[[0; COLS]; 5]; 2],
            abc: [[0; COLS]; 3],
            pq: [[0; COLS]; 2],
            fields: [[[0; 2]; COLS]; 2],
            mags: [[0; COLS]; 2],
            out: [FlowPixel::default(); COLS],
        })
    }
}

/// One stage of the engine, run over every call the engine makes for the
/// frame (every strip, every window row), on the recorded rows of the
/// strip (narrower strips use its first columns).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// `E` from five rows of `d` (Simpson and Box⋆Sobel terms).
    BoundaryMinusDomain,
    /// `V = G ⋆ E` (vertical then horizontal binomial, two channels).
    Smooth,
    /// Sobel of `p0`, the residual `Dn`, the five products and their horizontal `G`.
    StructureRow,
    /// The vertical `G` of the five sums (per output row).
    VerticalBinomial,
    /// The 2×2 solve `divergence_free_q32`, per output pixel.
    Solve,
    /// `curl_free_q32` of both components, per output pixel.
    CurlFree,
    /// `magnitude_q32` of `v_c` and of `v_d`, per output pixel.
    Magnitudes,
    /// The whole per-pixel tail of `Engine::emit` (solve, `curl_free`,
    /// four `q16`, two magnitudes, the `FlowPixel`), without the vertical `G`.
    Tail,
}

impl Stage {
    /// Every stage, in pipeline order.
    pub const ALL: [Stage; 8] = [
        Stage::BoundaryMinusDomain,
        Stage::Smooth,
        Stage::StructureRow,
        Stage::VerticalBinomial,
        Stage::Solve,
        Stage::CurlFree,
        Stage::Magnitudes,
        Stage::Tail,
    ];

    /// Name in bench ids and tables.
    pub const fn name(self) -> &'static str {
        match self {
            Stage::BoundaryMinusDomain => "boundary_minus_domain",
            Stage::Smooth => "smooth",
            Stage::StructureRow => "structure_row",
            Stage::VerticalBinomial => "vertical_binomial x5",
            Stage::Solve => "divergence_free_q32",
            Stage::CurlFree => "curl_free_q32 x2",
            Stage::Magnitudes => "magnitude_q32 x2",
            Stage::Tail => "emit tail (all per-pixel)",
        }
    }

    /// The parts of the engine's work (`Tail` contains `Solve`,
    /// `CurlFree` and `Magnitudes`).
    pub const fn is_part(self) -> bool {
        !matches!(self, Stage::Tail)
    }

    /// Run this stage over the whole frame.
    pub fn run(self, strip: &Strip, tiles: &[Tile], scratch: &mut Scratch) {
        match self {
            Stage::BoundaryMinusDomain => run_boundary_minus_domain(strip, tiles, scratch),
            Stage::Smooth => run_smooth(strip, tiles, scratch),
            Stage::StructureRow => run_structure_row(strip, tiles, scratch),
            Stage::VerticalBinomial => run_vertical_binomial(strip, tiles, scratch),
            Stage::Solve => run_solve(strip, tiles, scratch),
            Stage::CurlFree => run_curl_free(strip, tiles, scratch),
            Stage::Magnitudes => run_magnitudes(strip, tiles, scratch),
            Stage::Tail => run_tail(strip, tiles, scratch),
        }
        black_box(scratch);
    }
}

/// Window columns of a tile.
fn window(tile: &Tile) -> usize {
    tile.width + 2 * HALO
}

// One function per stage, never inlined, so a profiler sees each stage
// apart (callgrind: inclusive cost of `common::run_*`).

#[inline(never)]
pub fn run_boundary_minus_domain(strip: &Strip, tiles: &[Tile], s: &mut Scratch) {
    for tile in tiles {
        let n = window(tile);
        for t in 4..tile.height + 2 * HALO {
            let [ex, ey] = &mut s.e;
            boundary_minus_domain(
                five(&strip.d, t - 4),
                &mut s.vert_d,
                (&mut ex[(t - 2) % 5], &mut ey[(t - 2) % 5]),
                n,
            );
        }
    }
}

#[inline(never)]
pub fn run_smooth(strip: &Strip, tiles: &[Tile], s: &mut Scratch) {
    for tile in tiles {
        let n = window(tile);
        for t in 8..tile.height + 2 * HALO {
            let [vx, vy] = &mut s.v;
            smooth(
                [five(&strip.e[0], t - 6), five(&strip.e[1], t - 6)],
                &mut s.vert_e,
                (&mut vx[(t - 4) % 4], &mut vy[(t - 4) % 4]),
                n,
            );
        }
    }
}

#[inline(never)]
pub fn run_structure_row(strip: &Strip, tiles: &[Tile], s: &mut Scratch) {
    for tile in tiles {
        let n = window(tile);
        for t in 10..tile.height + 2 * HALO {
            let j = t - 5;
            let [sa, sb, sc] = &mut s.small;
            let [sp, sq] = &mut s.wide;
            let k = j % 5;
            structure_row(
                &residual_inputs(&strip.v, &strip.p0, &strip.d, j),
                &mut s.products,
                [&mut sa[k], &mut sb[k], &mut sc[k]],
                [&mut sp[k], &mut sq[k]],
                n,
            );
        }
    }
}

#[inline(never)]
pub fn run_vertical_binomial(strip: &Strip, tiles: &[Tile], s: &mut Scratch) {
    for tile in tiles {
        let n = window(tile);
        for t in 2 * HALO..tile.height + 2 * HALO {
            let o = t - HALO;
            for (plane, out) in strip.small.iter().zip(s.abc.iter_mut()) {
                vertical_binomial(five(plane, o - 2), out, n, HALO);
            }
            for (plane, out) in strip.wide.iter().zip(s.pq.iter_mut()) {
                vertical_binomial(five(plane, o - 2), out, n, HALO);
            }
        }
    }
}

/// Output rows `o` and columns `i` of the engine's emit calls for a tile.
fn emit_cells(tile: &Tile) -> impl Iterator<Item = (usize, std::ops::Range<usize>)> {
    let cols = HALO..HALO + tile.width;
    (HALO..HALO + tile.height).map(move |o| (o, cols.clone()))
}

#[inline(never)]
pub fn run_solve(strip: &Strip, tiles: &[Tile], s: &mut Scratch) {
    let config = &strip.config;
    for tile in tiles {
        for (o, cols) in emit_cells(tile) {
            for i in cols {
                s.fields[1][i] = divergence_free_q32(config, sums(&strip.abc, &strip.pq, o, i));
            }
        }
    }
}

#[inline(never)]
pub fn run_curl_free(strip: &Strip, tiles: &[Tile], s: &mut Scratch) {
    let config = &strip.config;
    for tile in tiles {
        for (o, cols) in emit_cells(tile) {
            let (vx, vy) = (&strip.v[0][o], &strip.v[1][o]);
            for i in cols {
                s.fields[0][i] = [curl_free_q32(config, vx[i]), curl_free_q32(config, vy[i])];
            }
        }
    }
}

#[inline(never)]
pub fn run_magnitudes(strip: &Strip, tiles: &[Tile], s: &mut Scratch) {
    for tile in tiles {
        for (o, cols) in emit_cells(tile) {
            let (v_c, v_d) = (&strip.v_c[o], &strip.v_d[o]);
            for i in cols {
                s.mags[0][i] = magnitude_q32(v_c[i]);
                s.mags[1][i] = magnitude_q32(v_d[i]);
            }
        }
    }
}

#[inline(never)]
pub fn run_tail(strip: &Strip, tiles: &[Tile], s: &mut Scratch) {
    let config = &strip.config;
    for tile in tiles {
        for (o, cols) in emit_cells(tile) {
            let (vx, vy, luma) = (&strip.v[0][o], &strip.v[1][o], &strip.p0[o]);
            for (i, out) in cols.zip(s.out.iter_mut()) {
                let v_d = divergence_free_q32(config, sums(&strip.abc, &strip.pq, o, i));
                let v_c = [curl_free_q32(config, vx[i]), curl_free_q32(config, vy[i])];
                *out = FlowPixel {
                    v_c: v_c.map(|v| I16F16::from_bits(q16(v))),
                    v_d: v_d.map(|v| I16F16::from_bits(q16(v))),
                    m_c: U32F32::from_bits(magnitude_q32(v_c)),
                    m_d: U32F32::from_bits(magnitude_q32(v_d)),
                    luma: luma[i],
                };
            }
            black_box(&s.out);
        }
    }
}

/// Parse a binary PGM (P5, maxval 255) into `(width, height, pixels)`.
pub fn read_pgm(path: &str) -> (usize, usize, Vec<u8>) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut fields = Vec::new();
    let mut at = 0;
    while fields.len() < 4 {
        while bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        if bytes[at] == b'#' {
            while bytes[at] != b'\n' {
                at += 1;
            }
            continue;
        }
        let start = at;
        while !bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        fields.push(String::from_utf8_lossy(&bytes[start..at]).into_owned());
    }
    assert_eq!(fields[0], "P5", "{path}: not a binary PGM");
    assert_eq!(fields[3], "255", "{path}: maxval must be 255");
    let (w, h): (usize, usize) = (fields[1].parse().unwrap(), fields[2].parse().unwrap());
    let pixels = bytes[at + 1..at + 1 + w * h].to_vec();
    (w, h, pixels)
}

//! The fixed engine's pass over a textured moving pair, for profilers and
//! for A/B builds (`scripts/profile-stages`): `engine_pass` is `represent`
//! with `Fixed` gains (one pass) over the host engine's strips, as it
//! ships: `scripts/profile-stages` attributes each instruction to the
//! stage inlined at its address (the debug info's inlined subroutines).
//!
//! ```text
//! stage_profile [--size WxH] [--reps N] [--best]  # the pass N times: run under callgrind
//! stage_profile --time [--size WxH] [--best]      # ns/px of the pass, JSON lines
//! stage_profile --digest                  # hash of every output, all sizes
//! ```
//! The pass is the baseline compilation unless `--best`: then the one the
//! CLI runs (`dispatch`, AVX2 where the CPU has it).
//! `--digest` prints an FNV-1a hash of every `FlowPixel` and of the
//! min–max representation of the textured pair at each bench size: two
//! builds (e.g. before and after an optimisation of the core) must print
//! the same lines.
//! Under callgrind, a stage's instructions divided by `reps · W · H` are
//! its instructions per pixel.

use std::hint::black_box;
use std::time::Instant;

use reynoldsflow_core::fixed::types::U16F16;
use reynoldsflow_core::{
    Config, FramePair, Job, Params, Pixels, Plan, Scaling, Sink, SliceEngine, represent,
};

mod common;
use common::{SIZES, moving_pair};
use reynoldsflow_host::internals::HostEngine;
use reynoldsflow_host::internals::bytes::{self, Isa, Pass};
use reynoldsflow_host::internals::strip_width;

const FIXED: Scaling = Scaling::Fixed {
    k_d: U16F16::lit("8"),
    k_c: U16F16::lit("8"),
};

/// The whole engine over the frame: `represent`, `Fixed` gains (one pass),
/// strips of the host engine, compiled for `isa` (`dispatch`).
#[inline(never)]
fn engine_pass(isa: Isa, engine: &mut SliceEngine<'_>, job: &Job<'_>, rgb: &mut [u8]) {
    let pass = Pass::Represent(FIXED, rgb);
    bytes::run(isa, engine, job.plan(), job.frames(), pass, &mut ()).unwrap();
}

/// FNV-1a over every field of every pixel, in the order the sink sees them.
struct Digest(u64);

impl Digest {
    fn eat(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
    }
}

impl Sink for Digest {
    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        self.eat(&(y as u64).to_le_bytes());
        self.eat(&(x as u64).to_le_bytes());
        for px in pixels.iter() {
            for v in px.v_c.iter().chain(&px.v_d) {
                self.eat(&v.to_bits().to_le_bytes());
            }
            self.eat(&px.m_c.to_bits().to_le_bytes());
            self.eat(&px.m_d.to_bits().to_le_bytes());
            self.eat(&[px.luma]);
        }
    }
}

/// Hashes of the outputs at every bench size.
fn digests() {
    for (w, h) in SIZES {
        let (prev, next) = moving_pair(w, h);
        let config = Config::new(w, h, Params::DEFAULT).unwrap();
        let plan = Plan::strips(config, strip_width(w)).unwrap();
        let job = plan
            .bind(FramePair::packed(&config, &prev, &next).unwrap())
            .unwrap();
        let mut memory = HostEngine::new();
        let mut engine = memory.engine(&plan).unwrap();
        let mut pixels = Digest(0xcbf2_9ce4_8422_2325);
        let mut rgb = vec![0u8; 3 * w * h];
        let scaling = Scaling::PerFrameMinMax;
        represent(&mut engine, &job, scaling, &mut rgb, &mut pixels).unwrap();
        let mut bytes = Digest(0xcbf2_9ce4_8422_2325);
        bytes.eat(&rgb);
        println!(
            "{w}x{h}: pixels {:016x}, min-max RGB {:016x}",
            pixels.0, bytes.0
        );
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let (mut w, mut h, mut reps, mut timing) = (640usize, 480usize, 1usize, false);
    let mut strip = None;
    let mut isa = Isa::Portable;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--size" => {
                let s = args.next().expect("--size WxH");
                let (a, b) = s.split_once('x').expect("--size WxH");
                (w, h) = (a.parse().expect("width"), b.parse().expect("height"));
            }
            "--reps" => reps = args.next().and_then(|r| r.parse().ok()).expect("--reps N"),
            "--time" => timing = true,
            "--best" => isa = Isa::Best,
            "--strip" => strip = args.next().and_then(|r| r.parse().ok()),
            "--digest" => return digests(),
            _ => {} // cargo bench's own flags
        }
    }
    let (prev, next) = moving_pair(w, h);
    let config = Config::new(w, h, Params::DEFAULT).unwrap();
    let plan = Plan::strips(config, strip.unwrap_or(strip_width(w))).unwrap();
    let job = plan
        .bind(FramePair::packed(&config, &prev, &next).unwrap())
        .unwrap();
    let mut memory = HostEngine::new();
    let mut engine = memory.engine(&plan).unwrap();
    let mut rgb = vec![0u8; 3 * w * h];
    if !timing {
        for _ in 0..reps {
            engine_pass(isa, &mut engine, &job, &mut rgb);
        }
        black_box(&rgb);
        println!("stage_profile {w}x{h}: {reps} engine pass(es)");
        return;
    }
    let px = (w * h) as f64;
    let times: Vec<f64> = (0..41)
        .map(|_| {
            let t = Instant::now();
            engine_pass(isa, &mut engine, &job, &mut rgb);
            t.elapsed().as_secs_f64() * 1e9 / px
        })
        .collect();
    println!(
        "{{\"size\":\"{w}x{h}\",\"stage\":\"engine (represent, Fixed)\",\"ns_per_px\":{:.4}}}",
        median(times)
    );
}

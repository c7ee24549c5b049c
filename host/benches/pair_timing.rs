//! Milliseconds per frame pair of the fixed engine, for side-by-side runs
//! against other programs (`scripts/bench-vs-opencv`): loads two PGM
//! frames once, warms up, then times `--iters` computations (or as many as
//! fit in `--seconds`) and prints one JSON line with every time in ms.
//! Only the computation is timed, never file I/O.
//!
//! ```text
//! pair_timing --prev A.pgm --next B.pgm --mode MODE [--threads N]
//!             [--seconds S] [--min-iters N] [--warmup N]
//! ```
//! Modes:
//! - `serial`: the core's `represent`, `HostEngine` in 128-px strips,
//!   `Fixed` gains (one engine pass, as when streaming), one thread;
//! - `serial-portable`: `serial` compiled for the baseline (SSE2 on x86-64)
//!   whatever the CPU, where `serial` takes the widest instructions the CPU
//!   has (`reynoldsflow_host::internals::bytes`);
//! - `serial-minmax`: `serial` with per-frame min–max (two engine passes);
//! - `parallel`: the host's one-pair engine (`PairEngine`, what the
//!   GStreamer element and the ROS 2 node run), `Fixed` gains, on
//!   `--threads` threads: tiles balanced over the threads, their
//!   magnitudes kept, then their bytes. (`run` parallelises across pairs
//!   instead; its scaling is timed on the command itself,
//!   `scripts/bench-vs-opencv`.)
//!
//! Without `--prev` (e.g. under `cargo bench`), it times the built-in
//! textured pair at 640×480 in every mode.

use std::hint::black_box;
use std::time::Instant;

use reynoldsflow_core::Scaling;
use reynoldsflow_host::Gray;
use reynoldsflow_host::engine::PairEngine;
use reynoldsflow_host::internals::bytes::Isa;
use reynoldsflow_host::settings::{ScaleArg, Settings};

mod common;
use common::{COLS, FIXED, core_engine, moving_pair, read_gray};

struct Options {
    prev: Option<String>,
    next: Option<String>,
    mode: String,
    threads: usize,
    seconds: f64,
    min_iters: usize,
    warmup: usize,
}

fn options() -> Options {
    let mut o = Options {
        prev: None,
        next: None,
        mode: "serial".into(),
        threads: 1,
        seconds: 1.0,
        min_iters: 10,
        warmup: 3,
    };
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let mut value = || args.next().unwrap_or_else(|| panic!("{arg} needs a value"));
        match arg.as_str() {
            "--prev" => o.prev = Some(value()),
            "--next" => o.next = Some(value()),
            "--mode" => o.mode = value(),
            "--threads" => o.threads = value().parse().expect("--threads"),
            "--seconds" => o.seconds = value().parse().expect("--seconds"),
            "--min-iters" => o.min_iters = value().parse().expect("--min-iters"),
            "--warmup" => o.warmup = value().parse().expect("--warmup"),
            // Flags cargo bench passes to every bench binary (`--bench`, `--quick`, …).
            _ => {}
        }
    }
    o
}

/// One computation of the pair in `mode`.
fn computation(
    mode: &str,
    threads: usize,
    (w, h): (usize, usize),
    prev: &[u8],
    next: &[u8],
) -> Box<dyn FnMut()> {
    match mode {
        "serial" | "serial-minmax" | "serial-portable" => {
            let scaling = if mode == "serial-minmax" {
                Scaling::PerFrameMinMax
            } else {
                FIXED
            };
            let isa = if mode == "serial-portable" {
                Isa::Portable
            } else {
                Isa::Best
            };
            Box::new(core_engine::<COLS>(isa, prev, next, (w, h), None, scaling))
        }
        "parallel" => {
            let prev = Gray::new(w, h, prev.to_vec()).unwrap();
            let next = Gray::new(w, h, next.to_vec()).unwrap();
            let settings = Settings {
                // `FIXED`'s gains, as `--scale fixed:8,8`.
                scale: ScaleArg::Fixed { k_d: 8.0, k_c: 8.0 },
                threads: Some(threads),
                ..Settings::default()
            };
            let mut engine = PairEngine::new(&settings).unwrap();
            let mut rgb = vec![0; 3 * w * h];
            Box::new(move || {
                engine.image(&prev, &next, &mut rgb).unwrap();
                black_box(&rgb);
            })
        }
        other => {
            panic!("unknown --mode {other} (serial, serial-portable, serial-minmax, parallel)")
        }
    }
}

/// Times in ms of at least `min_iters` runs and at least `seconds` in all.
fn time(run: &mut dyn FnMut(), warmup: usize, min_iters: usize, seconds: f64) -> Vec<f64> {
    for _ in 0..warmup {
        run();
    }
    let start = Instant::now();
    let mut times = Vec::new();
    while times.len() < min_iters || start.elapsed().as_secs_f64() < seconds {
        let t = Instant::now();
        run();
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times
}

fn median(times: &[f64]) -> f64 {
    let mut sorted = times.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted[sorted.len() / 2]
}

fn main() {
    let o = options();
    match (&o.prev, &o.next) {
        (Some(prev), Some(next)) => {
            let (w, h, p) = read_gray(prev);
            let (w2, h2, n) = read_gray(next);
            assert_eq!((w, h), (w2, h2), "frames differ in size");
            let mut run = computation(&o.mode, o.threads, (w, h), &p, &n);
            let times = time(&mut *run, o.warmup, o.min_iters, o.seconds);
            let list: Vec<String> = times.iter().map(|t| format!("{t:.4}")).collect();
            println!(
                "{{\"mode\":\"{}\",\"threads\":{},\"width\":{w},\"height\":{h},\"ms\":[{}]}}",
                o.mode,
                o.threads,
                list.join(",")
            );
        }
        _ => {
            let (w, h) = (640, 480);
            let (p, n) = moving_pair(w, h);
            for (mode, threads) in [
                ("serial", 1),
                ("serial-portable", 1),
                ("serial-minmax", 1),
                ("parallel", 1),
                ("parallel", 2),
            ] {
                let mut run = computation(mode, threads, (w, h), &p, &n);
                let times = time(&mut *run, 2, 5, 0.5);
                println!(
                    "pair_timing {w}x{h} {mode:>13} {threads}t: {:8.3} ms/pair (median of {})",
                    median(&times),
                    times.len()
                );
            }
        }
    }
}

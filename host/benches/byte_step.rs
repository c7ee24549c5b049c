//! The host engine's per-frame min–max byte step at 640×480, between the
//! `bench_start` and `bench_stop` markers of the QEMU instruction counter
//! (`scripts/qemu/insncount.c`): `scripts/byte-step-aarch64` runs it under
//! `qemu-aarch64` and prints instructions a pixel.
//!
//! ```text
//! byte_step [--window step|image] [--isa best|portable]
//! ```
//! `step` (the default): the byte step (`kept_to_bytes`) over the kept
//! magnitudes of the textured moving pair, in the scales of their
//! extremes, compiled for `--isa` (default `best`: NEON on aarch64) — the
//! one call `PairEngine::image` makes on one thread; its bytes must be
//! the engine's (checked, exit 1 otherwise). `image`: the whole
//! `PairEngine::image` of the pair on one thread (`--isa` does not apply).
//! The pair, the engine and the buffers are made before the first marker.

use std::hint::black_box;
use std::process;

use reynoldsflow_core::Extremes;
use reynoldsflow_host::Gray;
use reynoldsflow_host::engine::PairEngine;
use reynoldsflow_host::internals::bytes::{Isa, kept_to_bytes};
use reynoldsflow_host::settings::Settings;

mod common;
use common::moving_pair;

/// Frame size of the measurement: a companion board's camera.
const WIDTH: usize = 640;
const HEIGHT: usize = 480;

/// The instruction counter counts from here (QEMU plugin `start=`)...
#[unsafe(no_mangle)]
#[inline(never)]
pub extern "C" fn bench_start() {
    // Different values in each marker, so the two bodies never fold into one.
    black_box(1u32);
}

/// ...to here (`stop=`).
#[unsafe(no_mangle)]
#[inline(never)]
pub extern "C" fn bench_stop() {
    black_box(2u32);
}

/// Counted between the markers, called through opaque pointers so that
/// the markers stay functions of their own.
fn counted<T>(f: impl FnOnce() -> T) -> T {
    black_box(bench_start as extern "C" fn())();
    let out = f();
    black_box(bench_stop as extern "C" fn())();
    out
}

fn usage() -> ! {
    eprintln!("usage: byte_step [--window step|image] [--isa best|portable]");
    process::exit(2);
}

fn main() {
    let (mut image_window, mut isa) = (false, Isa::Best);
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match (arg.as_str(), args.next().as_deref()) {
            ("--window", Some("step")) => image_window = false,
            ("--window", Some("image")) => image_window = true,
            ("--isa", Some("best")) => isa = Isa::Best,
            ("--isa", Some("portable")) => isa = Isa::Portable,
            _ => usage(),
        }
    }
    let (prev, next) = moving_pair(WIDTH, HEIGHT);
    let frame = |pixels| Gray::new(WIDTH, HEIGHT, pixels).expect("640x480 frame");
    let (prev, next) = (frame(prev), frame(next));
    let settings = Settings {
        threads: Some(1),
        ..Settings::default()
    };
    let mut engine = PairEngine::new(&settings)
        .expect("default settings")
        .keep_magnitudes(true);
    let mut rgb = vec![0u8; 3 * WIDTH * HEIGHT];
    if image_window {
        counted(|| engine.image(&prev, &next, &mut rgb)).expect("a valid pair");
        black_box(&rgb);
        println!("byte_step: PairEngine::image of a {WIDTH}x{HEIGHT} pair, one thread");
        return;
    }
    engine.image(&prev, &next, &mut rgb).expect("a valid pair");
    let kept = engine.magnitudes().expect("magnitudes kept");
    let [scale_d, scale_c] = [kept.m_d, kept.m_c].map(|plane| {
        let mut extremes = Extremes::EMPTY;
        extremes.add_all(plane);
        extremes.byte_scale()
    });
    let mut bytes = vec![0u8; rgb.len()];
    let planes = [kept.m_d, kept.m_c];
    counted(|| kept_to_bytes(isa, planes, kept.luma, &mut bytes, &[scale_d, scale_c]));
    if bytes != rgb {
        eprintln!("byte_step: the step's bytes differ from PairEngine::image's");
        process::exit(1);
    }
    println!("byte_step: {isa:?} byte step of a {WIDTH}x{HEIGHT} pair, the engine's bytes");
}

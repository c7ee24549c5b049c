//! Throughput of the fixed engine per tile shape (the "Memory and tiling" table of docs/firmware.md):
//! the full representation (`Fixed` gains, one pass) of a textured moving
//! pair at 160×120, 320×240 and 640×480, one engine, one thread.
//!
//! `cargo bench -p reynoldsflow-host --bench tiling`

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use reynoldsflow_core::Engine;

use reynoldsflow_host::internals::bytes::Isa;

mod common;
use common::{COLS, FIXED, STRIPS, core_engine};

/// A textured frame moved by (t, t/2) px: every stage has work to do.
fn frame(w: usize, h: usize, t: f64) -> Vec<u8> {
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64 - t, (i / w) as f64 - t / 2.0);
            (128.0 + 60.0 * (0.21 * x).sin() * (0.17 * y).cos() + 40.0 * (0.05 * (x + y)).sin())
                as u8
        })
        .collect()
}

/// One tile shape: an engine of `COLS` columns computing `tile` tiles.
fn bench_shape<const COLS: usize>(c: &mut Criterion, w: usize, h: usize, tile: (usize, usize)) {
    let (prev, next) = (frame(w, h, 0.0), frame(w, h, 1.0));
    let mut run = core_engine::<COLS>(Isa::Best, &prev, &next, (w, h), Some(tile), FIXED);
    let mut group = c.benchmark_group(format!("tiling/{w}x{h}"));
    group.throughput(Throughput::Elements((w * h) as u64));
    let name = format!(
        "{}x{} ({} B)",
        tile.0.min(w),
        tile.1.min(h),
        Engine::<COLS>::WORKING_BYTES
    );
    group.bench_function(BenchmarkId::from_parameter(name), |b| b.iter(&mut run));
    group.finish();
}

/// Tile shapes: 32×32 squares, 64-, 80- and 128-px strips, and the full
/// width (an engine exactly as wide as the frame).
fn tiling(c: &mut Criterion) {
    fn shapes<const FULL: usize>(c: &mut Criterion, w: usize, h: usize) {
        bench_shape::<46>(c, w, h, (32, 32));
        bench_shape::<78>(c, w, h, (64, h));
        bench_shape::<94>(c, w, h, (80, h));
        bench_shape::<COLS>(c, w, h, (STRIPS, h));
        bench_shape::<FULL>(c, w, h, (w, h));
    }
    shapes::<174>(c, 160, 120);
    shapes::<334>(c, 320, 240);
    shapes::<654>(c, 640, 480);
}

criterion_group!(benches, tiling);
criterion_main!(benches);

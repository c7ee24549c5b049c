//! Throughput of the whole representation `F_R` of a textured moving pair
//! at 160×120, 320×240, 640×480 and 1280×720:
//! - `core/strips`: the fixed engine (`HostEngine`, full-height 128-px
//!   strips) through `represent`, `Fixed` gains (one engine pass, as when
//!   streaming), one thread;
//! - `core/strips-minmax`: the same with per-frame min–max (two passes);
//! - `core/tiles-64x64`: an `Engine<78>` over 64×64 tiles, `Fixed`;
//! - `host/planes`: the host's whole-frame path with every plane out
//!   (`PairEngine::fields`: per-frame min–max in one pass, f64 planes),
//!   one thread, as `run --npy` and `pair` compute;
//! - `host/rgb`: the same path, the bytes alone (`PairEngine::image`,
//!   per-frame min–max), as `run` computes by default;
//! - `float/reference`: the float64 reference, `compute` + `representation`.
//!
//! `cargo bench -p reynoldsflow-host --bench representation [-- --quick]`

use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use reynoldsflow_core::Scaling;
use reynoldsflow_host::Gray;
use reynoldsflow_host::engine::PairEngine;
use reynoldsflow_host::reference::{FloatParams, FloatScaling, compute, representation};
use reynoldsflow_host::settings::Settings;

use reynoldsflow_host::internals::bytes::Isa;

mod common;
use common::{COLS, FIXED, SIZES, core_engine, moving_pair};

fn representation_benches(c: &mut Criterion) {
    for (w, h) in SIZES {
        let (prev, next) = moving_pair(w, h);
        let (gprev, gnext) = (
            Gray::new(w, h, prev.clone()).unwrap(),
            Gray::new(w, h, next.clone()).unwrap(),
        );
        let mut group = c.benchmark_group(format!("representation/{w}x{h}"));
        group.throughput(Throughput::Elements((w * h) as u64));
        if w * h > 320 * 240 {
            group.sample_size(10);
        }
        let mut run = core_engine::<COLS>(Isa::Best, &prev, &next, (w, h), None, FIXED);
        group.bench_function(BenchmarkId::from_parameter("core/strips"), |b| {
            b.iter(&mut run)
        });
        let mut run = core_engine::<COLS>(
            Isa::Best,
            &prev,
            &next,
            (w, h),
            None,
            Scaling::PerFrameMinMax,
        );
        group.bench_function(BenchmarkId::from_parameter("core/strips-minmax"), |b| {
            b.iter(&mut run)
        });
        let mut run = core_engine::<78>(Isa::Best, &prev, &next, (w, h), Some((64, 64)), FIXED);
        group.bench_function(BenchmarkId::from_parameter("core/tiles-64x64"), |b| {
            b.iter(&mut run)
        });
        // The engine at the defaults (per-frame min–max), one thread.
        let settings = Settings {
            threads: Some(1),
            ..Settings::default()
        };
        let mut engine = PairEngine::new(&settings).unwrap();
        let mut rgb = vec![0; 3 * w * h];
        group.bench_function(BenchmarkId::from_parameter("host/planes"), |b| {
            b.iter(|| engine.fields(&gprev, &gnext).unwrap())
        });
        group.bench_function(BenchmarkId::from_parameter("host/rgb"), |b| {
            b.iter(|| engine.image(&gprev, &gnext, &mut rgb).unwrap())
        });
        group.bench_function(BenchmarkId::from_parameter("float/reference"), |b| {
            b.iter(|| {
                let flow = compute(&gprev, &gnext, &FloatParams::default()).unwrap();
                representation(&flow, &gprev, FloatScaling::PerFrameMinMax)
            })
        });
        group.finish();
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(15)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    targets = representation_benches
}
criterion_main!(benches);

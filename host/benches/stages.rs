//! Throughput of each stage kernel of the fixed engine on its own
//! (`reynoldsflow_core::internals`), at 160×120, 320×240, 640×480 and
//! 1280×720: every call the host engine (`Engine<142>`, 128-px strips)
//! makes for a frame, on the real inputs of a textured moving pair
//! (recorded by a stage-by-stage mirror of the engine that is checked
//! against it). Throughput is frame pixels per second, so the stages'
//! times add up to about the engine's (the rest is loading rows, ring
//! bookkeeping and the sink).
//!
//! `cargo bench -p reynoldsflow-host --bench stages [-- --quick]`

use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};

mod common;
use common::{SIZES, Scratch, Stage, Strip, moving_pair};

fn stages(c: &mut Criterion) {
    for (w, h) in SIZES {
        let (prev, next) = moving_pair(w, h);
        let strip = Strip::record(w, h, &prev, &next);
        let tiles = strip.tiles();
        let mut scratch = Scratch::new();
        let mut group = c.benchmark_group(format!("stages/{w}x{h}"));
        group.throughput(Throughput::Elements(strip.pixels() as u64));
        for stage in Stage::ALL {
            group.bench_function(BenchmarkId::from_parameter(stage.name()), |b| {
                b.iter(|| stage.run(&strip, &tiles, &mut scratch))
            });
        }
        group.finish();
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(20)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    targets = stages
}
criterion_main!(benches);

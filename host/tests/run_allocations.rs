//! A warm `run` allocates no frame-sized memory per pair: frames, engines
//! and output buffers are reused. Counted with a global allocator, so this
//! file holds one test (no other test allocates while it counts).

use std::alloc::{GlobalAlloc, Layout, System};
use std::io::Cursor;
use std::sync::atomic::{AtomicUsize, Ordering};

use reynoldsflow_core::IntensityScale;
use reynoldsflow_host::engine::Compute;
use reynoldsflow_host::limits::Limits;
use reynoldsflow_host::outputs::{OutputSpec, StreamFormat};
use reynoldsflow_host::pipeline::{self, Destination, Options};
use reynoldsflow_host::sequence::y4m::Y4mSource;
use reynoldsflow_host::settings::{EngineKind, ScaleArg};

const W: usize = 160;
const H: usize = 120;

/// Allocations of at least half a gray frame: pixel-sized buffers.
static LARGE: AtomicUsize = AtomicUsize::new(0);

struct Counting;

// SAFETY: forwards every call to the system allocator unchanged.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() >= W * H / 2 {
            LARGE.fetch_add(1, Ordering::SeqCst);
        }
        // SAFETY: the caller's contract is passed on as it stands.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size >= W * H / 2 {
            LARGE.fetch_add(1, Ordering::SeqCst);
        }
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// A Y4M stream of `n` textured frames moving right by 1 px per frame.
fn y4m(n: usize) -> Vec<u8> {
    let mut bytes = format!("YUV4MPEG2 W{W} H{H} F25:1 Cmono\n").into_bytes();
    for t in 0..n {
        bytes.extend_from_slice(b"FRAME\n");
        bytes.extend((0..W * H).map(|i| {
            let (x, y) = (i % W + 1000 - t, i / W);
            ((x * 37 + y * 11 + (x * y) % 23) % 251) as u8
        }));
    }
    bytes
}

/// Large allocations of a whole run of `frames` frames streamed in `format`.
fn large_allocations(
    frames: usize,
    scale: ScaleArg,
    format: StreamFormat,
    threads: usize,
) -> usize {
    let input = y4m(frames);
    let compute = Compute::new(
        EngineKind::Fixed,
        scale,
        IntensityScale::PER_255,
        1e-4,
        None,
    )
    .unwrap();
    let spec = OutputSpec::default();
    let mut out = std::io::sink();
    let before = LARGE.load(Ordering::SeqCst);
    let mut source = Y4mSource::new(
        "test.y4m".into(),
        Box::new(Cursor::new(input)),
        None,
        Limits::default(),
    )
    .unwrap();
    let summary = pipeline::process(
        &mut source,
        &compute,
        Destination::Stream {
            spec: &spec,
            format,
            writer: &mut out,
        },
        Options::new(threads),
        &mut || {},
    )
    .unwrap();
    assert_eq!(summary.results, frames - 1);
    LARGE.load(Ordering::SeqCst) - before
}

#[test]
fn a_warm_run_allocates_no_frame_sized_memory_per_pair() {
    let fixed = ScaleArg::Fixed {
        k_d: 8.0,
        k_c: 32.0,
    };
    for (scale, format, threads) in [
        (ScaleArg::MinMax, StreamFormat::Rgb24, 1),
        (ScaleArg::MinMax, StreamFormat::Y4m, 2),
        (fixed, StreamFormat::Rgb24, 2),
    ] {
        // 60 pairs: a buffer allocated per pair would count at least 59.
        let large = large_allocations(61, scale, format, threads);
        // What warms up: frames, payloads and images in flight (at most
        // 2 · threads pairs), each worker's magnitude plane and scratch.
        let bound = 8 * threads + 8;
        eprintln!(
            "{scale:?} {format:?} {threads} threads: {large} large allocations (bound {bound})"
        );
        assert!(
            large <= bound,
            "{scale:?} {format:?} {threads} threads: {large} > {bound}"
        );
    }
}

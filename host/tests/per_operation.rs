//! The input limits and the stop token are values each operation is given,
//! not settings of the process: two operations of one process, run at the
//! same time with different ones, do not affect each other.

use std::io::Cursor;

use reynoldsflow_core::IntensityScale;
use reynoldsflow_host::engine::Compute;
use reynoldsflow_host::limits::Limits;
use reynoldsflow_host::outputs::{OutputSpec, StreamFormat};
use reynoldsflow_host::pipeline::{self, Destination, Options, Summary};
use reynoldsflow_host::sequence::y4m::Y4mSource;
use reynoldsflow_host::sequence::{self, FrameSource, InputSpec};
use reynoldsflow_host::settings::{EngineKind, ScaleArg};
use reynoldsflow_host::stop::Stop;
use reynoldsflow_host::{HostError, io::image_file};

const W: usize = 16;
const H: usize = 8;

/// `n` frames of `W × H` as a Y4M stream (fixed content).
fn y4m(n: usize) -> Vec<u8> {
    let mut bytes = format!("YUV4MPEG2 W{W} H{H} F25:1 Cmono\n").into_bytes();
    for t in 0..n {
        bytes.extend_from_slice(b"FRAME\n");
        bytes.extend((0..W * H).map(|i| ((i * 37 + t * 11) % 251) as u8));
    }
    bytes
}

/// A binary PGM of `W × H`.
fn pgm() -> Vec<u8> {
    let mut bytes = format!("P5 {W} {H} 255\n").into_bytes();
    bytes.extend((0..W * H).map(|i| (i % 251) as u8));
    bytes
}

#[test]
fn two_operations_with_different_limits_do_not_affect_each_other() {
    let dir = tempfile::tempdir().unwrap();
    let clip = dir.path().join("clip.y4m");
    std::fs::write(&clip, y4m(3)).unwrap();
    let spec = InputSpec::Path {
        path: clip.clone(),
        raw: None,
    };
    let (tight, ample) = (Limits::new((W * H - 1) as u64), Limits::default());
    // Interleaved on two threads, many times: a limit of the process would
    // let one side's setting leak into the other's reads.
    std::thread::scope(|scope| {
        let refused = scope.spawn(|| {
            for _ in 0..200 {
                let err = sequence::open(&spec, tight).err().expect("over the limit");
                assert!(
                    matches!(err, HostError::Setting { .. })
                        && err.to_string().starts_with("max_pixels: "),
                    "{err}"
                );
                let err = image_file::decode_gray(&pgm(), tight).unwrap_err();
                assert!(
                    err.to_string().contains("exceeds the limit of 127 pixels"),
                    "{err}"
                );
            }
        });
        let read = scope.spawn(|| {
            for _ in 0..200 {
                let mut source = sequence::open(&spec, ample).unwrap();
                let mut frames = 0;
                while source.next_frame().unwrap().is_some() {
                    frames += 1;
                }
                assert_eq!(frames, 3);
                assert_eq!(
                    image_file::decode_gray(&pgm(), ample).unwrap().size(),
                    (W, H)
                );
            }
        });
        refused.join().unwrap();
        read.join().unwrap();
    });
    // A source opened within its limits keeps reading whatever limits
    // another operation is opened with afterwards.
    let mut open = sequence::open(&spec, ample).unwrap();
    assert!(sequence::open(&spec, tight).is_err());
    assert!(open.next_frame().unwrap().is_some());
}

/// `frames` frames streamed through the fixed engine on `threads`
/// workers, `stop` set after `stop_after` results (never with `None`):
/// the run's result and the results delivered.
fn run(
    frames: usize,
    threads: usize,
    stop: &Stop,
    stop_after: Option<usize>,
) -> (Result<Summary, HostError>, usize) {
    let compute = Compute::new(
        EngineKind::Fixed,
        ScaleArg::MinMax,
        IntensityScale::PER_255,
        1e-4,
        None,
    )
    .unwrap();
    let spec = OutputSpec::default();
    let mut source = Y4mSource::new(
        "clip.y4m".into(),
        Box::new(Cursor::new(y4m(frames))),
        None,
        Limits::default(),
    )
    .unwrap();
    let mut out = std::io::sink();
    let mut delivered = 0;
    let result = pipeline::process(
        &mut source as &mut dyn FrameSource,
        &compute,
        Destination::Stream {
            spec: &spec,
            format: StreamFormat::Rgb24,
            writer: &mut out,
        },
        Options {
            stop: stop.clone(),
            ..Options::new(threads)
        },
        &mut || {
            delivered += 1;
            if Some(delivered) == stop_after {
                stop.stop();
            }
        },
    );
    (result, delivered)
}

#[test]
fn a_stop_token_stops_its_run_and_no_other() {
    const FRAMES: usize = 200;
    for threads in [1, 2] {
        let (stopped, free) = (Stop::new(), Stop::new());
        let ((result, delivered), (other, other_delivered)) = std::thread::scope(|scope| {
            let stopped = scope.spawn(|| run(FRAMES, threads, &stopped, Some(2)));
            let free = scope.spawn(|| run(FRAMES, threads, &free, None));
            (stopped.join().unwrap(), free.join().unwrap())
        });
        let err = result.expect_err("stopped");
        assert!(
            matches!(&err, HostError::Io { source, .. }
                if source.kind() == std::io::ErrorKind::Interrupted),
            "{err}"
        );
        // Pairs in flight finish; no new one starts.
        assert!((2..FRAMES / 2).contains(&delivered), "{delivered}");
        assert!(!free.is_stopped());
        assert_eq!(other.unwrap().outputs, FRAMES - 1);
        assert_eq!(other_delivered, FRAMES - 1);
    }
    // A token set before the run: nothing is computed.
    let stop = Stop::new();
    stop.stop();
    let (result, delivered) = run(10, 1, &stop, None);
    assert!(result.is_err());
    assert_eq!(delivered, 0);
}

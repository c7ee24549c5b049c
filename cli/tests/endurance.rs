//! An endless stream in flat memory: 20 000 frames of 320×240 through
//! `reynoldsflow run - --raw 320x240 --out - --format rgb24`, resident
//! memory read from /proc while it runs: after the first 1 000 results,
//! halfway and at the end.
//!
//! The buffer pools grow when a pair is late (a busy machine), by one
//! buffer at a time, up to a bound: a step, once. A leak grows in both
//! halves of the run; the test fails on growth in both, and on any step
//! above a few buffers.
//!
//! The stream is 1.5 G pixels, minutes in the test profile: this test runs
//! in the release profile, from scripts/test
//! (`cargo test --release -p reynoldsflow-cli --test endurance`).

use std::io::{Read, Write};
use std::process::{Command, Stdio};
use std::sync::mpsc;

mod child_support;
mod run_support;

use child_support::status_kib;

const W: usize = 320;
const H: usize = 240;
const FRAMES: usize = 20_000;
const EARLY: usize = 1_000;
const MIDDLE: usize = FRAMES / 2;
/// The most one half of the run may grow by without counting as growth.
const FLAT_KIB: u64 = 512;
/// The most the pools may grow by in all: a few 2 MiB payload mappings.
const BOUND_KIB: u64 = 8 * 1024;

/// Frame `t`: a textured scene panning right, one column a frame, with a
/// fixed-pattern grain (so every pair has motion and texture).
fn frame(scene: &[u8], scene_w: usize, t: usize) -> Vec<u8> {
    let x0 = t % (scene_w - W);
    (0..H)
        .flat_map(|y| &scene[y * scene_w + x0..y * scene_w + x0 + W])
        .copied()
        .collect()
}

#[cfg_attr(
    debug_assertions,
    ignore = "1.5 G pixels: runs in the release profile from scripts/test"
)]
#[test]
fn resident_memory_is_flat_over_20000_frames() {
    let scene_w = W + 997;
    let scene: Vec<u8> = run_support::moving_frame(scene_w, H, 0).pixels;
    let mut child = Command::new(run_support::BIN)
        .args([
            "run", "-", "--raw", "320x240", "--out", "-", "--format", "rgb24",
        ])
        .args(["--threads", "2"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start reynoldsflow");
    let pid = child.id();
    let mut stdin = child.stdin.take().unwrap();
    // The feeder keeps stdin open after the last frame until the end has
    // been measured, so the process is alive to be read.
    let (close_tx, close_rx) = mpsc::channel::<()>();
    let feeder = std::thread::spawn(move || {
        for t in 0..FRAMES {
            stdin.write_all(&frame(&scene, scene_w, t)).unwrap();
        }
        let _ = close_rx.recv();
        drop(stdin);
    });
    let mut stdout = child.stdout.take().unwrap();
    let result = 3 * W * H;
    // Each figure is the highest VmRSS over a window of 50 results, both
    // windows with the pipeline busy (pairs in flight come and go within a
    // window; growth would show between them).
    let windows = [
        EARLY - 50..EARLY,
        MIDDLE - 50..MIDDLE,
        FRAMES - 150..FRAMES - 100,
    ];
    let (mut received, mut buf) = (0usize, vec![0u8; 1 << 16]);
    let mut rss = [0u64; 3];
    loop {
        let n = stdout.read(&mut buf).unwrap();
        assert!(n > 0, "the stream ended early, after {received} bytes");
        received += n;
        let results = received / result;
        for (window, kib) in windows.iter().zip(&mut rss) {
            if window.contains(&results) {
                *kib = (*kib).max(status_kib(pid, "VmRSS"));
            }
        }
        // Every pair computed: FRAMES − 1 results, the last input consumed.
        if results == FRAMES - 1 && received % result == 0 {
            break;
        }
    }
    let peak = status_kib(pid, "VmHWM");
    close_tx.send(()).unwrap();
    feeder.join().unwrap();
    let mut rest = Vec::new();
    stdout.read_to_end(&mut rest).unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        rest.is_empty(),
        "{} bytes after the last result",
        rest.len()
    );
    let [early, middle, late] = rss;
    let report = format!(
        "{FRAMES} frames of {W}x{H}: VmRSS {early} KiB around result {EARLY}, {middle} KiB \
         around {MIDDLE}, {late} KiB near the end ({:+} KiB, {:+} KiB); peak {peak} KiB",
        middle as i64 - early as i64,
        late as i64 - middle as i64
    );
    println!("{report}");
    let grew = |from: u64, to: u64| to.saturating_sub(from) > FLAT_KIB;
    assert!(
        !(grew(early, middle) && grew(middle, late)),
        "grew in both halves: {report}"
    );
    assert!(
        late.saturating_sub(early) <= BOUND_KIB,
        "grew past the pools' bound: {report}"
    );
}

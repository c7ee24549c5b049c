//! An endless stream in flat memory: 20 000 frames of 320×240 through
//! `reynoldsflow run - --raw 320x240 --out - --format rgb24`, resident
//! memory read from /proc while it runs, after the first 1 000 results and
//! at the end.
//!
//! The stream is 1.5 G pixels, minutes in the test profile: this test runs
//! in the release profile, from scripts/test
//! (`cargo test --release -p reynoldsflow-host --test endurance`).

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
    let (early_window, late_window) = (EARLY - 50..EARLY, FRAMES - 150..FRAMES - 100);
    let (mut received, mut buf) = (0usize, vec![0u8; 1 << 16]);
    let (mut early, mut late) = (0u64, 0u64);
    loop {
        let n = stdout.read(&mut buf).unwrap();
        assert!(n > 0, "the stream ended early, after {received} bytes");
        received += n;
        let results = received / result;
        if early_window.contains(&results) {
            early = early.max(status_kib(pid, "VmRSS"));
        }
        if late_window.contains(&results) {
            late = late.max(status_kib(pid, "VmRSS"));
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
    println!(
        "{FRAMES} frames of {W}x{H}: VmRSS {early} KiB around result {EARLY}, {late} KiB near the end ({:+} KiB); peak {peak} KiB",
        late as i64 - early as i64
    );
    assert!(
        late.abs_diff(early) <= 1024,
        "VmRSS {early} KiB around result {EARLY}, {late} KiB near the end"
    );
}

//! `reynoldsflow verify` end to end, through the built binary: `run`'s own
//! streams and folders verify; a changed byte is reported at its frame,
//! pixel and channel; `--tolerance`; frame counts and truncation; and bad
//! command lines exit 2.

mod run_support;

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Output;

use run_support::*;

const W: usize = 40;
const H: usize = 30;
/// Input frames; `run` gives one result per consecutive pair.
const N: usize = 5;
const RESULTS: usize = N - 1;
/// Bytes of one RGB24 frame.
const FRAME: usize = 3 * W * H;

/// `N` moving frames as `dir/src/f0.pgm` … (run's outputs: `f0` … `f3`).
fn clip(dir: &Path) -> PathBuf {
    let src = dir.join("src");
    let frames: Vec<_> = (0..N).map(|t| moving_frame(W, H, t)).collect();
    write_pgms(&src, &frames);
    src
}

/// What `run SRC --out - --format FORMAT [flags]` writes.
fn stream(src: &Path, format: &str, flags: &[&str]) -> Vec<u8> {
    let mut a = args!["run", src, "--out", "-", "--format", format].to_vec();
    a.extend(flags.iter().map(Into::into));
    let out = run(&a);
    ok(&out);
    out.stdout
}

fn verify(input: &Path, captured: &Path, flags: &[&str]) -> Output {
    let mut a = args!["verify", input, captured].to_vec();
    a.extend(flags.iter().map(Into::into));
    run(&a)
}

fn code(out: &Output) -> Option<i32> {
    out.status.code()
}

/// The `key=value` fields of the report's machine line (exactly one).
fn fields(out: &Output) -> BTreeMap<String, String> {
    let text = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = text.lines().filter(|l| l.starts_with("frames=")).collect();
    assert_eq!(lines.len(), 1, "one machine line in:\n{text}");
    lines[0]
        .split(' ')
        .map(|kv| {
            let (k, v) = kv.split_once('=').unwrap_or_else(|| panic!("{kv:?}"));
            (k.to_owned(), v.to_owned())
        })
        .collect()
}

#[track_caller]
fn assert_fields(out: &Output, want: &[(&str, &str)]) {
    let got = fields(out);
    for (k, v) in want {
        assert_eq!(
            got.get(*k).map(String::as_str),
            Some(*v),
            "{k} in {got:?}; stderr: {}",
            stderr(out)
        );
    }
}

/// Exit 0 and a pass over all `RESULTS` frames, nothing differing.
#[track_caller]
fn assert_identical(out: &Output) {
    assert_eq!(code(out), Some(0), "stderr: {}", stderr(out));
    let results = RESULTS.to_string();
    assert_fields(
        out,
        &[
            ("frames", &results),
            ("expected_frames", &results),
            ("captured_frames", &results),
            ("pixels_differing", "0"),
            ("max_diff", "0"),
            ("first_diff", "none"),
            ("result", "pass"),
        ],
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.starts_with("reynoldsflow verify: PASS (identical)"),
        "{text}"
    );
}

/// Where byte `offset` of an RGB24 frame is: (x, y, channel name).
fn rgb_place(offset: usize) -> (usize, usize, &'static str) {
    let pixel = offset / 3;
    (pixel % W, pixel / W, ["R", "G", "B"][offset % 3])
}

#[test]
fn runs_own_streams_verify_from_files_and_stdin() {
    let tmp = tempfile::tempdir().unwrap();
    let src = clip(tmp.path());

    let rgb = stream(&src, "rgb24", &[]);
    assert_eq!(rgb.len(), RESULTS * FRAME);
    let rgb_file = tmp.path().join("device.rgb");
    fs::write(&rgb_file, &rgb).unwrap();
    assert_identical(&verify(&src, &rgb_file, &[]));

    let y4m = stream(&src, "y4m", &[]);
    let y4m_file = tmp.path().join("device.y4m");
    fs::write(&y4m_file, &y4m).unwrap();
    let out = verify(&src, &y4m_file, &[]);
    assert_identical(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("(y4m)"));

    // The capture on stdin: raw RGB24, or Y4M told by its header.
    for bytes in [&rgb, &y4m] {
        assert_identical(&run_with(
            &args!["verify", src, "-"],
            Some(bytes.as_slice()),
            &[],
        ));
    }
    // Any input run reads: here raw gray frames on stdin.
    let raw: Vec<u8> = (0..N).flat_map(|t| moving_frame(W, H, t).pixels).collect();
    assert_identical(&run_with(
        &args!["verify", "-", rgb_file, "--raw", "40x30"],
        Some(&raw),
        &[],
    ));
}

#[test]
fn the_settings_flags_are_runs_and_they_matter() {
    let tmp = tempfile::tempdir().unwrap();
    let src = clip(tmp.path());
    let flags = [
        "--engine",
        "float",
        "--scale",
        "fixed:8,32",
        "--variant",
        "cd",
    ];
    let file = tmp.path().join("float.rgb");
    fs::write(&file, stream(&src, "rgb24", &flags)).unwrap();
    assert_identical(&verify(&src, &file, &flags));
    // Recomputed with the defaults, the same capture fails from its first frame.
    let out = verify(&src, &file, &[]);
    assert_eq!(code(&out), Some(1), "{}", stderr(&out));
    assert_fields(&out, &[("result", "fail")]);
    assert!(fields(&out)["first_diff"].starts_with("frame:0,"));

    // --keep-count: N frames in the stream, and verify must be told so.
    let kept = tmp.path().join("kept.rgb");
    fs::write(&kept, stream(&src, "rgb24", &["--keep-count"])).unwrap();
    let out = verify(&src, &kept, &["--keep-count"]);
    assert_eq!(code(&out), Some(0), "{}", stderr(&out));
    assert_fields(&out, &[("frames", "5"), ("expected_frames", "5")]);
    let out = verify(&src, &kept, &[]);
    assert_eq!(code(&out), Some(1));
    assert!(
        stderr(&out).contains("the captured stream has 5 frames, the input gives 4"),
        "{}",
        stderr(&out)
    );
    // --max-frames reads fewer input frames, as run does.
    let short = tmp.path().join("short.rgb");
    fs::write(&short, stream(&src, "rgb24", &["--max-frames", "3"])).unwrap();
    let out = verify(&src, &short, &["--max-frames", "3"]);
    assert_eq!(code(&out), Some(0), "{}", stderr(&out));
    assert_fields(&out, &[("frames", "2")]);
}

#[test]
fn a_flipped_byte_is_named_by_frame_pixel_and_channel() {
    let tmp = tempfile::tempdir().unwrap();
    let src = clip(tmp.path());
    let good = stream(&src, "rgb24", &[]);
    let k = 2;
    // The middle of frame k, off the start of a pixel so the channel is not R.
    let offset = FRAME / 2 + 1;
    let (x, y, channel) = rgb_place(offset);
    assert_eq!((x, y, channel), (0, 15, "G"), "the place this test means");
    let mut bad = good.clone();
    bad[k * FRAME + offset] ^= 0x80;
    let file = tmp.path().join("bad.rgb");
    fs::write(&file, &bad).unwrap();
    let out = verify(&src, &file, &[]);
    assert_eq!(code(&out), Some(1), "{}", stderr(&out));
    let place = format!("frame:{k},x:{x},y:{y},channel:{channel}");
    assert_fields(
        &out,
        &[
            ("frames", "4"),
            ("pixels_differing", "1"),
            ("max_diff", "128"),
            ("first_diff", &place),
            ("result", "fail"),
        ],
    );
    let err = stderr(&out);
    assert_eq!(err.lines().count(), 1, "{err}");
    let (want, got) = (good[k * FRAME + offset], bad[k * FRAME + offset]);
    assert!(
        err.starts_with("reynoldsflow: error: ")
            && err.contains(&format!(
                "1 pixel differs from the recomputed representation (largest difference 128); \
                 first at frame {k}, x {x}, y {y}, channel {channel} (expected {want}, captured {got})"
            )),
        "{err}"
    );

    // In a Y4M capture the planes are compared: a byte of frame k's Cr plane.
    let mut y4m = stream(&src, "y4m", &[]);
    let header = y4m.iter().position(|&b| b == b'\n').unwrap() + 1;
    let per_frame = b"FRAME\n".len() + FRAME;
    let p = 7 * W + 33;
    y4m[header + k * per_frame + 6 + 2 * W * H + p] ^= 0x01;
    let file = tmp.path().join("bad.y4m");
    fs::write(&file, &y4m).unwrap();
    let out = verify(&src, &file, &[]);
    assert_eq!(code(&out), Some(1), "{}", stderr(&out));
    assert_fields(
        &out,
        &[
            ("pixels_differing", "1"),
            ("max_diff", "1"),
            ("first_diff", "frame:2,x:33,y:7,channel:Cr"),
        ],
    );
}

#[test]
fn tolerance_allows_that_many_and_no_more() {
    let tmp = tempfile::tempdir().unwrap();
    let src = clip(tmp.path());
    let good = stream(&src, "rgb24", &[]);
    // A byte of frame 1 that can take +2.
    let at = FRAME
        + (FRAME / 3..FRAME)
            .find(|&i| good[FRAME + i] <= 253)
            .unwrap();
    let (x, y, channel) = rgb_place(at - FRAME);
    let place = format!("frame:1,x:{x},y:{y},channel:{channel}");
    let changed = |by: u8| {
        let mut bytes = good.clone();
        bytes[at] += by;
        let file = tmp.path().join(format!("plus{by}.rgb"));
        fs::write(&file, bytes).unwrap();
        file
    };

    let plus1 = changed(1);
    let out = verify(&src, &plus1, &["--tolerance", "1"]);
    assert_eq!(code(&out), Some(0), "{}", stderr(&out));
    assert_fields(
        &out,
        &[
            ("pixels_differing", "1"),
            ("max_diff", "1"),
            ("first_diff", &place),
            ("first_over_tolerance", "none"),
            ("tolerance", "1"),
            ("result", "pass"),
        ],
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("PASS (within tolerance)"));
    // Not identical, so without --tolerance it fails.
    let out = verify(&src, &plus1, &[]);
    assert_eq!(code(&out), Some(1));
    assert_fields(&out, &[("first_diff", &place), ("result", "fail")]);

    let out = verify(&src, &changed(2), &["--tolerance", "1"]);
    assert_eq!(code(&out), Some(1), "{}", stderr(&out));
    assert_fields(
        &out,
        &[
            ("max_diff", "2"),
            ("first_over_tolerance", &place),
            ("result", "fail"),
        ],
    );
    assert!(
        stderr(&out).contains("by more than --tolerance 1"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn runs_png_folder_verifies_and_a_changed_png_is_named() {
    let tmp = tempfile::tempdir().unwrap();
    let src = clip(tmp.path());
    let dir = tmp.path().join("pngs");
    // --viz adds a subfolder (hsv/) that verify leaves alone.
    ok(&run(&args!["run", src, "--out", dir, "--viz"]));
    assert_identical(&verify(&src, &dir, &[]));
    assert_identical(&verify(&src, &dir, &["--captured-format", "png-dir"]));
    // The PNGs hold exactly the stream's bytes.
    let rgb = stream(&src, "rgb24", &[]);
    assert_eq!(
        rgb[2 * FRAME..3 * FRAME],
        run_support::rgb(&dir.join("f2.png"))
    );

    // Frame 2 replaced by frame 1: found in frame 2, its file named.
    fs::copy(dir.join("f1.png"), dir.join("f2.png")).unwrap();
    let out = verify(&src, &dir, &[]);
    assert_eq!(code(&out), Some(1), "{}", stderr(&out));
    assert!(
        fields(&out)["first_diff"].starts_with("frame:2,"),
        "{:?}",
        fields(&out)
    );
    assert!(
        stderr(&out).contains("first at frame 2 (f2.png), x "),
        "{}",
        stderr(&out)
    );

    // One PNG missing: a count the report states.
    fs::remove_file(dir.join("f3.png")).unwrap();
    let out = verify(&src, &dir, &[]);
    assert_eq!(code(&out), Some(1));
    assert_fields(&out, &[("captured_frames", "3"), ("expected_frames", "4")]);
    assert!(
        stderr(&out).contains("the captured folder has 3 PNG frames, the input gives 4"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn wrong_frame_counts_and_a_truncated_frame_fail_with_the_numbers() {
    let tmp = tempfile::tempdir().unwrap();
    let src = clip(tmp.path());
    let good = stream(&src, "rgb24", &[]);
    let write = |name: &str, bytes: &[u8]| {
        let file = tmp.path().join(name);
        fs::write(&file, bytes).unwrap();
        file
    };

    let out = verify(&src, &write("fewer.rgb", &good[..3 * FRAME]), &[]);
    assert_eq!(code(&out), Some(1));
    assert_fields(
        &out,
        &[
            ("frames", "3"),
            ("captured_frames", "3"),
            ("expected_frames", "4"),
            ("pixels_differing", "0"),
            ("result", "fail"),
        ],
    );
    let err = stderr(&out);
    assert!(
        err.contains(
            "fewer.rgb: the captured stream has 3 frames, the input gives 4 (5 input frames, one result per consecutive pair)"
        ),
        "{err}"
    );

    let more = [&good[..], &good[..FRAME]].concat();
    let out = verify(&src, &write("more.rgb", &more), &[]);
    assert_eq!(code(&out), Some(1));
    assert_fields(&out, &[("frames", "4"), ("captured_frames", "5")]);
    assert!(
        stderr(&out).contains("the captured stream has 5 frames, the input gives 4"),
        "{}",
        stderr(&out)
    );

    let cut = good.len() - 10;
    let out = verify(&src, &write("cut.rgb", &good[..cut]), &[]);
    assert_eq!(code(&out), Some(1));
    assert_fields(&out, &[("frames", "3"), ("result", "fail")]);
    let err = stderr(&out);
    assert!(
        err.contains(&format!(
            "cut.rgb: truncated: frame 3 has {} of its {FRAME} bytes (a 40x30 rgb24 frame",
            FRAME - 10
        )),
        "{err}"
    );

    // A Y4M capture of another size or layout is refused before comparing.
    let y4m = stream(&src, "y4m", &[]);
    let header_end = y4m.iter().position(|&b| b == b'\n').unwrap();
    let header = String::from_utf8(y4m[..header_end].to_vec()).unwrap();
    for (changed, needle) in [
        (
            header.replace("W40", "W41"),
            "its frames are 41x30, but the input's are 40x30",
        ),
        (header.replace(" C444", ""), "the Y4M stream is C420jpeg"),
    ] {
        let bytes = [changed.as_bytes(), &y4m[header_end..]].concat();
        let out = verify(&src, &write("other.y4m", &bytes), &[]);
        assert_eq!(code(&out), Some(1), "{needle}");
        assert!(stderr(&out).contains(needle), "{}", stderr(&out));
        assert!(out.stdout.is_empty());
    }
}

#[test]
fn bad_command_lines_exit_2_with_one_line() {
    let tmp = tempfile::tempdir().unwrap();
    let src = clip(tmp.path());
    let file = tmp.path().join("device.rgb");
    fs::write(&file, stream(&src, "rgb24", &[])).unwrap();
    let cases: Vec<(Vec<std::ffi::OsString>, &str)> = vec![
        (
            args!["verify", src, file, "--tolerance", "-3"].to_vec(),
            "-3",
        ),
        (
            args!["verify", src, file, "--tolerance=-3"].to_vec(),
            "--tolerance",
        ),
        (
            args!["verify", src, file, "--tolerance", "256"].to_vec(),
            "256",
        ),
        (args!["verify", src].to_vec(), "<CAPTURED>"),
        (
            args!["verify", src, file, "--captured-format", "bmp"].to_vec(),
            "bmp",
        ),
        (
            args!["verify", "-", "-", "--raw", "40x30"].to_vec(),
            "standard input",
        ),
        (
            args!["verify", src, file, "--viz"].to_vec(),
            "--viz: does not apply to verify",
        ),
        (
            args!["verify", src, file, "--lambda", "1e9"].to_vec(),
            "--lambda",
        ),
    ];
    for (a, needle) in cases {
        let out = run(&a);
        let err = stderr(&out);
        assert_eq!(code(&out), Some(2), "{a:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{a:?}: {err}");
        assert!(
            err.starts_with("reynoldsflow: error: ") && err.contains(needle),
            "{a:?}: {err}"
        );
        assert!(out.stdout.is_empty(), "{a:?}");
    }
}

#[test]
fn help_shows_an_example_and_the_report_line() {
    let out = run(&args!["verify", "--help"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(code(&out), Some(0));
    assert!(
        text.contains("reynoldsflow verify clip.y4m device.rgb"),
        "{text}"
    );
    assert!(
        text.contains("first_diff=frame:F,x:X,y:Y,channel:C"),
        "{text}"
    );
    // The flags a stream cannot carry are not offered.
    assert!(!text.contains("--viz") && !text.contains("--npy"), "{text}");
    let out = run(&args!["--help"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("reynoldsflow verify "));
}

//! `reynoldsflow run` end to end, through the built binary: every input
//! kind, every output kind, agreement with `reynoldsflow pair`, and every
//! bad input failing with one line that names the file and the problem.

mod run_support;

use std::ffi::OsStr;
use std::fs;
use std::path::Path;

use reynoldsflow_host::outputs::{decode_npy_xy, flo};
use reynoldsflow_host::{Gray, io::npy};
use run_support::*;

const W: usize = 40;
const H: usize = 30;

fn frames(n: usize) -> Vec<Gray> {
    (0..n).map(|t| moving_frame(W, H, t)).collect()
}

/// Names of the representation PNGs directly in `dir`.
fn pngs(dir: &Path) -> Vec<String> {
    tree(dir)
        .into_iter()
        .filter(|p| !p.contains('/') && p.ends_with(".png"))
        .collect()
}

#[test]
fn demo_runs_with_no_input_into_the_default_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(BIN)
        .args(["run", "--max-frames", "3"])
        .current_dir(tmp.path())
        .output()
        .unwrap();
    let err = ok(&out);
    let dir = tmp.path().join("reynoldsflow-out");
    assert_eq!(pngs(&dir), ["000000.png", "000001.png"]);
    assert_eq!(err.lines().count(), 2, "{err}");
    assert!(err.contains("built-in demo; on your footage"), "{err}");
    assert!(
        err.contains(
            "2 outputs from 3 frames of 320x240 of built-in demo sequence -> reynoldsflow-out/"
        ),
        "{err}"
    );
    // Something real to look at: motion in R and G, the scene in B.
    let rep = rgb(&dir.join("000001.png"));
    let spread = |c: usize| {
        let v: Vec<u8> = rep.iter().skip(c).step_by(3).copied().collect();
        let mean = v.iter().map(|&b| f64::from(b)).sum::<f64>() / v.len() as f64;
        (v.iter()
            .map(|&b| (f64::from(b) - mean).powi(2))
            .sum::<f64>()
            / v.len() as f64)
            .sqrt()
    };
    for c in 0..3 {
        assert!(spread(c) > 5.0, "channel {c} is nearly flat: {}", spread(c));
    }
}

/// A folder of mixed PGM/PNG/JPEG frames in natural order gives exactly
/// what `pair` gives on each consecutive pair, in both engines.
#[test]
fn folder_run_equals_pair_on_every_pair() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("frames");
    fs::create_dir(&src).unwrap();
    let f = frames(4);
    // Natural order: f2 before f10; a note and a hidden file are ignored.
    fs::write(src.join("f1.pgm"), pgm(&f[0])).unwrap();
    fs::write(src.join("f2.png"), png_gray(&f[1])).unwrap();
    fs::write(src.join("f3.jpg"), jpeg(&f[2])).unwrap();
    fs::write(src.join("f10.pgm"), pgm(&f[3])).unwrap();
    fs::write(src.join("notes.txt"), "not a frame").unwrap();
    fs::write(src.join(".hidden.png"), "not a frame").unwrap();
    let order = ["f1.pgm", "f2.png", "f3.jpg", "f10.pgm"];
    for engine in ["fixed", "float"] {
        let out = tmp.path().join(format!("run-{engine}"));
        let err = ok(&run(&args![
            "run",
            src,
            "--out",
            out,
            "--engine",
            engine,
            "--npy",
            "--flo=v_c,v_d,v_R"
        ]));
        assert!(err.contains("3 outputs from 4 frames of 40x30"), "{err}");
        assert_eq!(pngs(&out), ["f1.png", "f2.png", "f3.png"]);
        for (i, stem) in ["f1", "f2", "f3"].iter().enumerate() {
            let pair = tmp.path().join(format!("pair-{engine}-{stem}"));
            ok(&run(&args![
                "pair",
                src.join(order[i]),
                src.join(order[i + 1]),
                "--out",
                pair,
                "--engine",
                engine
            ]));
            assert_eq!(
                rgb(&out.join(format!("{stem}.png"))),
                rgb(&pair.join("rep.png")),
                "{engine} {stem}: run and pair differ"
            );
            // The fields read back to pair's values exactly (.npy) or as f32 (.flo).
            let plane = |name: &str| npy::read(&pair.join(format!("{name}.npy"))).unwrap().data;
            let (vcx, vcy, vdx, vdy) = (plane("vcx"), plane("vcy"), plane("vdx"), plane("vdy"));
            let sum = |a: &[f64], b: &[f64]| -> Vec<f64> {
                a.iter().zip(b).map(|(a, b)| a + b).collect()
            };
            let expected = [
                ("v_c", vcx.clone(), vcy.clone()),
                ("v_d", vdx.clone(), vdy.clone()),
                ("v_R", sum(&vcx, &vdx), sum(&vcy, &vdy)),
            ];
            for (field, x, y) in expected {
                let bytes = fs::read(out.join(field).join(format!("{stem}.npy"))).unwrap();
                let (h, w, nx, ny) = decode_npy_xy(&bytes).unwrap();
                assert_eq!((h, w), (H, W), "{field} shape");
                assert!(
                    nx == x && ny == y,
                    "{engine} {stem} {field}.npy differs from pair"
                );
                let f =
                    flo::decode(&fs::read(out.join(field).join(format!("{stem}.flo"))).unwrap())
                        .unwrap();
                assert_eq!((f.width, f.height), (W, H));
                let as32 = |v: &[f64]| v.iter().map(|&a| f64::from(a as f32)).collect::<Vec<_>>();
                assert!(
                    f.u == as32(&x) && f.v == as32(&y),
                    "{engine} {stem} {field}.flo"
                );
            }
        }
        assert!(temp_files(&out).is_empty());
    }
}

#[test]
fn y4m_of_every_chroma_layout_raw_stdin_and_folders_agree() {
    let tmp = tempfile::tempdir().unwrap();
    let f = frames(4);
    let folder = tmp.path().join("pgm");
    write_pgms(&folder, &f);
    let reference = tmp.path().join("ref");
    ok(&run(&args!["run", folder, "--out", reference]));
    let want: Vec<Vec<u8>> = (0..3)
        .map(|i| rgb(&reference.join(format!("f{i}.png"))))
        .collect();
    let check = |out: &Path, what: &str| {
        assert_eq!(
            pngs(out),
            ["000000.png", "000001.png", "000002.png"],
            "{what}"
        );
        for (i, w) in want.iter().enumerate() {
            assert_eq!(
                &rgb(&out.join(format!("{i:06}.png"))),
                w,
                "{what}: result {i}"
            );
        }
    };
    for chroma in [
        "", "420jpeg", "420paldv", "420mpeg2", "420", "422", "411", "444", "444alpha", "mono",
    ] {
        let file = tmp.path().join(format!("c{chroma}.y4m"));
        fs::write(&file, y4m(&f, chroma)).unwrap();
        let out = tmp.path().join(format!("y4m-{chroma}"));
        ok(&run(&args!["run", file, "--out", out]));
        check(&out, &format!("C{chroma}"));
    }
    // Y4M on stdin.
    let out = tmp.path().join("stdin-y4m");
    ok(&run_with(
        &args!["run", "-", "--out", out],
        Some(&y4m(&f, "420jpeg")),
        &[],
    ));
    check(&out, "stdin y4m");
    // Raw gray frames on stdin, and from a file.
    let raw: Vec<u8> = f.iter().flat_map(|g| g.pixels.clone()).collect();
    let out = tmp.path().join("stdin-raw");
    let err = ok(&run_with(
        &args!["run", "-", "--raw", "40x30", "--out", out],
        Some(&raw),
        &[],
    ));
    assert!(err.contains("of stdin"), "{err}");
    check(&out, "stdin raw");
    let file = tmp.path().join("frames.gray");
    fs::write(&file, &raw).unwrap();
    let out = tmp.path().join("file-raw");
    ok(&run(&args!["run", file, "--raw", "40x30", "--out", out]));
    check(&out, "raw file");
    // A glob picks its frames only, in natural order.
    fs::write(folder.join("g1.pgm"), pgm(&f[0])).unwrap();
    fs::write(folder.join("g10.pgm"), pgm(&f[2])).unwrap();
    fs::write(folder.join("g2.pgm"), pgm(&f[1])).unwrap();
    let out = tmp.path().join("glob");
    ok(&run(&args!["run", folder.join("g*.pgm"), "--out", out]));
    assert_eq!(pngs(&out), ["g1.png", "g2.png"]);
    assert_eq!(rgb(&out.join("g1.png")), want[0]);
    assert_eq!(rgb(&out.join("g2.png")), want[1]);
}

#[test]
fn ffmpeg_videos_are_decoded_or_the_missing_ffmpeg_is_named() {
    let tmp = tempfile::tempdir().unwrap();
    let f = frames(5);
    let dir = tmp.path().join("pgm");
    write_pgms(&dir, &f);
    let video = tmp.path().join("clip.mp4");
    // Without ffmpeg (here: a program that does not exist), the message says what to install.
    fs::write(&video, b"\x00\x00\x00\x18ftypisom not really a video").unwrap();
    let out = tmp.path().join("none");
    let res = run_with(
        &args!["run", video, "--out", out],
        None,
        &[("REYNOLDSFLOW_FFMPEG", OsStr::new("/nonexistent/ffmpeg"))],
    );
    let err = stderr(&res);
    assert_eq!(res.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("clip.mp4") && err.contains("ffmpeg") && err.contains("not found"),
        "{err}"
    );
    assert!(!out.exists(), "nothing is created for an unreadable input");

    if !have_ffmpeg() {
        return;
    }
    // A video ffmpeg cannot decode: ffmpeg's own reason, naming the file.
    let res = run(&args!["run", video, "--out", out]);
    let err = stderr(&res);
    assert_eq!(res.status.code(), Some(1), "{err}");
    assert!(err.contains("clip.mp4: ffmpeg cannot decode it"), "{err}");

    // Lossless gray video: exactly the frames, so exactly the folder's outputs.
    let reference = tmp.path().join("ref");
    ok(&run(&args!["run", dir, "--out", reference]));
    let lossless = tmp.path().join("clip.mkv");
    ffmpeg_encode(&dir, &lossless, &["-c:v", "ffv1", "-pix_fmt", "gray"]);
    let out = tmp.path().join("mkv");
    let err = ok(&run(&args!["run", lossless, "--out", out]));
    assert!(err.contains("4 outputs from 5 frames of 40x30"), "{err}");
    for i in 0..4 {
        assert_eq!(
            rgb(&out.join(format!("{i:06}.png"))),
            rgb(&reference.join(format!("f{i}.png"))),
            "lossless video result {i}"
        );
    }
    // A lossy MP4 and AVI: every pair, stems by index.
    for (name, codec) in [
        ("clip.mp4", vec!["-c:v", "mpeg4", "-q:v", "2"]),
        ("clip.avi", vec!["-c:v", "mjpeg", "-q:v", "2"]),
    ] {
        let video = tmp.path().join(name);
        ffmpeg_encode(&dir, &video, &codec);
        let out = tmp.path().join(format!("out-{name}"));
        ok(&run(&args![
            "run",
            video,
            "--out",
            out,
            "--max-frames",
            "4"
        ]));
        assert_eq!(
            pngs(&out),
            ["000000.png", "000001.png", "000002.png"],
            "{name}"
        );
    }
}

#[test]
fn every_output_kind_variants_streams_and_keep_count() {
    let tmp = tempfile::tempdir().unwrap();
    let f = frames(4);
    let src = tmp.path().join("src");
    write_pgms(&src, &f);
    let out = tmp.path().join("all");
    ok(&run(&args![
        "run",
        src,
        "--out",
        out,
        "--viz",
        "--npy=v_R",
        "--flo",
        "--keep-count",
        "--threads",
        "2"
    ]));
    let mut expected = Vec::new();
    for i in 0..4 {
        expected.push(format!("f{i}.png"));
        expected.push(format!("hsv/f{i}.png"));
        expected.push(format!("v_R/f{i}.flo"));
        expected.push(format!("v_R/f{i}.npy"));
    }
    expected.sort();
    assert_eq!(tree(&out), expected);
    // --keep-count: the last frame gets a copy of the last result.
    for sub in ["f{}.png", "hsv/f{}.png", "v_R/f{}.npy", "v_R/f{}.flo"] {
        let file = |i: usize| fs::read(out.join(sub.replace("{}", &i.to_string()))).unwrap();
        assert_eq!(file(3), file(2), "{sub}");
        assert_ne!(file(1), file(2), "{sub}");
    }

    // Variants are the representation's channels rearranged, or the colour wheel.
    let base: Vec<u8> = rgb(&out.join("f1.png"));
    for variant in ["dc0", "cd", "hsv"] {
        let vout = tmp.path().join(variant);
        ok(&run(&args![
            "run",
            src,
            "--out",
            vout,
            "--variant",
            variant
        ]));
        let image = rgb(&vout.join("f1.png"));
        let expect: Vec<u8> = match variant {
            "dc0" => base.chunks(3).flat_map(|p| [p[0], 0, p[2]]).collect(),
            "cd" => base.chunks(3).flat_map(|p| [p[1], p[0], p[2]]).collect(),
            _ => rgb(&out.join("hsv/f1.png")),
        };
        assert_eq!(image, expect, "{variant}");
    }

    // Streams: raw RGB24 frames back to back, and Y4M C444.
    let res = run(&args![
        "run",
        src,
        "--out",
        "-",
        "--format",
        "rgb24",
        "--keep-count"
    ]);
    ok(&res);
    let frame = 3 * W * H;
    assert_eq!(res.stdout.len(), 4 * frame);
    for i in 0..4 {
        assert_eq!(
            res.stdout[i * frame..(i + 1) * frame],
            rgb(&out.join(format!("f{i}.png"))),
            "rgb24 {i}"
        );
    }
    let res = run(&args!["run", src, "--out", "-", "--format", "y4m"]);
    ok(&res);
    let header = b"YUV4MPEG2 W40 H30 F25:1 Ip A1:1 C444\n";
    assert!(
        res.stdout.starts_with(header),
        "{:?}",
        String::from_utf8_lossy(&res.stdout[..40])
    );
    let body = &res.stdout[header.len()..];
    assert_eq!(body.len(), 3 * (6 + 3 * W * H));
    let first = &body[6..6 + W * H];
    let rep = rgb(&out.join("f0.png"));
    let luma: Vec<u8> = rep
        .chunks(3)
        .map(|p| {
            (16 + ((66 * i32::from(p[0]) + 129 * i32::from(p[1]) + 25 * i32::from(p[2]) + 128)
                >> 8)) as u8
        })
        .collect();
    assert_eq!(first, &luma[..]);
    assert!(
        body.chunks(6 + 3 * W * H)
            .all(|c| c.starts_with(b"FRAME\n"))
    );

    // The same bytes whatever the thread count.
    let one = tmp.path().join("one");
    ok(&run(&args![
        "run",
        src,
        "--out",
        one,
        "--threads",
        "1",
        "--viz",
        "--npy=v_R",
        "--flo",
        "--keep-count"
    ]));
    for file in tree(&out) {
        assert_eq!(
            fs::read(out.join(&file)).unwrap(),
            fs::read(one.join(&file)).unwrap(),
            "{file}"
        );
    }
}

#[test]
fn lean_and_full_paths_and_every_thread_count_give_the_same_bytes() {
    // Wider than one 128-px strip, so strips meet inside the frame.
    let (w, h) = (200, 48);
    let f: Vec<Gray> = (0..6).map(|t| moving_frame(w, h, t)).collect();
    let tmp = tempfile::tempdir().unwrap();
    let video = tmp.path().join("clip.y4m");
    fs::write(&video, y4m(&f, "420jpeg")).unwrap();
    for scale in ["minmax", "fixed:8,32"] {
        // A stream: the same bytes with one worker and with two.
        let stream = |threads: &str| {
            let res = run(&args![
                "run",
                video,
                "--out",
                "-",
                "--format",
                "rgb24",
                "--scale",
                scale,
                "--threads",
                threads
            ]);
            ok(&res);
            res.stdout
        };
        let one = stream("1");
        assert_eq!(one.len(), 5 * 3 * w * h, "{scale}");
        assert!(one == stream("2"), "{scale}: 1 thread vs 2");
        // Files: the representation alone (computed without the fields) and
        // with every field output (computed from them) are the same PNGs.
        let lean = tmp.path().join(format!("lean-{scale}"));
        let full = tmp.path().join(format!("full-{scale}"));
        ok(&run(&args![
            "run",
            video,
            "--out",
            lean,
            "--scale",
            scale,
            "--threads",
            "2"
        ]));
        ok(&run(&args![
            "run",
            video,
            "--out",
            full,
            "--scale",
            scale,
            "--viz",
            "--npy",
            "--threads",
            "1"
        ]));
        assert_eq!(pngs(&lean).len(), 5);
        for name in pngs(&lean) {
            let bytes = fs::read(lean.join(&name)).unwrap();
            assert!(
                bytes == fs::read(full.join(&name)).unwrap(),
                "{scale}: {name}"
            );
        }
        let frame = 3 * w * h;
        assert_eq!(rgb(&lean.join("000004.png")), one[4 * frame..], "{scale}");
    }
}

/// Run with `args`; expect exit status `code`, one line naming
/// every needle.
#[track_caller]
fn expect_failure(
    label: &str,
    args: &[std::ffi::OsString],
    stdin: Option<&[u8]>,
    code: i32,
    needles: &[&str],
) -> String {
    let res = run_with(args, stdin, &[]);
    let err = stderr(&res);
    println!("{label}: exit {:?}: {}", res.status.code(), err.trim_end());
    assert_eq!(res.status.code(), Some(code), "{label}: {err}");
    assert_eq!(err.lines().count(), 1, "{label}: not one line: {err}");
    assert!(err.starts_with("reynoldsflow: error: "), "{label}: {err}");
    for needle in needles {
        assert!(err.contains(needle), "{label}: '{needle}' not in: {err}");
    }
    err
}

#[test]
fn bad_inputs_fail_with_one_line_naming_file_and_problem() {
    let tmp = tempfile::tempdir().unwrap();
    let p = |name: &str| tmp.path().join(name);
    let out = p("out");
    let f = frames(3);

    // Truncated Y4M: a frame cut short. The complete first pair's output stays, whole.
    let mut bytes = y4m(&f, "420jpeg");
    bytes.truncate(bytes.len() - 100);
    fs::write(p("cut.y4m"), &bytes).unwrap();
    expect_failure(
        "truncated y4m",
        &args!["run", p("cut.y4m"), "--out", out],
        None,
        1,
        &["cut.y4m", "truncated: frame 2"],
    );
    assert_eq!(pngs(&out), ["000000.png"]);
    assert!(temp_files(&out).is_empty());
    let mut bytes = y4m(&f[..1], "mono");
    bytes.extend_from_slice(b"FRA");
    fs::write(p("cut2.y4m"), &bytes).unwrap();
    expect_failure(
        "y4m cut in a FRAME line",
        &args!["run", p("cut2.y4m"), "--out", p("o2")],
        None,
        1,
        &["cut2.y4m", "frame 1"],
    );

    // Bit depth.
    fs::write(p("deep.y4m"), b"YUV4MPEG2 W4 H4 F25:1 C420p10\n").unwrap();
    expect_failure(
        "10-bit y4m",
        &args!["run", p("deep.y4m"), "--out", p("o3")],
        None,
        1,
        &["deep.y4m", "10-bit", "only 8-bit"],
    );
    let deep = p("deep");
    fs::create_dir(&deep).unwrap();
    {
        use image::{ExtendedColorType, ImageEncoder, codecs::png::PngEncoder};
        let mut png16 = Vec::new();
        PngEncoder::new(&mut png16)
            .write_image(&[0u8; 2 * 16], 4, 4, ExtendedColorType::L16)
            .unwrap();
        fs::write(deep.join("a1.png"), &png16).unwrap();
        fs::write(deep.join("a2.png"), &png16).unwrap();
    }
    expect_failure(
        "16-bit png",
        &args!["run", deep, "--out", p("o4")],
        None,
        1,
        &["a1.png", "16-bit"],
    );

    // Frames of different sizes.
    let sizes = p("sizes");
    fs::create_dir(&sizes).unwrap();
    fs::write(sizes.join("f1.pgm"), pgm(&f[0])).unwrap();
    fs::write(sizes.join("f2.pgm"), pgm(&f[1])).unwrap();
    fs::write(sizes.join("f10.pgm"), pgm(&moving_frame(20, 30, 0))).unwrap();
    expect_failure(
        "sizes",
        &args!["run", sizes, "--out", p("o5")],
        None,
        1,
        &["f10.pgm", "20x30", "differs", "f2.pgm", "40x30"],
    );
    assert!(temp_files(&p("o5")).is_empty());

    // Unreadable image.
    let garbage = p("garbage");
    fs::create_dir(&garbage).unwrap();
    fs::write(garbage.join("f1.pgm"), pgm(&f[0])).unwrap();
    fs::write(garbage.join("f2.png"), b"\x89PNG\r\n\x1a\nbroken").unwrap();
    expect_failure(
        "broken png",
        &args!["run", garbage, "--out", p("o6")],
        None,
        1,
        &["f2.png", "cannot decode"],
    );
    fs::write(garbage.join("f2.png"), b"plain text").unwrap();
    expect_failure(
        "not an image",
        &args!["run", garbage, "--out", p("o6")],
        None,
        1,
        &["f2.png", "not a PGM"],
    );

    // Output not writable: a folder inside a file, and a file in its place.
    let folder = p("frames");
    write_pgms(&folder, &f);
    fs::write(p("file"), "x").unwrap();
    expect_failure(
        "out under a file",
        &args!["run", folder, "--out", p("file").join("sub")],
        None,
        1,
        &["file/sub", "not writable"],
    );
    expect_failure(
        "out is a file",
        &args!["run", folder, "--out", p("file")],
        None,
        1,
        &["file", "not a folder"],
    );

    // Inputs that are not sequences.
    expect_failure(
        "missing",
        &args!["run", p("missing.mp4"), "--out", p("o7")],
        None,
        1,
        &["missing.mp4", "No such file"],
    );
    fs::create_dir(p("empty")).unwrap();
    expect_failure(
        "empty folder",
        &args!["run", p("empty"), "--out", p("o7")],
        None,
        1,
        &["empty", "no frames"],
    );
    expect_failure(
        "single image",
        &args!["run", folder.join("f0.pgm"), "--out", p("o7")],
        None,
        1,
        &["f0.pgm", "single image"],
    );
    expect_failure(
        "glob of nothing",
        &args!["run", folder.join("z*.png"), "--out", p("o7")],
        None,
        1,
        &["z*.png", "matches no frame"],
    );
    assert!(
        !p("o7").exists(),
        "inputs refused before anything runs leave no folder"
    );
    expect_failure(
        "stdin not y4m",
        &args!["run", "-", "--out", p("o7")],
        Some(b"hello"),
        1,
        &["stdin", "not a Y4M", "--raw"],
    );
    expect_failure(
        "raw truncated",
        &args!["run", "-", "--raw", "4x4", "--out", p("o7")],
        Some(&[0u8; 40]),
        1,
        &["stdin", "truncated", "frame 2"],
    );
    fs::write(p("header.y4m"), b"YUV4MPEG2 W4 H4 Cmono\n").unwrap();
    expect_failure(
        "no frames",
        &args!["run", p("header.y4m"), "--out", p("o8")],
        None,
        1,
        &["header.y4m", "no frames"],
    );
    fs::write(p("empty.mp4"), b"").unwrap();
    expect_failure(
        "empty file",
        &args!["run", p("empty.mp4"), "--out", p("o8")],
        None,
        1,
        &["empty.mp4", "empty file"],
    );

    // Flags.
    expect_failure(
        "--format without a stream",
        &args!["run", folder, "--out", p("o9"), "--format", "y4m"],
        None,
        1,
        &["--format"],
    );
    expect_failure(
        "stream with files",
        &args!["run", folder, "--out", "-", "--npy"],
        None,
        1,
        &["--out -", "--npy"],
    );
    expect_failure(
        "nothing to write",
        &args!["run", folder, "--out", p("o9"), "--no-rep"],
        None,
        1,
        &["--no-rep"],
    );
    expect_failure(
        "bad field",
        &args!["run", folder, "--npy=v_x"],
        None,
        2,
        &["v_x", "v_R"],
    );
    expect_failure(
        "bad variant",
        &args!["run", folder, "--variant", "rgb"],
        None,
        2,
        &["rgb", "dc0"],
    );
    expect_failure(
        "bad raw size",
        &args!["run", "-", "--raw", "0x4"],
        None,
        2,
        &["--raw", "WxH"],
    );
    expect_failure(
        "tile with float",
        &args![
            "run",
            folder,
            "--engine",
            "float",
            "--tile",
            "8x8",
            "--out",
            p("o9")
        ],
        None,
        1,
        &["--tile"],
    );
    expect_failure(
        "lambda",
        &args!["run", folder, "--lambda", "1", "--out", p("o9")],
        None,
        1,
        &["--lambda", "range"],
    );
}

#[test]
fn one_frame_gives_no_result() {
    let tmp = tempfile::tempdir().unwrap();
    let f = frames(1);
    let file = tmp.path().join("one.y4m");
    fs::write(&file, y4m(&f, "mono")).unwrap();
    let out = tmp.path().join("one");
    let err = ok(&run(&args!["run", file, "--out", out]));
    assert!(
        err.contains("1 frame") && err.contains("no result"),
        "{err}"
    );
    assert!(pngs(&out).is_empty());
}

#[test]
#[cfg_attr(
    not(feature = "crash-injection"),
    ignore = "the crash hook needs --features reynoldsflow-cli/crash-injection (scripts/test)"
)]
fn a_run_killed_mid_write_is_cleaned_up() {
    let tmp = tempfile::tempdir().unwrap();
    let f = frames(6);
    // Crash after 2 results, mid-write of the third: a temp file, never a partial PNG.
    let src = tmp.path().join("src");
    write_pgms(&src, &f);
    let out = tmp.path().join("crash");
    let res = run_with(
        &args!["run", src, "--out", out, "--threads", "1"],
        None,
        &[("REYNOLDSFLOW_ABORT_AFTER", OsStr::new("2"))],
    );
    assert!(!res.status.success());
    assert_eq!(pngs(&out), ["f0.png", "f1.png"]);
    assert_eq!(temp_files(&out).len(), 1, "{:?}", tree(&out));
    for png in pngs(&out) {
        rgb(&out.join(png)); // each decodes whole
    }
    // The next run into the folder removes it and completes.
    ok(&run(&args!["run", src, "--out", out]));
    assert!(temp_files(&out).is_empty(), "{:?}", tree(&out));
    assert_eq!(pngs(&out).len(), 5);
}

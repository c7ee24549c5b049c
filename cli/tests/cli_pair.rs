//! The `reynoldsflow pair` command as outside checks use it: the built
//! binary on vector cases with both engines, and bad inputs that must fail
//! with one readable line and leave the output directory empty.

use std::ffi::{OsStr, OsString};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use image::{ExtendedColorType, ImageEncoder, codecs::png::PngEncoder};
use reynoldsflow_host::limits::Limits;
use reynoldsflow_host::{io::image_file, io::npy};

const BIN: &str = env!("CARGO_BIN_EXE_reynoldsflow");
const VECTORS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/vectors");
const FIELDS: [&str; 4] = ["vcx", "vcy", "vdx", "vdy"];

fn case(name: &str) -> PathBuf {
    Path::new(VECTORS).join(name)
}

/// Command-line arguments from strings and paths alike.
macro_rules! args {
    ($($a:expr),* $(,)?) => { [$(OsString::from(AsRef::<OsStr>::as_ref(&$a))),*] };
}

fn run(args: &[OsString]) -> Output {
    Command::new(BIN)
        .args(args)
        .output()
        .expect("run reynoldsflow")
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = match fs::read_dir(dir) {
        Ok(entries) => entries
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect(),
        Err(_) => Vec::new(),
    };
    names.sort();
    names
}

/// The four fields of an output directory, checked for shape `(h, w)`.
fn read_fields(dir: &Path, w: usize, h: usize) -> [Vec<f64>; 4] {
    FIELDS.map(|name| {
        let a = npy::read(&dir.join(format!("{name}.npy"))).unwrap();
        assert_eq!((a.height, a.width), (h, w), "{name}.npy shape");
        a.data
    })
}

/// `max |a − b|` over the vector field's largest magnitude in `b` (see float_vectors.rs).
fn field_errors(ours: &[Vec<f64>; 4], theirs: &[Vec<f64>; 4]) -> [f64; 4] {
    let scale =
        |x: &[f64], y: &[f64]| match x.iter().zip(y).fold(0.0f64, |m, (x, y)| m.max(x.hypot(*y))) {
            0.0 => 1.0,
            m => m,
        };
    let scales = [scale(&theirs[0], &theirs[1]), scale(&theirs[2], &theirs[3])];
    std::array::from_fn(|k| {
        ours[k]
            .iter()
            .zip(&theirs[k])
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
            / scales[k / 2]
    })
}

#[test]
fn both_engines_write_the_five_files() {
    for name in ["translate_64x48", "row_7x1"] {
        let dir = case(name);
        let reference = image_file::read_rgb8(&dir.join("rep.png"), Limits::default()).unwrap();
        let (w, h) = (reference.width, reference.height);
        let vectors = read_fields(&dir, w, h);
        let tmp = tempfile::tempdir().unwrap();
        for engine in ["float", "fixed"] {
            let out = tmp.path().join(engine).join("nested");
            let run = run(&args![
                "pair",
                dir.join("f0.pgm"),
                dir.join("f1.pgm"),
                "--out",
                out,
                "--engine",
                engine
            ]);
            assert!(
                run.status.success(),
                "{name} {engine}: {}",
                String::from_utf8_lossy(&run.stderr)
            );
            assert!(run.stderr.is_empty());
            assert_eq!(
                files_in(&out),
                ["rep.png", "vcx.npy", "vcy.npy", "vdx.npy", "vdy.npy"]
            );
            let fields = read_fields(&out, w, h);
            let rep = image_file::read_rgb8(&out.join("rep.png"), Limits::default()).unwrap();
            assert_eq!((rep.width, rep.height), (w, h));
            let err = field_errors(&fields, &vectors);
            let differ = rep
                .bytes
                .iter()
                .zip(&reference.bytes)
                .filter(|(a, b)| a != b)
                .count();
            let shown = err.map(|e| format!("{e:.1e}")).join(" ");
            println!(
                "{name} {engine}: relative error vs vectors (vcx vcy vdx vdy) {shown}; rep.png bytes differing {differ}/{}",
                3 * w * h
            );
            match engine {
                "float" => {
                    assert!(err.iter().all(|&e| e <= 1e-9), "{name}: {err:?}");
                    // float_vectors.rs found no rounding ties in the vectors.
                    assert_eq!(differ, 0, "{name}: float rep.png");
                }
                _ => {
                    // Q16.16 fields: half a step (2⁻¹⁶) of rounding, plus the core's
                    // quantised λ (1e-4 · (1 + 3.8e-7)) and solve truncation: measured
                    // at most 1.04 steps over all vectors; 2 steps means something broke.
                    let lsb = fields.iter().zip(&vectors).fold(0.0f64, |m, (a, b)| {
                        a.iter()
                            .zip(b)
                            .fold(m, |m, (a, b)| m.max((a - b).abs() * 65536.0))
                    });
                    println!("{name} fixed: largest |fixed - float| = {lsb:.3} Q16.16 steps");
                    assert!(lsb <= 2.0, "{name}: fixed engine off by {lsb} steps");
                    // B is the frame itself, in both engines.
                    assert!(
                        rep.bytes
                            .chunks(3)
                            .zip(reference.bytes.chunks(3))
                            .all(|(a, b)| a[2] == b[2])
                    );
                }
            }
        }
    }
}

#[test]
fn tiles_do_not_change_the_files() {
    let dir = case("zoom_64x48");
    let tmp = tempfile::tempdir().unwrap();
    let mut outputs = Vec::new();
    for tile in [None, Some("5x7"), Some("64x48"), Some("128x1")] {
        let out = tmp.path().join(tile.unwrap_or("strips"));
        let (f0, f1) = (dir.join("f0.pgm"), dir.join("f1.pgm"));
        let files = pair_files(&f0, &f1, &out, tile, &["--scale", "fixed:8,32"]);
        outputs.push(files);
    }
    assert_eq!(outputs[0].len(), 5);
    assert!(
        outputs.iter().all(|o| *o == outputs[0]),
        "a tiling changed the output files"
    );
}

/// The output files of `pair` on `(f0, f1)` with `--tile` (or strips) and
/// `extra` arguments, by name.
fn pair_files(
    f0: &Path,
    f1: &Path,
    out: &Path,
    tile: Option<&str>,
    extra: &[&str],
) -> Vec<(String, Vec<u8>)> {
    let mut args = args!["pair", f0, f1, "--out", out].to_vec();
    args.extend(extra.iter().map(OsString::from));
    if let Some(t) = tile {
        args.extend(args!["--tile", t]);
    }
    let run = run(&args);
    assert!(
        run.status.success(),
        "{tile:?}: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    files_in(out)
        .into_iter()
        .map(|f| {
            let bytes = fs::read(out.join(&f)).unwrap();
            (f, bytes)
        })
        .collect()
}

/// A textured `w × h` frame seen through a shift of `dx` px.
fn write_textured(path: &Path, w: usize, h: usize, dx: usize) {
    let mut bytes = format!("P5\n{w} {h}\n255\n").into_bytes();
    bytes.extend((0..w * h).map(|i| {
        let (x, y) = ((i % w + dx) as u32, (i / w) as u32);
        (x.wrapping_mul(0x9e37_79b9) ^ y.wrapping_mul(0x85eb_ca6b)).rotate_left(7) as u8 / 2
            + ((x / 3 + y / 2) % 64) as u8
    }));
    fs::write(path, bytes).unwrap();
}

/// Any tile up to the frame (and beyond it, which is the frame) gives the
/// untiled files: random sizes and tiles (fixed seed), and full-width
/// strips of a 1280-wide frame, each in one window of an engine grown to it.
#[test]
fn any_tile_up_to_the_frame_gives_the_untiled_files() {
    let tmp = tempfile::tempdir().unwrap();
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut below = |n: usize| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed % n as u64) as usize
    };
    let mut cases: Vec<(usize, usize, Vec<String>)> = vec![(
        1280,
        24,
        vec![
            "1280x3".into(),
            "1280x24".into(),
            "1279x5".into(),
            "640x24".into(),
        ],
    )];
    for _ in 0..4 {
        let (w, h) = (20 + below(400), 10 + below(40));
        let tiles = (0..3)
            .map(|_| format!("{}x{}", 1 + below(w + 20), 1 + below(h + 5)))
            .chain([format!("{w}x{h}")])
            .collect();
        cases.push((w, h, tiles));
    }
    for (w, h, tiles) in cases {
        let (f0, f1) = (tmp.path().join("f0.pgm"), tmp.path().join("f1.pgm"));
        write_textured(&f0, w, h, 0);
        write_textured(&f1, w, h, 1);
        let untiled = pair_files(&f0, &f1, &tmp.path().join(format!("{w}x{h}")), None, &[]);
        assert_eq!(untiled.len(), 5);
        for tile in tiles {
            let out = tmp.path().join(format!("{w}x{h}-{tile}"));
            let tiled = pair_files(&f0, &f1, &out, Some(&tile), &[]);
            assert!(
                tiled == untiled,
                "{w}x{h} with --tile {tile} changed the files"
            );
        }
    }
}

fn write_pgm(path: &Path, w: usize, h: usize) {
    let mut bytes = format!("P5\n{w} {h}\n255\n").into_bytes();
    bytes.extend((0..w * h).map(|i| (i * 31 % 256) as u8));
    fs::write(path, bytes).unwrap();
}

/// Run with `args` (after `pair`) into a fresh output directory; expect
/// failure with one line naming the problem, and no file written.
fn expect_failure(label: &str, args: &[OsString], needles: &[&str]) {
    let tmp = tempfile::tempdir().unwrap();
    // Half the time the directory exists (it must stay empty), half it does not (it must not appear).
    for precreate in [false, true] {
        let out = tmp.path().join(format!("out-{precreate}"));
        if precreate {
            fs::create_dir(&out).unwrap();
        }
        let mut full = args!["pair", "--out", out].to_vec();
        full.extend_from_slice(args);
        let run = run(&full);
        let stderr = String::from_utf8_lossy(&run.stderr);
        println!(
            "{label}: exit {:?}: {}",
            run.status.code(),
            stderr.trim_end()
        );
        assert!(!run.status.success(), "{label}: succeeded");
        assert_eq!(stderr.lines().count(), 1, "{label}: not one line: {stderr}");
        assert!(
            stderr.starts_with("reynoldsflow: error: "),
            "{label}: {stderr}"
        );
        for needle in needles {
            assert!(
                stderr.contains(needle),
                "{label}: '{needle}' not in: {stderr}"
            );
        }
        assert_eq!(
            out.exists(),
            precreate,
            "{label}: output directory created or removed"
        );
        assert!(
            files_in(&out).is_empty(),
            "{label}: wrote {:?}",
            files_in(&out)
        );
    }
}

#[test]
fn bad_inputs_fail_with_one_line_and_write_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let p = |name: &str| tmp.path().join(name);
    let good = case("noise_33x17").join("f0.pgm");
    write_pgm(&p("a.pgm"), 4, 3);
    write_pgm(&p("b.pgm"), 3, 4);
    fs::write(p("garbage.pgm"), b"this is not an image\n").unwrap();
    fs::write(p("maxval.pgm"), b"P2 1 1 15\n7\n").unwrap();
    let mut png16 = Vec::new();
    PngEncoder::new(&mut png16)
        .write_image(&[0u8; 2 * 3 * 4 * 3], 4, 3, ExtendedColorType::Rgb16)
        .unwrap();
    fs::write(p("deep.png"), png16).unwrap();

    expect_failure(
        "missing file",
        &args![p("missing.pgm"), good],
        &["missing.pgm", "No such file"],
    );
    expect_failure(
        "size mismatch",
        &args![p("a.pgm"), p("b.pgm")],
        &["b.pgm", "3x4", "a.pgm", "4x3", "differs"],
    );
    expect_failure(
        "16-bit PNG",
        &args![p("deep.png"), p("deep.png")],
        &["deep.png", "16-bit"],
    );
    expect_failure(
        "maxval 15",
        &args![good, p("maxval.pgm")],
        &["maxval.pgm", "maxval is 15"],
    );
    expect_failure(
        "garbage",
        &args![p("garbage.pgm"), good],
        &["garbage.pgm", "not a PGM"],
    );
    expect_failure(
        "bad --scale",
        &args![good, good, "--scale", "fixed:8"],
        &["--scale", "fixed:KD,KC"],
    );
    expect_failure(
        "inexact --intensity-scale",
        &args![good, good, "--intensity-scale", "0.0039215686"],
        &["--intensity-scale", "1/255"],
    );
    expect_failure(
        "lambda out of the fixed range",
        &args![good, good, "--lambda", "1"],
        &["--lambda", "range"],
    );
    expect_failure(
        "--tile with float",
        &args![good, good, "--engine", "float", "--tile", "8x8"],
        &["--tile"],
    );
    expect_failure(
        "bad --tile",
        &args![good, good, "--tile", "0x8"],
        &["--tile"],
    );
    expect_failure("missing F1", &args![good], &["required", "F1"]);
}

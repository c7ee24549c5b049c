//! Helpers shared by the `run` and `dataset` end-to-end tests: the built
//! binary, small moving test frames in every container, and checks on
//! output folders.
#![allow(dead_code)]

use std::ffi::{OsStr, OsString};
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use reynoldsflow_host::limits::Limits;
use reynoldsflow_host::{Gray, io::image_file};

pub const BIN: &str = env!("CARGO_BIN_EXE_reynoldsflow");

/// Command-line arguments from strings and paths alike.
#[macro_export]
macro_rules! args {
    ($($a:expr),* $(,)?) => { [$(std::ffi::OsString::from(AsRef::<std::ffi::OsStr>::as_ref(&$a))),*] };
}

/// Run the binary with `args` (and `stdin` bytes, if any), environment
/// `env` added; the test's own ffmpeg override is never inherited.
pub fn run_with(args: &[OsString], stdin: Option<&[u8]>, env: &[(&str, &OsStr)]) -> Output {
    let mut cmd = Command::new(BIN);
    cmd.args(args)
        .env_remove("REYNOLDSFLOW_FFMPEG")
        .env_remove("REYNOLDSFLOW_ABORT_AFTER")
        // Tests of `dataset` give a shard explicitly, never the CI runner's.
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .stdin(if stdin.is_some() {
            Stdio::piped()
        } else {
            Stdio::null()
        })
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    for (k, v) in env {
        cmd.env(k, v);
    }
    let mut child = cmd.spawn().expect("start reynoldsflow");
    if let Some(bytes) = stdin {
        let mut pipe = child.stdin.take().unwrap();
        let bytes = bytes.to_vec();
        // Feed from a thread so a full stdout pipe cannot deadlock the test.
        std::thread::spawn(move || {
            let _ = pipe.write_all(&bytes);
        });
    }
    child.wait_with_output().expect("wait for reynoldsflow")
}

pub fn run(args: &[OsString]) -> Output {
    run_with(args, None, &[])
}

pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Assert success, returning stderr.
#[track_caller]
pub fn ok(out: &Output) -> String {
    let err = stderr(out);
    assert!(out.status.success(), "failed ({:?}): {err}", out.status);
    err
}

/// A small frame of a textured pattern moving right and down by
/// `t · (1.5, 0.5)` px, with a fixed-pattern grain.
pub fn moving_frame(w: usize, h: usize, t: usize) -> Gray {
    let pixels = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x as f64, y as f64)))
        .map(|(x, y)| {
            let t = t as f64;
            let (u, v) = (x - 1.5 * t, y - 0.5 * t);
            let grain =
                ((x as u32).wrapping_mul(2_654_435_761) ^ (y as u32).wrapping_mul(40_503)) >> 28;
            let value = 128.0
                + 55.0 * (0.45 * u).sin() * (0.3 * v + 0.2 * u).cos()
                + 30.0 * (0.17 * v - 0.11 * u).sin()
                + f64::from(grain);
            value.round().clamp(0.0, 255.0) as u8
        })
        .collect();
    Gray::new(w, h, pixels).unwrap()
}

/// The bytes of a binary PGM.
pub fn pgm(g: &Gray) -> Vec<u8> {
    let mut bytes = format!("P5\n{} {}\n255\n", g.width, g.height).into_bytes();
    bytes.extend_from_slice(&g.pixels);
    bytes
}

/// The bytes of a gray PNG.
pub fn png_gray(g: &Gray) -> Vec<u8> {
    use image::{ExtendedColorType, ImageEncoder, codecs::png::PngEncoder};
    let mut out = Vec::new();
    PngEncoder::new(&mut out)
        .write_image(
            &g.pixels,
            g.width as u32,
            g.height as u32,
            ExtendedColorType::L8,
        )
        .unwrap();
    out
}

/// The bytes of a colour JPEG of a gray frame (decodes to nearly, not exactly, the frame).
pub fn jpeg(g: &Gray) -> Vec<u8> {
    use image::{ExtendedColorType, ImageEncoder, codecs::jpeg::JpegEncoder};
    let rgb: Vec<u8> = g.pixels.iter().flat_map(|&p| [p, p / 2, 255 - p]).collect();
    let mut out = Vec::new();
    JpegEncoder::new_with_quality(&mut out, 95)
        .write_image(
            &rgb,
            g.width as u32,
            g.height as u32,
            ExtendedColorType::Rgb8,
        )
        .unwrap();
    out
}

/// A Y4M stream of `frames` with chroma layout `chroma` (e.g. "420jpeg",
/// "444", "mono"; "" for no C tag), chroma planes filled with noise.
pub fn y4m(frames: &[Gray], chroma: &str) -> Vec<u8> {
    let (w, h) = frames[0].size();
    let tag = if chroma.is_empty() {
        String::new()
    } else {
        format!(" C{chroma}")
    };
    let mut out = format!("YUV4MPEG2 W{w} H{h} F25:1 Ip A1:1{tag}\n").into_bytes();
    let half = |n: usize| n.div_ceil(2);
    let extra = match chroma {
        "" | "420jpeg" | "420paldv" | "420mpeg2" | "420" => 2 * half(w) * half(h),
        "422" => 2 * half(w) * h,
        "411" => 2 * w.div_ceil(4) * h,
        "444" => 2 * w * h,
        "444alpha" => 3 * w * h,
        "mono" => 0,
        other => panic!("no layout {other}"),
    };
    for (i, f) in frames.iter().enumerate() {
        out.extend_from_slice(b"FRAME\n");
        out.extend_from_slice(&f.pixels);
        out.extend((0..extra).map(|k| (k * 31 + i * 7) as u8));
    }
    out
}

/// Every file under `dir`, as sorted relative paths with `/`.
pub fn tree(dir: &Path) -> Vec<String> {
    fn walk(base: &Path, dir: &Path, out: &mut Vec<String>) {
        let Ok(entries) = fs::read_dir(dir) else {
            return;
        };
        for e in entries.map(Result::unwrap) {
            let p = e.path();
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                let rel = p.strip_prefix(base).unwrap();
                out.push(rel.to_string_lossy().replace('\\', "/"));
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// Temp files of atomic writes (hidden `.tmp` names) anywhere under `dir`.
pub fn temp_files(dir: &Path) -> Vec<String> {
    tree(dir)
        .into_iter()
        .filter(|p| {
            let name = p.rsplit('/').next().unwrap();
            name.starts_with('.') && name.ends_with(".tmp")
        })
        .collect()
}

/// The RGB8 pixels of a PNG.
pub fn rgb(path: &Path) -> Vec<u8> {
    image_file::read_rgb8(path, Limits::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .bytes
}

/// Whether this environment must have ffmpeg (CI, or asked for).
pub fn ffmpeg_required() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true")
        || std::env::var("REYNOLDSFLOW_REQUIRE_FFMPEG").is_ok_and(|v| v == "1")
}

/// Whether `ffmpeg` runs here; panics when it is required and missing.
pub fn have_ffmpeg() -> bool {
    let found = Command::new("ffmpeg")
        .arg("-version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        found || !ffmpeg_required(),
        "ffmpeg is required here (CI=true or REYNOLDSFLOW_REQUIRE_FFMPEG=1) but not installed: apt-get install ffmpeg"
    );
    if !found {
        println!(
            "ffmpeg not installed: skipping the ffmpeg decode checks (the missing-ffmpeg error is still tested)"
        );
    }
    found
}

/// Encode the PGM frames `dir/f%d.pgm` (from 0) with ffmpeg, codec args given.
pub fn ffmpeg_encode(dir: &Path, out: &Path, codec: &[&str]) {
    let status = Command::new("ffmpeg")
        .args(["-nostdin", "-v", "error", "-y", "-framerate", "25", "-i"])
        .arg(dir.join("f%d.pgm"))
        .args(codec)
        .arg(out)
        .status()
        .expect("run ffmpeg");
    assert!(
        status.success(),
        "ffmpeg could not encode {}",
        out.display()
    );
}

/// Write `frames` as `dir/f0.pgm`, `dir/f1.pgm`, …
pub fn write_pgms(dir: &Path, frames: &[Gray]) -> Vec<PathBuf> {
    fs::create_dir_all(dir).unwrap();
    frames
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let p = dir.join(format!("f{i}.pgm"));
            fs::write(&p, pgm(f)).unwrap();
            p
        })
        .collect()
}

/// Poll `ready` until it holds, then SIGKILL `child`; give up when the
/// child ends first or `within` passes. Waits for the child either way;
/// whether it was killed.
pub fn kill_when(child: &mut Child, within: Duration, mut ready: impl FnMut() -> bool) -> bool {
    let started = Instant::now();
    let killed = loop {
        if ready() {
            child.kill().unwrap();
            break true;
        }
        if child.try_wait().unwrap().is_some() || started.elapsed() > within {
            break false;
        }
        std::thread::sleep(Duration::from_millis(1));
    };
    child.wait().unwrap();
    killed
}

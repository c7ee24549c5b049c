//! `reynoldsflow budget` prints the engine's working bytes and the halo
//! overhead, and they agree with the core's own figures.

use std::process::Command;

use reynoldsflow_core::Engine;

fn budget(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_reynoldsflow"))
        .arg("budget")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

/// The best shape for 640×480 in 32 KiB: 92-px strips (seven of them) fit,
/// 93-px ones do not, and 80-px ones (eight) pay more halo.
#[test]
fn budget_of_92_px_strips_fits_32_kib_at_1_19_overhead() {
    let (ok, stdout, _) = budget(&["--width", "640", "--height", "480", "--tile", "92x480"]);
    assert!(ok);
    assert_eq!(
        stdout,
        format!(
            "working_bytes={} overhead=1.1868\n",
            Engine::<106>::WORKING_BYTES
        )
    );
    const { assert!(Engine::<106>::WORKING_BYTES <= 32 * 1024) };
    const { assert!(Engine::<107>::WORKING_BYTES > 32 * 1024) };
    let (ok, stdout, _) = budget(&["--width", "640", "--height", "480", "--tile", "80x480"]);
    assert!(ok);
    assert!(stdout.ends_with(" overhead=1.2093\n"), "{stdout}");
}

#[test]
fn tiles_larger_than_the_frame_are_the_frame() {
    let (ok, stdout, _) = budget(&["--width", "20", "--height", "10", "--tile", "500x500"]);
    assert!(ok);
    // One 20×10 tile read with its halo: 34 × 24 pixels for 200.
    assert_eq!(
        stdout,
        format!(
            "working_bytes={} overhead=4.0800\n",
            Engine::<34>::WORKING_BYTES
        )
    );
}

#[test]
fn bad_geometry_is_refused() {
    for args in [
        ["--width", "0", "--height", "10", "--tile", "8x8"],
        ["--width", "10", "--height", "70000", "--tile", "8x8"],
        ["--width", "10", "--height", "10", "--tile", "8by8"],
    ] {
        let (ok, stdout, stderr) = budget(&args);
        assert!(!ok && stdout.is_empty(), "{args:?}");
        assert!(
            stderr.starts_with("reynoldsflow: error:"),
            "{args:?}: {stderr}"
        );
    }
}

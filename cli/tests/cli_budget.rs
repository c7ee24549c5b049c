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

/// The best shape for 640×480 in 32 KiB: six strips, the fewest that fit
/// (a strip of 115 px is the widest that does, 128-px ones for five strips
/// do not), the narrowest of them 107 px (least memory at that overhead);
/// 80-px strips (eight) pay more halo.
#[test]
fn budget_of_107_px_strips_fits_32_kib_at_1_16_overhead() {
    let (ok, stdout, _) = budget(&["--width", "640", "--height", "480", "--tile", "107x480"]);
    assert!(ok);
    assert_eq!(
        stdout,
        format!(
            "working_bytes={} overhead=1.1642\n",
            Engine::<121>::WORKING_BYTES
        )
    );
    const { assert!(Engine::<121>::WORKING_BYTES <= 32 * 1024) };
    const { assert!(Engine::<129>::WORKING_BYTES <= 32 * 1024) };
    const { assert!(Engine::<130>::WORKING_BYTES > 32 * 1024) };
    let (ok, stdout, _) = budget(&["--width", "640", "--height", "480", "--tile", "128x480"]);
    assert!(ok);
    assert!(stdout.starts_with("working_bytes=35816 "), "{stdout}");
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

/// Every row of the firmware guide's "Memory and tiling" table is what
/// `budget` prints for it (the table cannot drift from the engine's layout).
#[test]
fn the_guides_memory_table_is_what_budget_prints() {
    let readme =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/firmware.md"))
            .expect("docs/firmware.md");
    let start = readme
        .find("## Memory and tiling")
        .expect("docs/firmware.md has a \"Memory and tiling\" section");
    let section = &readme[start..];
    let rows: Vec<Vec<&str>> = section
        .lines()
        .skip_while(|l| !l.starts_with("| frame |"))
        .skip(2)
        .take_while(|l| l.starts_with('|'))
        .map(|l| l.trim_matches('|').split('|').map(str::trim).collect())
        .collect();
    assert!(rows.len() >= 10, "the table has {} rows", rows.len());
    for row in rows {
        let [frame, tile, bytes, overhead] = row[..] else {
            panic!("a row of {} cells: {row:?}", row.len());
        };
        let (w, h) = frame.split_once('×').expect("W×H");
        let tile = tile.replace('×', "x");
        let (ok, stdout, stderr) = budget(&["--width", w, "--height", h, "--tile", &tile]);
        assert!(ok, "{row:?}: {stderr}");
        let bytes: String = bytes.chars().filter(|c| !c.is_whitespace()).collect();
        let printed: f64 = stdout
            .trim()
            .rsplit_once("overhead=")
            .and_then(|(_, o)| o.parse().ok())
            .expect("an overhead");
        assert!(
            stdout.starts_with(&format!("working_bytes={bytes} ")),
            "{row:?}: budget prints {stdout}"
        );
        assert_eq!(
            format!("{printed:.3}"),
            overhead,
            "{row:?}: budget prints {stdout}"
        );
    }
}

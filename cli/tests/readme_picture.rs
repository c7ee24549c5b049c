//! The README's first picture is what its command 1 writes: the PNG in
//! docs/ is byte for byte the file `reynoldsflow run --out reynoldsflow-out`
//! makes for frame 10 of the built-in demo, so it cannot drift from the code.

mod run_support;

use run_support::*;

#[test]
fn the_readme_picture_is_what_command_1_writes() {
    let tmp = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(BIN)
        .args(["run", "--out", "reynoldsflow-out"])
        .current_dir(tmp.path())
        .output()
        .unwrap();
    ok(&out);
    let written = std::fs::read(tmp.path().join("reynoldsflow-out/000010.png")).unwrap();
    let readme = concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md");
    let picture = "docs/run-output.png";
    assert!(
        std::fs::read_to_string(readme)
            .unwrap()
            .contains(&format!("]({picture})")),
        "README.md no longer shows {picture}"
    );
    let committed = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../docs/run-output.png"
    ))
    .unwrap();
    assert!(
        written == committed,
        "{picture} is not what `run` writes for frame 10 of the demo: copy reynoldsflow-out/000010.png there"
    );
}

//! The committed header is what cbindgen generates from the crate now.

use std::path::Path;

#[test]
fn committed_header_is_generated_from_the_crate() {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config =
        cbindgen::Config::from_file(crate_dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_crate(crate_dir)
        .with_config(config)
        .generate()
        .expect("cbindgen parses the crate")
        .write(&mut generated);
    let header = crate_dir.join("include/reynoldsflow.h");
    if std::env::var_os("REYNOLDSFLOW_BLESS").is_some() {
        std::fs::write(&header, &generated).expect("write the header");
    }
    let committed = std::fs::read(&header).unwrap_or_default();
    assert!(
        committed == generated,
        "capi/include/reynoldsflow.h differs from what cbindgen generates; regenerate with \
         REYNOLDSFLOW_BLESS=1 cargo test -p reynoldsflow-capi --test header"
    );
}

//! Golden bytes: the fixed core's output on the shared vectors, committed in
//! `tests/golden/`, so any change to the fixed-point arithmetic shows up as
//! a reviewed diff (`SUMMARY.txt` names what changed). After a deliberate
//! change, regenerate with
//! `REYNOLDSFLOW_BLESS=1 cargo test -p reynoldsflow-tests --test golden`:
//! blessing also appends to `SUMMARY.txt`, below [`CHANGES`], how many
//! bytes of each output changed against the goldens it replaces and by how
//! much (the check compares only the part above that line).

use std::fmt::Write as _;
use std::path::PathBuf;

use fixed::types::U16F16;
use reynoldsflow_core::{Params, Scaling};
use reynoldsflow_host::fixed_engine::{FixedOutput, compute_fixed};
use reynoldsflow_host::image_io;
use reynoldsflow_tests::{vector_cases, vectors_dir};

/// The line that starts the record of the last blessing's changes.
const CHANGES: &str = "# changes at the last blessing";

fn golden_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("golden")
}

/// FNV-1a, 64 bits: a stable fingerprint for the summary.
fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    })
}

/// The fields' raw bits: four i32 planes (Q16.16 `v_c` x, y, `v_d` x, y),
/// then two u64 planes (Q32.32 `|v_c|`, `|v_d|`), little-endian.
fn field_bytes(out: &FixedOutput) -> Vec<u8> {
    let mut bytes = Vec::new();
    for plane in [
        &out.planes.vcx,
        &out.planes.vcy,
        &out.planes.vdx,
        &out.planes.vdy,
    ] {
        // Exact: the planes hold Q16.16 values converted to f64.
        bytes.extend(
            plane
                .iter()
                .flat_map(|v| ((v * 65536.0) as i32).to_le_bytes()),
        );
    }
    for plane in [&out.m_c, &out.m_d] {
        bytes.extend(
            plane
                .iter()
                .flat_map(|v| ((v * 4_294_967_296.0) as u64).to_le_bytes()),
        );
    }
    bytes
}

/// Differing elements and the largest difference, reading both as
/// little-endian integers of `width` bytes (1 for pixels).
fn changes(old: &[u8], new: &[u8], width: usize) -> String {
    if old.len() != new.len() {
        return format!("size {} -> {}", old.len(), new.len());
    }
    let value = |c: &[u8]| -> i128 {
        match width {
            1 => i128::from(c[0]),
            4 => i128::from(i32::from_le_bytes(c.try_into().unwrap())),
            _ => i128::from(u64::from_le_bytes(c.try_into().unwrap())),
        }
    };
    let (mut count, mut max) = (0usize, 0i128);
    for (a, b) in old.chunks(width).zip(new.chunks(width)) {
        let diff = (value(a) - value(b)).abs();
        count += usize::from(diff != 0);
        max = max.max(diff);
    }
    format!("{count} of {} differ, by at most {max}", old.len() / width)
}

/// What blessing `bytes` changes in the golden output `name` at `path`.
fn change_note(path: &std::path::Path, name: &str, bytes: &[u8], quads: usize) -> String {
    let old = match name.ends_with(".png") {
        true => image_io::read_rgb8(path).map(|img| img.bytes).ok(),
        false => std::fs::read(path).ok(),
    };
    let Some(old) = old else {
        return "new".into();
    };
    match name.ends_with(".png") {
        true => format!("bytes: {}", changes(&old, bytes, 1)),
        // Four i32 planes of `quads` values, then two u64 planes.
        false if old.len() == bytes.len() => {
            let split = 4 * 4 * quads;
            format!(
                "Q16.16 field values: {}; Q32.32 magnitudes: {}",
                changes(&old[..split], &bytes[..split], 4),
                changes(&old[split..], &bytes[split..], 8)
            )
        }
        false => changes(&old, bytes, 1),
    }
}

#[test]
fn fixed_core_output_equals_the_golden_bytes() {
    let bless = std::env::var_os("REYNOLDSFLOW_BLESS").is_some();
    let fixed = Scaling::Fixed {
        k_d: U16F16::from_num(8),
        k_c: U16F16::from_num(32),
    };
    let mut summary =
        String::from("# case output bytes fnv1a64 (regenerate: see tests/golden.rs)\n");
    let mut changed = Vec::new();
    let mut notes = format!("{CHANGES} (not checked; written by blessing)\n");
    for case in vector_cases() {
        let dir = vectors_dir().join(&case);
        let f0 = image_io::read_gray(&dir.join("f0.pgm")).unwrap();
        let f1 = image_io::read_gray(&dir.join("f1.pgm")).unwrap();
        let minmax =
            compute_fixed(&f0, &f1, Params::DEFAULT, None, Scaling::PerFrameMinMax).unwrap();
        let fixed = compute_fixed(&f0, &f1, Params::DEFAULT, None, fixed).unwrap();
        // PNGs are compared by their pixels (encoders may change), the fields by their bytes.
        let outputs = [
            ("fields.bin", field_bytes(&minmax)),
            ("rep_minmax.png", minmax.rep.clone()),
            ("rep_fixed.png", fixed.rep.clone()),
        ];
        for (name, bytes) in outputs {
            let path = golden_dir().join(&case).join(name);
            let is_png = name.ends_with(".png");
            writeln!(
                summary,
                "{case} {name} {} {:016x}",
                bytes.len(),
                fnv(&bytes)
            )
            .unwrap();
            if bless {
                let note = change_note(&path, name, &bytes, f0.width * f0.height);
                writeln!(notes, "{case} {name}: {note}").unwrap();
                std::fs::create_dir_all(path.parent().unwrap()).unwrap();
                match is_png {
                    true => image_io::write_png(&path, f0.width, f0.height, &bytes).unwrap(),
                    false => std::fs::write(&path, &bytes).unwrap(),
                }
                continue;
            }
            let golden = match is_png {
                true => image_io::read_rgb8(&path)
                    .map(|img| img.bytes)
                    .map_err(|e| e.to_string()),
                false => std::fs::read(&path).map_err(|e| e.to_string()),
            };
            let golden =
                golden.unwrap_or_else(|e| panic!("{}: {e} (bless to create it)", path.display()));
            if golden != bytes {
                changed.push(format!("{case}/{name}"));
            }
        }
    }
    let summary_path = golden_dir().join("SUMMARY.txt");
    if bless {
        std::fs::write(&summary_path, format!("{summary}{notes}")).unwrap();
    }
    assert!(
        changed.is_empty(),
        "fixed-point output changed: {changed:?}"
    );
    let committed = std::fs::read_to_string(&summary_path).unwrap();
    let checked = committed.split(CHANGES).next().unwrap_or_default();
    assert_eq!(checked, summary, "SUMMARY.txt is stale");
}

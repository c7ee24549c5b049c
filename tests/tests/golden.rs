//! Golden bytes: the fixed core's output on the shared vectors, committed in
//! `tests/golden/`, so any change to the core's arithmetic shows up as a
//! reviewed diff (`SUMMARY.txt` names what changed). After a deliberate
//! change, regenerate with
//! `REYNOLDSFLOW_BLESS=1 cargo test -p reynoldsflow-tests --test golden`:
//! blessing also appends to `SUMMARY.txt`, below [`CHANGES`], how many
//! bytes of each output changed against the goldens it replaces and by how
//! much (the check compares only the part above that line).
//!
//! The host engine's image (`PairEngine::image`, per-frame min–max: the
//! engine pass, then the byte step of the widest instructions, AVX2 or
//! NEON) must give the committed min–max bytes too, on one thread and on
//! several; `scripts/test-resample-aarch64` runs this file under
//! `qemu-aarch64`, so the aarch64 build's bytes are held to these.

use std::fmt::Write as _;
use std::path::PathBuf;

use fixed::types::U16F16;
use reynoldsflow_core::{Params, Scaling};
use reynoldsflow_host::engine::PairEngine;
use reynoldsflow_host::internals::{FixedOutput, compute_fixed};
use reynoldsflow_host::io::image_file;
use reynoldsflow_host::limits::Limits;
use reynoldsflow_host::settings::Settings;
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

/// The fields' raw bits: six `f32` planes (`v_c` x, y, `v_d` x, y, `|v_c|`,
/// `|v_d|`), little-endian.
fn field_bytes(out: &FixedOutput) -> Vec<u8> {
    let planes = [
        &out.planes.v_c.u,
        &out.planes.v_c.v,
        &out.planes.v_d.u,
        &out.planes.v_d.v,
        &out.m_c,
        &out.m_d,
    ];
    // Exact: the planes hold the core's `f32` values converted to f64.
    planes
        .into_iter()
        .flat_map(|plane| plane.iter().flat_map(|&v| (v as f32).to_le_bytes()))
        .collect()
}

/// The values of a `fields.bin` of `pixels` pixels, in pixels: the six
/// `f32` planes of [`field_bytes`], or the format before it (until the
/// core's tail moved to `f32`: four Q16.16 `i32` planes, then two Q32.32
/// `u64` planes), so that a blessing across the change can say by how much
/// the values moved.
fn field_values(bytes: &[u8], pixels: usize) -> Option<Vec<f64>> {
    if bytes.len() == 24 * pixels {
        let values = bytes.chunks_exact(4);
        return Some(
            values
                .map(|c| f64::from(f32::from_le_bytes(c.try_into().unwrap())))
                .collect(),
        );
    }
    if bytes.len() != 32 * pixels {
        return None;
    }
    let (q16, q32) = bytes.split_at(16 * pixels);
    let fields = q16
        .chunks_exact(4)
        .map(|c| f64::from(i32::from_le_bytes(c.try_into().unwrap())) / 65536.0);
    let magnitudes = q32
        .chunks_exact(8)
        .map(|c| u64::from_le_bytes(c.try_into().unwrap()) as f64 / 4_294_967_296.0);
    Some(fields.chain(magnitudes).collect())
}

/// Differing pixel bytes and the largest difference.
fn byte_changes(old: &[u8], new: &[u8]) -> String {
    if old.len() != new.len() {
        return format!("size {} -> {}", old.len(), new.len());
    }
    let diffs = old.iter().zip(new).map(|(a, b)| a.abs_diff(*b));
    let (count, max) = diffs.fold((0, 0), |(n, m), d| (n + usize::from(d != 0), m.max(d)));
    format!("{count} of {} differ, by at most {max}", old.len())
}

/// Differing field values (fields, then magnitudes) and the largest
/// differences, absolute in pixels and relative to each plane's largest
/// value.
fn field_changes(old: &[f64], new: &[f64], pixels: usize) -> String {
    let part = |range: core::ops::Range<usize>| {
        let (old, new) = (&old[range.clone()], &new[range]);
        let scale = old
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()))
            .max(f64::MIN_POSITIVE);
        let (mut count, mut max) = (0usize, 0.0f64);
        for (a, b) in old.iter().zip(new) {
            count += usize::from(a != b);
            max = max.max((a - b).abs());
        }
        format!(
            "{count} of {} differ, by at most {max:.3e} px ({:.1e} of the largest)",
            old.len(),
            max / scale
        )
    };
    format!(
        "field values: {}; magnitudes: {}",
        part(0..4 * pixels),
        part(4 * pixels..6 * pixels)
    )
}

/// What blessing `bytes` changes in the golden output `name` at `path`.
fn change_note(path: &std::path::Path, name: &str, bytes: &[u8], pixels: usize) -> String {
    let old = match name.ends_with(".png") {
        true => image_file::read_rgb8(path, Limits::default())
            .map(|img| img.bytes)
            .ok(),
        false => std::fs::read(path).ok(),
    };
    let Some(old) = old else {
        return "new".into();
    };
    if name.ends_with(".png") {
        return format!("bytes: {}", byte_changes(&old, bytes));
    }
    match (field_values(&old, pixels), field_values(bytes, pixels)) {
        (Some(old), Some(new)) => field_changes(&old, &new, pixels),
        _ => byte_changes(&old, bytes),
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
        let f0 = image_file::read_gray(&dir.join("f0.pgm"), Limits::default()).unwrap();
        let f1 = image_file::read_gray(&dir.join("f1.pgm"), Limits::default()).unwrap();
        let minmax =
            compute_fixed(&f0, &f1, Params::DEFAULT, None, Scaling::PerFrameMinMax).unwrap();
        let fixed = compute_fixed(&f0, &f1, Params::DEFAULT, None, fixed).unwrap();
        for threads in [1, 3] {
            let settings = Settings {
                threads: Some(threads),
                ..Settings::default()
            };
            let mut engine = PairEngine::new(&settings).unwrap();
            let image = engine.image_vec(&f0, &f1).unwrap();
            assert!(
                image == minmax.rep,
                "{case}: PairEngine::image on {threads} thread(s)"
            );
        }
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
                    true => image_file::write_png(&path, f0.width, f0.height, &bytes).unwrap(),
                    false => std::fs::write(&path, &bytes).unwrap(),
                }
                continue;
            }
            let golden = match is_png {
                true => image_file::read_rgb8(&path, Limits::default())
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
    assert!(changed.is_empty(), "the core's output changed: {changed:?}");
    let committed = std::fs::read_to_string(&summary_path).unwrap();
    let checked = committed.split(CHANGES).next().unwrap_or_default();
    assert_eq!(checked, summary, "SUMMARY.txt is stale");
}

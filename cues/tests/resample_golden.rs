//! The resampler's golden bytes (`cues/tests/golden/resample/`): fixed
//! inputs resized down, up, mixed and to their own size, compared byte for
//! byte with the committed outputs. The same test runs on x86-64 (`cargo
//! test`) and on aarch64 under qemu-aarch64 (scripts/test-resample-aarch64):
//! the integer definition must give one set of bytes everywhere.
//!
//! `REYNOLDSFLOW_BLESS=1` rewrites the files (review the diff: a change
//! here changes every resized dataset).

use std::fmt::Write as _;
use std::path::PathBuf;

use reynoldsflow_cues::resample::Resize;

/// `(source, destination)` sizes: area down (integer and fractional
/// factors), bilinear up, one axis each way, the identity, and 1-px sides.
const CASES: [((usize, usize), (usize, usize)); 12] = [
    ((64, 48), (32, 24)),
    ((64, 48), (20, 15)),
    ((64, 48), (64, 48)),
    ((64, 48), (100, 75)),
    ((64, 48), (96, 36)),
    ((64, 48), (7, 5)),
    ((64, 48), (1, 1)),
    ((37, 23), (16, 10)),
    ((37, 23), (50, 31)),
    ((37, 23), (5, 40)),
    ((1, 1), (3, 3)),
    ((5, 1), (2, 4)),
];

/// A frame with smooth gradients, a sharp edge and fixed-seed noise, in
/// integers only.
fn input(w: usize, h: usize) -> Vec<u8> {
    let mut state = 0x2545_f491_u32;
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let noise = (state >> 27) as usize;
            let edge = if 3 * x + 2 * y > 2 * w { 90 } else { 0 };
            ((x * x * 3 / (w + 1) + y * 5 + (x * y) / 4 + edge + noise) % 256) as u8
        })
        .collect()
}

fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    })
}

fn golden_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden/resample")
}

#[test]
fn resized_frames_equal_the_golden_bytes() {
    let bless = std::env::var("REYNOLDSFLOW_BLESS").is_ok_and(|v| v == "1");
    let dir = golden_dir();
    let mut summary = String::from(
        "# cues/tests/resample_golden.rs: source -> destination, FNV-1a 64 of the output bytes\n",
    );
    let mut differ = Vec::new();
    for ((sw, sh), (dw, dh)) in CASES {
        let src = input(sw, sh);
        let mut out = vec![0u8; dw * dh];
        Resize::new(sw, sh, dw, dh)
            .unwrap()
            .frame(&src, &mut out)
            .unwrap();
        let name = format!("{sw}x{sh}-to-{dw}x{dh}.gray");
        writeln!(summary, "{name} {:016x}", fnv1a64(&out)).unwrap();
        let path = dir.join(&name);
        if bless {
            std::fs::write(&path, &out).unwrap();
            continue;
        }
        let golden = std::fs::read(&path)
            .unwrap_or_else(|e| panic!("{}: {e} (REYNOLDSFLOW_BLESS=1 writes it)", path.display()));
        if golden != out {
            let first = golden.iter().zip(&out).position(|(a, b)| a != b);
            differ.push(format!("{name}: first difference at byte {first:?}"));
        }
    }
    let summary_path = dir.join("SUMMARY.txt");
    if bless {
        std::fs::write(&summary_path, &summary).unwrap();
        return;
    }
    assert!(
        differ.is_empty(),
        "resized bytes differ from the golden files: {differ:#?}"
    );
    assert_eq!(std::fs::read_to_string(summary_path).unwrap(), summary);
    println!(
        "{} resizes equal their golden bytes on {}",
        CASES.len(),
        std::env::consts::ARCH
    );
}

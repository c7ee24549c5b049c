//! The fixed-point core against float64: on the shared vectors and on
//! property-generated pairs, within the foundation issue's tolerances:
//! `v_c` within max(1e-4·max|v_c|, 2⁻¹⁴) everywhere; `v_d` within
//! 1e-3·max|v_d| at ≥ 99.9 % of pixels and 1e-2·max|v_d| everywhere;
//! representation bytes within ±1 and ≥ 99 % identical in both scale modes.
//! `v_d`'s bounds have a floor of one Q16.16 step (2⁻¹⁶): where the float
//! field is rounding residue (the 1×1 vector's `|v_d|` = 4.9e-14, exactly 0
//! in exact arithmetic), no fixed-point value can be relatively close.

use fixed::types::U16F16;
use proptest::prelude::*;
use reynoldsflow_core::{Params, Scaling};
use reynoldsflow_host::fixed_engine::{FixedOutput, compute_fixed};
use reynoldsflow_host::reference::{self, FloatFlow, FloatParams, FloatScaling};
use reynoldsflow_host::{Gray, image_io, npy};
use reynoldsflow_tests::{FieldError, Pattern, byte_diff, frame_pair, vector_cases, vectors_dir};

const K_D: f64 = 8.0;
const K_C: f64 = 32.0;

fn fixed_scaling(minmax: bool) -> Scaling {
    match minmax {
        true => Scaling::PerFrameMinMax,
        false => Scaling::Fixed {
            k_d: U16F16::from_num(K_D),
            k_c: U16F16::from_num(K_C),
        },
    }
}

fn float_scaling(minmax: bool) -> FloatScaling {
    match minmax {
        true => FloatScaling::PerFrameMinMax,
        false => FloatScaling::Fixed { k_d: K_D, k_c: K_C },
    }
}

/// Field errors of the fixed output against float fields; panics past tolerance.
fn check_fields(what: &str, fixed: &FixedOutput, float: &FloatFlow) -> (FieldError, FieldError) {
    let vc = FieldError::measure(
        &fixed.planes.vcx,
        &fixed.planes.vcy,
        &float.vcx,
        &float.vcy,
        |m| (1e-4 * m).max(2f64.powi(-14)),
    );
    assert_eq!(vc.over, 0, "{what}: v_c beyond tolerance: {vc:?}");
    let q16 = 2f64.powi(-16);
    let vd = FieldError::measure(
        &fixed.planes.vdx,
        &fixed.planes.vdy,
        &float.vdx,
        &float.vdy,
        |m| (1e-3 * m).max(q16),
    );
    assert!(
        vd.over * 1000 <= vd.pixels,
        "{what}: v_d beyond 1e-3·max at over 0.1 % of pixels: {vd:?}"
    );
    assert!(
        vd.max_err <= (1e-2 * vd.max_ref).max(q16),
        "{what}: v_d beyond 1e-2·max: {vd:?}"
    );
    (vc, vd)
}

/// Byte differences of the fixed representation against a float one; panics past tolerance.
fn check_bytes(what: &str, fixed: &[u8], float: &[u8]) -> usize {
    let (max, differing) = byte_diff(fixed, float);
    assert!(max <= 1, "{what}: bytes differ by {max}");
    assert!(
        differing * 100 <= fixed.len(),
        "{what}: {differing} of {} bytes differ",
        fixed.len()
    );
    differing
}

#[derive(Default)]
struct Tally {
    vc_max: f64,
    vc_sq: f64,
    vd_rel_max: f64,
    vd_rel_sq: f64,
    n: f64,
    bytes: usize,
    bytes_differing: usize,
}

impl Tally {
    fn add(&mut self, vc: FieldError, vd: FieldError) {
        let rel = vd.max_ref.max(2f64.powi(-16));
        self.vc_max = self.vc_max.max(vc.max_err);
        self.vc_sq += vc.rms_err * vc.rms_err;
        self.vd_rel_max = self.vd_rel_max.max(vd.max_err / rel);
        self.vd_rel_sq += (vd.rms_err / rel).powi(2);
        self.n += 1.0;
    }

    fn print(&self, what: &str) {
        println!(
            "{what}: v_c max err {:.3e} px (rms {:.3e}); v_d max err {:.3e} of max|v_d| (rms {:.3e}); \
             bytes differing {} of {} ({:.4} %)",
            self.vc_max,
            (self.vc_sq / self.n).sqrt(),
            self.vd_rel_max,
            (self.vd_rel_sq / self.n).sqrt(),
            self.bytes_differing,
            self.bytes,
            100.0 * self.bytes_differing as f64 / self.bytes.max(1) as f64
        );
    }
}

#[test]
fn fixed_core_matches_the_vectors() {
    let mut tally = Tally::default();
    for case in vector_cases() {
        let dir = vectors_dir().join(&case);
        let f0 = image_io::read_gray(&dir.join("f0.pgm")).unwrap();
        let f1 = image_io::read_gray(&dir.join("f1.pgm")).unwrap();
        let plane = |name: &str| npy::read(&dir.join(format!("{name}.npy"))).unwrap().data;
        let vectors = FloatFlow {
            width: f0.width,
            height: f0.height,
            vcx: plane("vcx"),
            vcy: plane("vcy"),
            vdx: plane("vdx"),
            vdy: plane("vdy"),
        };
        for (minmax, png) in [(true, "rep.png"), (false, "rep_fixed.png")] {
            let fixed =
                compute_fixed(&f0, &f1, Params::DEFAULT, None, fixed_scaling(minmax)).unwrap();
            let (vc, vd) = check_fields(&case, &fixed, &vectors);
            tally.add(vc, vd);
            let expected = image_io::read_rgb8(&dir.join(png)).unwrap();
            tally.bytes_differing +=
                check_bytes(&format!("{case} {png}"), &fixed.rep, &expected.bytes);
            tally.bytes += fixed.rep.len();
        }
    }
    tally.print("fixed core vs vectors");
}

/// Frames of a generated pattern as `Gray` images.
fn grays(pattern: Pattern, w: usize, h: usize, seed: u64) -> (Gray, Gray) {
    let (a, b) = frame_pair(pattern, w, h, seed);
    (Gray::new(w, h, a).unwrap(), Gray::new(w, h, b).unwrap())
}

#[test]
fn fixed_core_matches_the_float_reference_on_generated_pairs() {
    let mut tally = Tally::default();
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
        cases: 240,
        ..ProptestConfig::default()
    });
    let strategy = (
        1usize..=96,
        1usize..=96,
        0usize..6,
        any::<u64>(),
        any::<bool>(),
    );
    let tally_cell = std::cell::RefCell::new(&mut tally);
    runner
        .run(&strategy, |(w, h, pattern, seed, minmax)| {
            let pattern = Pattern::ALL[pattern];
            let what = format!("{pattern:?} {w}x{h} seed {seed} minmax {minmax}");
            let (f0, f1) = grays(pattern, w, h, seed);
            let float = reference::compute(&f0, &f1, &FloatParams::default()).unwrap();
            let fixed =
                compute_fixed(&f0, &f1, Params::DEFAULT, None, fixed_scaling(minmax)).unwrap();
            let (vc, vd) = check_fields(&what, &fixed, &float);
            let rep = reference::representation(&float, &f0, float_scaling(minmax));
            let differing = check_bytes(&what, &fixed.rep, &rep);
            let mut tally = tally_cell.borrow_mut();
            tally.add(vc, vd);
            tally.bytes += rep.len();
            tally.bytes_differing += differing;
            Ok(())
        })
        .unwrap();
    tally.print("fixed core vs float reference, 240 generated pairs");
    assert_eq!(tally.n, 240.0);
}

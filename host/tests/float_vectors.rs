//! The float64 reference against every conformance vector (tests/vectors,
//! computed from the SPEC by an independent implementation): fields to
//! 1e-9 of each field's scale (a field that is rounding residue, below
//! SPEC §4's 1e-9 px, must be residue in ours too), representations
//! byte-exact except for rounding ties, which are counted and each one
//! checked to be a tie.

use std::fs;
use std::path::{Path, PathBuf};

use reynoldsflow_host::limits::Limits;
use reynoldsflow_host::reference::{self, FLAT_RANGE, FloatFlow, FloatParams, FloatScaling};
use reynoldsflow_host::settings::parse_ratio;
use reynoldsflow_host::{Gray, io::image_file, io::npy};

const VECTORS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/vectors");

/// Relative tolerance of the fields (vectors/README.md).
const FIELD_TOL: f64 = 1e-9;
/// How close to an integer `x·k + ½` must be for a differing byte to count as a tie.
const TIE_TOL: f64 = 1e-9;

struct Case {
    name: String,
    dir: PathBuf,
    prev: Gray,
    next: Gray,
    json: serde_json::Value,
}

impl Case {
    fn number(&self, key: &str) -> f64 {
        self.json[key]
            .as_f64()
            .unwrap_or_else(|| panic!("{}: case.json has no number {key}", self.name))
    }
}

fn cases() -> Vec<Case> {
    let mut dirs: Vec<PathBuf> = fs::read_dir(VECTORS)
        .expect("tests/vectors")
        .map(|e| e.unwrap().path())
        .filter(|p| p.join("case.json").exists())
        .collect();
    dirs.sort();
    // The README lists eleven cases (the last, plus1_48x32, checks SPEC §4's
    // flat range); fewer means the copy is incomplete.
    assert!(
        dirs.len() >= 11,
        "only {} vector cases in {VECTORS}",
        dirs.len()
    );
    dirs.into_iter()
        .map(|dir| Case {
            name: dir.file_name().unwrap().to_string_lossy().into_owned(),
            prev: image_file::read_gray(&dir.join("f0.pgm"), Limits::default()).unwrap(),
            next: image_file::read_gray(&dir.join("f1.pgm"), Limits::default()).unwrap(),
            json: serde_json::from_str(&fs::read_to_string(dir.join("case.json")).unwrap())
                .unwrap(),
            dir,
        })
        .collect()
}

fn params(case: &Case) -> FloatParams {
    let text = case.json["intensity_scale"]
        .as_str()
        .expect("intensity_scale");
    let (num, den) = parse_ratio(text).unwrap();
    FloatParams {
        intensity_scale: f64::from(num) / f64::from(den),
        lambda: case.number("lambda"),
    }
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// The largest magnitude `|v|` of a vector field: the scale its errors are
/// relative to (vectors/README.md: "relative to each field's largest
/// magnitude"). Per field, not per component: a component that is 0 in
/// exact arithmetic (`v_cy` of a one-row frame) holds only rounding
/// residue of the other's size, which no other summation order reproduces.
fn field_scale(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).fold(0.0f64, |m, (x, y)| m.max(x.hypot(*y)))
}

/// Largest `|ours − theirs|` over `scale`.
fn error(ours: &[f64], theirs: &[f64], scale: f64) -> f64 {
    ours.iter()
        .zip(theirs)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
        / scale
}

#[test]
fn fields_match_every_vector() {
    let mut worst = [0.0f64; 4];
    for case in cases() {
        let flow = reference::compute(&case.prev, &case.next, &params(&case)).unwrap();
        let (w, h) = (
            case.number("width") as usize,
            case.number("height") as usize,
        );
        assert_eq!((flow.width(), flow.height()), (w, h), "{}", case.name);
        let read = |name: &str| {
            let a = npy::read(&case.dir.join(format!("{name}.npy"))).unwrap();
            assert_eq!((a.height, a.width), (h, w), "{} {name}: shape", case.name);
            a.data
        };
        let theirs = ["vcx", "vcy", "vdx", "vdy"].map(read);
        let scales = [
            field_scale(&theirs[0], &theirs[1]),
            field_scale(&theirs[2], &theirs[3]),
        ];
        let ours = [&flow.v_c.u, &flow.v_c.v, &flow.v_d.u, &flow.v_d.v];
        let ours_scales = [field_scale(ours[0], ours[1]), field_scale(ours[2], ours[3])];
        let mut line = format!(
            "{:>16}  |v_c| {:.3e} |v_d| {:.3e}",
            case.name, scales[0], scales[1]
        );
        for (f, field) in ["v_c", "v_d"].iter().enumerate() {
            // A field below SPEC §4's flat range is rounding residue (0 in
            // exact arithmetic: plus1_48x32's v_c, pixel_1x1's v_d), whose
            // digits depend on summation order: ours must be residue too.
            if scales[f] < FLAT_RANGE {
                assert!(
                    ours_scales[f] < FLAT_RANGE,
                    "{} {field}: the vector's is residue ({:e}), ours {:e} is not",
                    case.name,
                    scales[f],
                    ours_scales[f]
                );
                line += &format!("  {field} residue (ours {:.1e})", ours_scales[f]);
                continue;
            }
            for k in [2 * f, 2 * f + 1] {
                let name = ["vcx", "vcy", "vdx", "vdy"][k];
                let err = error(ours[k], &theirs[k], scales[f]);
                line += &format!("  {name} {err:.1e}");
                assert!(
                    err <= FIELD_TOL,
                    "{} {name}: relative error {err:e} > {FIELD_TOL:e}",
                    case.name
                );
                worst[k] = worst[k].max(err);
            }
        }
        println!("{line}");
        // case.json records the magnitudes' maxima as well.
        let (m_d, m_c) = flow.magnitudes();
        for (name, ours, theirs, scale) in [
            ("max_m_d", max_abs(&m_d), case.number("max_m_d"), scales[1]),
            ("max_m_c", max_abs(&m_c), case.number("max_m_c"), scales[0]),
        ] {
            let agree = match scale < FLAT_RANGE {
                true => ours < FLAT_RANGE,
                false => (ours - theirs).abs() <= FIELD_TOL * scale,
            };
            assert!(agree, "{} {name}: {ours} vs {theirs}", case.name);
        }
    }
    println!(
        "worst relative error: vcx {:.1e}, vcy {:.1e}, vdx {:.1e}, vdy {:.1e}",
        worst[0], worst[1], worst[2], worst[3]
    );
}

/// Compare a representation with a stored PNG: B exactly, R and G exactly
/// or off by one at a rounding tie of `x · k + ½`. Returns the tie count.
fn compare_rep(case: &Case, file: &str, flow: &FloatFlow, scaling: FloatScaling) -> usize {
    let ours = reference::representation(flow, &case.prev, scaling);
    let theirs = image_file::read_rgb8(&case.dir.join(file), Limits::default()).unwrap();
    assert_eq!(
        (theirs.width, theirs.height),
        (flow.width(), flow.height()),
        "{} {file}",
        case.name
    );
    let (m_d, m_c) = flow.magnitudes();
    // x and k of each channel, as the SPEC defines them for this mode.
    let affine = |m: &[f64], fixed_k: f64| match scaling {
        FloatScaling::Fixed { .. } => (0.0, fixed_k),
        FloatScaling::PerFrameMinMax => {
            let min = m.iter().copied().fold(f64::INFINITY, f64::min);
            let max = m.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            (min, 255.0 / (max - min))
        }
    };
    let (k_d, k_c) = match scaling {
        FloatScaling::Fixed { k_d, k_c } => (k_d, k_c),
        FloatScaling::PerFrameMinMax => (0.0, 0.0),
    };
    let channels = [(&m_d, affine(&m_d, k_d)), (&m_c, affine(&m_c, k_c))];
    let mut ties = 0;
    for (i, (a, b)) in ours.chunks(3).zip(theirs.bytes.chunks(3)).enumerate() {
        assert_eq!(a[2], b[2], "{} {file}: B channel at pixel {i}", case.name);
        for (c, (m, (min, k))) in channels.iter().enumerate() {
            if a[c] == b[c] {
                continue;
            }
            let t = (m[i] - min) * k + 0.5;
            let tie = (t - t.round()).abs() <= TIE_TOL;
            assert!(
                tie && a[c].abs_diff(b[c]) == 1,
                "{} {file}: channel {c} at pixel {i}: ours {} theirs {}, x·k + ½ = {t:.12}",
                case.name,
                a[c],
                b[c]
            );
            ties += 1;
        }
    }
    ties
}

#[test]
fn representations_match_every_vector_but_for_ties() {
    let (mut total_minmax, mut total_fixed, mut bytes) = (0, 0, 0);
    for case in cases() {
        let flow = reference::compute(&case.prev, &case.next, &params(&case)).unwrap();
        let fixed = FloatScaling::Fixed {
            k_d: case.number("fixed_k_d"),
            k_c: case.number("fixed_k_c"),
        };
        let minmax = compare_rep(&case, "rep.png", &flow, FloatScaling::PerFrameMinMax);
        let fixed = compare_rep(&case, "rep_fixed.png", &flow, fixed);
        println!(
            "{:>16}  rep.png ties {minmax}, rep_fixed.png ties {fixed}",
            case.name
        );
        total_minmax += minmax;
        total_fixed += fixed;
        bytes += 2 * flow.width() * flow.height();
    }
    println!(
        "rounding ties: rep.png {total_minmax}, rep_fixed.png {total_fixed} (of {bytes} R/G bytes each)"
    );
}

#[test]
fn the_vectors_folder_is_where_the_tests_look() {
    assert!(Path::new(VECTORS).join("README.md").exists());
}

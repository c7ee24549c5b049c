//! The fixed core against float64 on the accuracy corpus (`corpus.rs`), at
//! the SPEC defaults s = 1/255, λ = 1e-4 and at s = 1/1024, λ = 1e-6,
//! with the hard bounds, per pair:
//! - `v_c` per component within max(1e-4·max|v_c|, 2⁻¹⁴) px everywhere;
//! - `v_d` per component within 1e-3·max|v_d| at ≥ 99.9 % of pixels and
//!   within 1e-2·max|v_d| everywhere, both floored at 2⁻¹⁶ (where the float
//!   field is rounding residue, e.g. the 1×1 vector's |v_d| = 4.9e-14 that
//!   is 0 in exact arithmetic, no fixed-point value is relatively close);
//! - representation bytes, per-frame min–max and Fixed(k_d = 8, k_c = 32):
//!   within ±1 everywhere and identical at ≥ 99 % of pixels.
//!
//! The reference is the host's float64 reference (`reference::compute`,
//! `representation`), except for the shared vectors at the SPEC defaults,
//! where it is what the independent implementation stored (fields and
//! PNGs).
//!
//! `cargo test -p reynoldsflow-tests --test accuracy -- --nocapture` prints,
//! per family, every pair's figures, then the summary table that
//! docs/accuracy.md's "## Accuracy (measured)" carries (the README's
//! "README" below). The test holds the guide to it: every
//! README row must be a measured row and back, and each figure `f` in it
//! must match the measured `m` by this rule:
//! - error fractions and byte max differences: `m ∈ [f/2, 2f]`, and `m = 0`
//!   when `f = 0`;
//! - "% identical": the percentages of *differing* pixels, `100 − f` and
//!   `100 − m`, within 2× of each other the same way (so 100 demands 0);
//! - pair counts: equal.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};

use reynoldsflow_core::fixed::types::{U16F16, U32F32};
use reynoldsflow_core::{IntensityScale, Params, Scaling};
use reynoldsflow_host::internals::compute_fixed;
use reynoldsflow_host::reference::{self, FloatFlow, FloatParams, FloatScaling};
use reynoldsflow_tests::corpus::{Case, Family, corpus};
use reynoldsflow_tests::{ByteDiff, FieldError, byte_diff};

/// The command that prints the README's table (the README must name it).
const COMMAND: &str = "cargo test -p reynoldsflow-tests --test accuracy -- --nocapture";
const README_HEADING: &str = "## Accuracy (measured)";

/// Fixed(k) gains of the representation comparison.
const K_D: f64 = 8.0;
const K_C: f64 = 32.0;

/// One parameter set, for the core and for the float reference.
struct ParamSet {
    label: &'static str,
    fixed: Params,
    float: FloatParams,
}

fn param_sets() -> [ParamSet; 2] {
    [
        ParamSet {
            label: "s = 1/255, λ = 1e-4",
            fixed: Params::DEFAULT,
            float: FloatParams::default(),
        },
        ParamSet {
            label: "s = 1/1024, λ = 1e-6",
            fixed: Params {
                scale: IntensityScale::new(1, 1024).expect("1/1024 is admissible"),
                lambda: U32F32::from_num(1e-6),
            },
            float: FloatParams {
                intensity_scale: 1.0 / 1024.0,
                lambda: 1e-6,
            },
        },
    ]
}

fn vc_tolerance(max: f64) -> f64 {
    (1e-4 * max).max(2f64.powi(-14))
}

fn vd_p999_tolerance(max: f64) -> f64 {
    (1e-3 * max).max(2f64.powi(-16))
}

fn vd_max_tolerance(max: f64) -> f64 {
    (1e-2 * max).max(2f64.powi(-16))
}

/// One pair at one parameter set: errors as fractions of their tolerances
/// (≤ 1 passes) and the byte comparisons.
struct PairResult {
    family: Family,
    name: String,
    size: (usize, usize),
    set: usize,
    max_vc: f64,
    max_vd: f64,
    vc: f64,
    vd_p999: f64,
    vd_max: f64,
    minmax: ByteDiff,
    fixed: ByteDiff,
}

impl PairResult {
    /// Which hard bounds this pair breaks.
    fn failures(&self) -> Vec<String> {
        let mut out = Vec::new();
        let what = format!("{} / {}", self.name, param_sets()[self.set].label);
        for (figure, value) in [
            ("v_c max", self.vc),
            ("v_d p99.9", self.vd_p999),
            ("v_d max", self.vd_max),
        ] {
            if value > 1.0 {
                out.push(format!("{what}: {figure} is {value:.3} of its tolerance"));
            }
        }
        for (mode, diff) in [("min–max", self.minmax), ("Fixed(8, 32)", self.fixed)] {
            if diff.max > 1 || diff.differing_pixels * 100 > diff.pixels {
                out.push(format!(
                    "{what}: {mode} bytes differ by up to {} at {} of {} pixels",
                    diff.max, diff.differing_pixels, diff.pixels
                ));
            }
        }
        out
    }
}

/// The float64 side of a comparison: fields and both representations.
fn reference(case: &Case, set: &ParamSet, spec_default: bool) -> (FloatFlow, Vec<u8>, Vec<u8>) {
    if let (Some(stored), true) = (&case.stored, spec_default) {
        let flow = stored.flow.clone();
        return (flow, stored.rep_minmax.clone(), stored.rep_fixed.clone());
    }
    let flow = reference::compute(&case.prev, &case.next, &set.float).expect("valid pair");
    let minmax = reference::representation(&flow, &case.prev, FloatScaling::PerFrameMinMax);
    let fixed = FloatScaling::Fixed { k_d: K_D, k_c: K_C };
    let fixed = reference::representation(&flow, &case.prev, fixed);
    (flow, minmax, fixed)
}

fn measure(case: &Case, set_index: usize) -> PairResult {
    let set = &param_sets()[set_index];
    let (flow, ref_minmax, ref_fixed) = reference(case, set, set_index == 0);
    let run = |scaling| {
        compute_fixed(&case.prev, &case.next, set.fixed, None, scaling).expect("core accepts")
    };
    let minmax = run(Scaling::PerFrameMinMax);
    let fixed = run(Scaling::Fixed {
        k_d: U16F16::from_num(K_D),
        k_c: U16F16::from_num(K_C),
    });
    // The fields do not depend on the scaling mode.
    assert_eq!(
        minmax.planes, fixed.planes,
        "{}: fields vary with the scaling",
        case.name
    );
    let p = &minmax.planes;
    let vc = FieldError::measure(&p.v_c.u, &p.v_c.v, &flow.v_c.u, &flow.v_c.v);
    let vd = FieldError::measure(&p.v_d.u, &p.v_d.v, &flow.v_d.u, &flow.v_d.v);
    PairResult {
        family: case.family,
        name: case.name.clone(),
        size: case.prev.size(),
        set: set_index,
        max_vc: vc.max_ref,
        max_vd: vd.max_ref,
        vc: vc.max_err / vc_tolerance(vc.max_ref),
        vd_p999: vd.p999_err / vd_p999_tolerance(vd.max_ref),
        vd_max: vd.max_err / vd_max_tolerance(vd.max_ref),
        minmax: byte_diff(&minmax.rep, &ref_minmax),
        fixed: byte_diff(&fixed.rep, &ref_fixed),
    }
}

/// Every pair of the corpus at both parameter sets, measured once per test
/// binary (both tests read it), pairs spread over the available cores.
fn results() -> &'static [PairResult] {
    static RESULTS: OnceLock<Vec<PairResult>> = OnceLock::new();
    RESULTS.get_or_init(|| {
        let cases = corpus();
        let jobs: Vec<(usize, usize)> = (0..cases.len())
            .flat_map(|c| (0..param_sets().len()).map(move |s| (c, s)))
            .collect();
        let next = AtomicUsize::new(0);
        let workers = std::thread::available_parallelism().map_or(1, |n| n.get());
        let mut done: Vec<(usize, PairResult)> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..workers)
                .map(|_| {
                    scope.spawn(|| {
                        let mut mine = Vec::new();
                        loop {
                            let i = next.fetch_add(1, Ordering::Relaxed);
                            let Some(&(c, s)) = jobs.get(i) else { break };
                            mine.push((i, measure(&cases[c], s)));
                        }
                        mine
                    })
                })
                .collect();
            handles
                .into_iter()
                .flat_map(|h| h.join().expect("a measurement panicked"))
                .collect()
        });
        done.sort_by_key(|(i, _)| *i);
        let results: Vec<PairResult> = done.into_iter().map(|(_, r)| r).collect();
        print_pairs(&results);
        println!("\n{}", summary_table(&summarise(&results)));
        results
    })
}

/// An error fraction as the tables print it: two significant digits.
fn fraction(x: f64) -> String {
    match x {
        0.0 => "0".into(),
        x => format!("{x:.1e}"),
    }
}

/// Percentage of identical pixels from the percentage that differ, with
/// enough decimals to give the differing part two significant digits.
fn identical(differing_pct: f64) -> String {
    if differing_pct == 0.0 {
        return "100".into();
    }
    let decimals = (1 - differing_pct.log10().floor() as i32).max(1) as usize;
    format!("{:.decimals$}", 100.0 - differing_pct)
}

fn differing_pct(d: ByteDiff) -> f64 {
    100.0 * d.differing_pixels as f64 / d.pixels.max(1) as f64
}

fn print_pairs(results: &[PairResult]) {
    for family in Family::ALL {
        println!(
            "\n{} (errors as fractions of their tolerances)",
            family.name()
        );
        println!(
            "{:<44} {:>7} {:<20} {:>8} {:>8} {:>8} {:>8} {:>8}  {:>12}  {:>12}",
            "pair",
            "size",
            "parameters",
            "max|v_c|",
            "max|v_d|",
            "v_c max",
            "v_d p999",
            "v_d max",
            "min–max: ± %=",
            "Fixed: ± %="
        );
        for r in results.iter().filter(|r| r.family == family) {
            println!(
                "{:<44} {:>7} {:<20} {:>8.2e} {:>8.2e} {:>8} {:>8} {:>8}  {:>3} {:>8}  {:>3} {:>8}",
                r.name,
                format!("{}×{}", r.size.0, r.size.1),
                param_sets()[r.set].label,
                r.max_vc,
                r.max_vd,
                fraction(r.vc),
                fraction(r.vd_p999),
                fraction(r.vd_max),
                r.minmax.max,
                identical(differing_pct(r.minmax)),
                r.fixed.max,
                identical(differing_pct(r.fixed)),
            );
        }
    }
}

/// The worst over one family's pairs at one parameter set.
#[derive(Default)]
struct Row {
    pairs: usize,
    vc: f64,
    vd_p999: f64,
    vd_max: f64,
    minmax_max: u8,
    minmax_differing: f64,
    fixed_max: u8,
    fixed_differing: f64,
}

impl Row {
    fn add(&mut self, r: &PairResult) {
        self.pairs += 1;
        self.vc = self.vc.max(r.vc);
        self.vd_p999 = self.vd_p999.max(r.vd_p999);
        self.vd_max = self.vd_max.max(r.vd_max);
        self.minmax_max = self.minmax_max.max(r.minmax.max);
        self.minmax_differing = self.minmax_differing.max(differing_pct(r.minmax));
        self.fixed_max = self.fixed_max.max(r.fixed.max);
        self.fixed_differing = self.fixed_differing.max(differing_pct(r.fixed));
    }
}

/// How a README figure is held to its measured value (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Figure {
    /// Counted exactly.
    Count(f64),
    /// Within 2×, 0 only for 0.
    Within2x(f64),
    /// A byte difference: printed as an integer, held within 2× likewise.
    MaxDiff(u8),
    /// A "% identical": the differing part within 2×.
    Identical(f64),
}

impl Figure {
    fn cell(self) -> String {
        match self {
            Figure::Count(n) => format!("{n}"),
            Figure::Within2x(x) => fraction(x),
            Figure::MaxDiff(n) => format!("{n}"),
            Figure::Identical(differing) => identical(differing),
        }
    }

    /// Does `printed` (a README cell) state this measured figure?
    fn matches(self, printed: &str) -> bool {
        let Ok(f) = printed.trim().parse::<f64>() else {
            return false;
        };
        // (1 ± 1e-9: `100 − f` of a printed percentage is not exact in f64.)
        let within_2x = |measured: f64, figure: f64| match figure {
            0.0 => measured == 0.0,
            f if f > 0.0 => {
                measured >= f / 2.0 * (1.0 - 1e-9) && measured <= 2.0 * f * (1.0 + 1e-9)
            }
            _ => false,
        };
        match self {
            Figure::Count(n) => n == f,
            Figure::Within2x(m) => within_2x(m, f),
            Figure::MaxDiff(n) => within_2x(f64::from(n), f),
            Figure::Identical(differing) => within_2x(differing, 100.0 - f),
        }
    }
}

const COLUMNS: [&str; 10] = [
    "family",
    "parameters",
    "pairs",
    "v_c max",
    "v_d p99.9",
    "v_d max",
    "min–max bytes: max diff",
    "min–max: % identical",
    "Fixed(8, 32) bytes: max diff",
    "Fixed(8, 32): % identical",
];

/// One summary row: its key (family, parameters) and its figures.
struct Summary {
    family: &'static str,
    params: &'static str,
    figures: [Figure; 8],
}

fn summarise(results: &[PairResult]) -> Vec<Summary> {
    let mut out = Vec::new();
    for family in Family::ALL {
        for (s, set) in param_sets().iter().enumerate() {
            let mut row = Row::default();
            results
                .iter()
                .filter(|r| r.family == family && r.set == s)
                .for_each(|r| row.add(r));
            out.push(Summary {
                family: family.name(),
                params: set.label,
                figures: [
                    Figure::Count(row.pairs as f64),
                    Figure::Within2x(row.vc),
                    Figure::Within2x(row.vd_p999),
                    Figure::Within2x(row.vd_max),
                    Figure::MaxDiff(row.minmax_max),
                    Figure::Identical(row.minmax_differing),
                    Figure::MaxDiff(row.fixed_max),
                    Figure::Identical(row.fixed_differing),
                ],
            });
        }
    }
    out
}

/// The summary as the README's markdown table.
fn summary_table(rows: &[Summary]) -> String {
    let line = |cells: Vec<String>| format!("| {} |", cells.join(" | "));
    let mut out = vec![
        line(COLUMNS.iter().map(|c| c.to_string()).collect()),
        line(
            vec!["---".into(); 2]
                .into_iter()
                .chain(vec!["---:".into(); 8])
                .collect(),
        ),
    ];
    for row in rows {
        let mut cells = vec![row.family.to_string(), row.params.to_string()];
        cells.extend(row.figures.iter().map(|f| f.cell()));
        out.push(line(cells));
    }
    out.join("\n")
}

/// The README's accuracy section: its text and its table's rows as cells
/// (header and separator dropped).
fn readme_table() -> (String, Vec<Vec<String>>) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/accuracy.md");
    let readme = std::fs::read_to_string(path).expect("docs/accuracy.md");
    let start = readme
        .find(README_HEADING)
        .unwrap_or_else(|| panic!("docs/accuracy.md has no {README_HEADING:?} section"));
    let body = &readme[start + README_HEADING.len()..];
    let section = &body[..body.find("\n## ").unwrap_or(body.len())];
    let rows = section
        .lines()
        .filter(|l| l.trim_start().starts_with('|'))
        .skip(2)
        .map(|l| {
            let l = l.trim().trim_start_matches('|').trim_end_matches('|');
            l.split('|').map(|c| c.trim().to_string()).collect()
        })
        .collect();
    (section.to_string(), rows)
}

#[test]
fn every_pair_is_within_the_tolerances() {
    let results = results();
    // Every family is populated at both parameter sets.
    for family in Family::ALL {
        let n = results.iter().filter(|r| r.family == family).count();
        assert!(n >= 2 * 4, "{}: only {n} measurements", family.name());
    }
    let failures: Vec<String> = results.iter().flat_map(PairResult::failures).collect();
    assert!(
        failures.is_empty(),
        "{} failure(s):\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn the_readme_table_is_what_the_corpus_measures() {
    let (section, rows) = readme_table();
    assert!(
        section.contains(COMMAND),
        "README's accuracy section must name the command that prints its table: {COMMAND}"
    );
    let measured = summarise(results());
    let mut problems = Vec::new();
    for row in &rows {
        if row.len() != COLUMNS.len() {
            problems.push(format!(
                "README row of {} cells, not {}: {row:?}",
                row.len(),
                COLUMNS.len()
            ));
            continue;
        }
        let Some(m) = measured
            .iter()
            .find(|m| m.family == row[0] && m.params == row[1])
        else {
            problems.push(format!(
                "README row {:?} / {:?} is not measured",
                row[0], row[1]
            ));
            continue;
        };
        for (k, figure) in m.figures.iter().enumerate() {
            let printed = &row[k + 2];
            if !figure.matches(printed) {
                problems.push(format!(
                    "{} / {} / {}: README says {printed}, measured {}",
                    row[0],
                    row[1],
                    COLUMNS[k + 2],
                    figure.cell()
                ));
            }
        }
    }
    for m in &measured {
        if !rows
            .iter()
            .any(|r| r.len() > 1 && r[0] == m.family && r[1] == m.params)
        {
            problems.push(format!("README lacks the row {} / {}", m.family, m.params));
        }
    }
    assert!(
        problems.is_empty(),
        "README's accuracy table is stale ({COMMAND} prints the current one):\n{}",
        problems.join("\n")
    );
}

#[test]
fn figures_hold_within_2x_and_no_further() {
    let m = Figure::Within2x(0.004);
    assert!(m.matches("4.0e-3") && m.matches("2.0e-3") && m.matches("8.0e-3"));
    assert!(!m.matches("1.9e-3") && !m.matches("8.1e-3") && !m.matches("0") && !m.matches("x"));
    assert!(Figure::Within2x(0.0).matches("0") && !Figure::Within2x(1e-9).matches("0"));
    // 99.90 % identical: 0.1 % differ; 0.05–0.2 % measured match it.
    assert!(Figure::Identical(0.05).matches("99.90") && Figure::Identical(0.2).matches("99.90"));
    assert!(!Figure::Identical(0.21).matches("99.90") && !Figure::Identical(0.01).matches("100"));
    assert!(Figure::Identical(0.0).matches("100") && Figure::Count(7.0).matches("7"));
    assert!(!Figure::Count(7.0).matches("8"));
    assert!(Figure::MaxDiff(1).matches("1") && !Figure::MaxDiff(1).matches("0"));
    // What the tables print round-trips through the rule.
    for x in [0.0, 1.234e-7, 0.5, 0.99, 1.0] {
        let f = Figure::Within2x(x);
        assert!(f.matches(&f.cell()), "{x}");
        let i = Figure::Identical(x);
        assert!(i.matches(&i.cell()), "{x}: {}", i.cell());
    }
}

#[test]
fn a_pair_past_any_bound_is_a_failure() {
    let at = |vc, vd_p999, vd_max, max, differing| PairResult {
        family: Family::TinyMotions,
        name: "synthetic".into(),
        size: (10, 10),
        set: 0,
        max_vc: 1.0,
        max_vd: 1.0,
        vc,
        vd_p999,
        vd_max,
        minmax: ByteDiff {
            max,
            differing_pixels: differing,
            pixels: 100,
        },
        fixed: ByteDiff {
            max: 0,
            differing_pixels: 0,
            pixels: 100,
        },
    };
    assert!(at(1.0, 1.0, 1.0, 1, 1).failures().is_empty());
    for broken in [
        at(1.01, 0.0, 0.0, 0, 0),
        at(0.0, 1.01, 0.0, 0, 0),
        at(0.0, 0.0, 1.01, 0, 0),
        at(0.0, 0.0, 0.0, 2, 1),
        at(0.0, 0.0, 0.0, 1, 2),
    ] {
        assert_eq!(broken.failures().len(), 1);
    }
}

//! What the figures show: the paper's temporal magnitude curves, error
//! against motion magnitude, and direction agreement over time, built from
//! the results as [`Figure`]s.

use super::plots::{Figure, PALETTE, Panel, Series};
use super::protocol::{EvalConfig, Method, SequenceResult};
use super::report::find;
use super::scenes::{Pattern, Scenario};

/// Colour of a method's curves.
fn color(m: Method) -> plotters::style::RGBColor {
    let i = Method::ALL.iter().position(|&k| k == m).unwrap_or(0);
    PALETTE[i % PALETTE.len()]
}

/// Title of a scenario's panel: its name and the level `r` was run at.
fn level_title(scenario: Scenario, r: &SequenceResult) -> String {
    format!(
        "{} ({})",
        scenario.name(),
        scenario.level_label(r.spec.level)
    )
}

/// Methods on the comparison plots: the fixed core is left out, its curve
/// lies on the float reference's (the report gives the largest gap).
const PLOTTED: [Method; 6] = [
    Method::HornSchunck,
    Method::LucasKanade,
    Method::RfVr,
    Method::RfVd,
    Method::RfVc,
    Method::RfVrSmallScale,
];

/// One solid curve per method of [`PLOTTED`], through `points(method)`.
fn plotted_series(points: impl Fn(Method) -> Vec<(f64, f64)>) -> Vec<Series> {
    PLOTTED
        .into_iter()
        .map(|m| Series {
            label: m.label().to_owned(),
            color: color(m),
            points: points(m),
            dashed: false,
        })
        .collect()
}

/// Mean |v_c| and |v_d| over the interior, frame by frame, per scenario
/// (the paper's bottom-row figure), with the true mean displacement.
pub fn temporal_magnitudes(
    results: &[SequenceResult],
    config: &EvalConfig,
    pattern: Pattern,
) -> Figure {
    let panels = Scenario::ALL
        .into_iter()
        .filter_map(|scenario| {
            let r = find(results, pattern, scenario, config.reference_level, false)?;
            let curve = |label: &str, color, dashed, f: &dyn Fn(usize) -> f64| Series {
                label: label.to_owned(),
                color,
                points: r
                    .pairs
                    .iter()
                    .map(|p| (p.frame as f64, f(p.frame)))
                    .collect(),
                dashed,
            };
            let at = |n: usize| &r.pairs[n];
            Some(Panel {
                title: level_title(scenario, r),
                x_label: "frame n (pair n → n+1)".to_owned(),
                y_label: "mean magnitude".to_owned(),
                log_y: false,
                series: vec![
                    curve("mean |v_c|", color(Method::RfVc), false, &|n| at(n).mean_vc),
                    curve("mean |v_d|", color(Method::RfVd), false, &|n| at(n).mean_vd),
                    curve("true mean |u| (px)", PALETTE[5], true, &|n| {
                        at(n).mean_truth
                    }),
                ],
            })
        })
        .collect();
    Figure {
        title: format!(
            "ReynoldsFlow temporal mean magnitudes, {} (SPEC defaults, interior, clean)",
            pattern.name()
        ),
        grid: (2, 3),
        panels,
        size: (1500, 900),
    }
}

/// Dense AEPE against the scenario's magnitude, per method (log scale).
pub fn aepe_vs_magnitude(
    results: &[SequenceResult],
    config: &EvalConfig,
    pattern: Pattern,
) -> Figure {
    let panels = Scenario::ALL
        .into_iter()
        .map(|scenario| Panel {
            title: scenario.name().to_owned(),
            x_label: scenario.level_unit().to_owned(),
            y_label: if scenario.moves() {
                "dense AEPE (px)".to_owned()
            } else {
                "spurious flow (px)".to_owned()
            },
            log_y: true,
            series: plotted_series(|m| {
                config
                    .levels
                    .iter()
                    .filter_map(|&li| {
                        let r = find(results, pattern, scenario, li, false)?;
                        let x = scenario.level_axis_value(r.spec.level);
                        Some((x, r.mean(m, |x| Some(x.aepe))?))
                    })
                    .collect()
            }),
        })
        .collect();
    Figure {
        title: format!(
            "Endpoint error against motion magnitude, {} (clean; RF v_R fixed = RF v_R)",
            pattern.name()
        ),
        grid: (2, 3),
        panels,
        size: (1500, 900),
    }
}

/// Sparse ACS frame by frame on the moving scenarios, per method.
pub fn acs_over_time(results: &[SequenceResult], config: &EvalConfig, pattern: Pattern) -> Figure {
    let panels = Scenario::ALL
        .into_iter()
        .filter(|s| s.moves())
        .filter_map(|scenario| {
            let r = find(results, pattern, scenario, config.reference_level, false)?;
            Some(Panel {
                title: level_title(scenario, r),
                x_label: "frame n".to_owned(),
                y_label: "ACS_sp".to_owned(),
                log_y: false,
                series: plotted_series(|m| {
                    r.pairs
                        .iter()
                        .filter_map(|p| {
                            let (_, x) = p.measures.iter().find(|(k, _)| *k == m)?;
                            Some((p.frame as f64, x.acs_sp?))
                        })
                        .collect()
                }),
            })
        })
        .collect();
    Figure {
        title: format!(
            "Angular cosine similarity at the sparse points over time, {} (clean)",
            pattern.name()
        ),
        grid: (2, 2),
        panels,
        size: (1300, 900),
    }
}

//! Evaluation against exact ground truth: the paper's controlled tests
//! (zoom in and out, rotation, translation, illumination) rendered
//! analytically, ReynoldsFlow's fields against Horn–Schunck and
//! Lucas–Kanade, measured by AEPE, AAE, radial correlation and angular
//! cosine similarity, with plots and a markdown report.
//!
//! One concept per module: [`scenes`] (patterns, scenarios, the camera),
//! [`truth`] (poses, the analytic flow, where the measures are taken),
//! [`baselines`], [`metrics`], [`protocol`] (what runs on which pair),
//! [`plots`] (drawing), [`figures`] (what is drawn) and [`report`].
//!
//! ```no_run
//! use reynoldsflow_eval::protocol::EvalConfig;
//! # fn main() -> Result<(), reynoldsflow_host::HostError> {
//! let summary = reynoldsflow_eval::run(&EvalConfig::quick(), std::path::Path::new("eval-out"))?;
//! println!("{} files", summary.files.len());
//! # Ok(()) }
//! ```

use std::io;
use std::path::Path;
use std::time::{Duration, Instant};

pub mod baselines;
pub mod field;
pub mod figures;
pub mod metrics;
pub mod plots;
pub mod protocol;
pub mod report;
pub mod scenes;
pub mod truth;

use protocol::{EvalConfig, SequenceResult};
use reynoldsflow_host::{HostError, io::atomic, io::image_file};
use scenes::{Pattern, Scenario};

/// What [`run`] wrote.
#[derive(Clone, Debug)]
pub struct Summary {
    /// File names written into the output directory.
    pub files: Vec<String>,
    /// Time to render and evaluate every sequence.
    pub compute: Duration,
    /// Time to draw and write the outputs.
    pub output: Duration,
}

/// Run the evaluation of `config` and write `report.md`, `results.csv`,
/// the figures and a few illustrations into `out` (created if missing; all
/// files are staged and renamed together, so a failure leaves `out` as it
/// was).
pub fn run(config: &EvalConfig, out: &Path) -> Result<Summary, HostError> {
    let start = Instant::now();
    let results = protocol::run_all(config)?;
    let compute = start.elapsed();
    let output_start = Instant::now();
    let files = outputs(config, &results, compute, out)?;
    let refs: Vec<(&str, &[u8])> = files
        .iter()
        .map(|(n, b)| (n.as_str(), b.as_slice()))
        .collect();
    atomic::write_files(out, &refs)?;
    Ok(Summary {
        files: files.into_iter().map(|(n, _)| n).collect(),
        compute,
        output: output_start.elapsed(),
    })
}

/// Every output file, named, as bytes.
fn outputs(
    config: &EvalConfig,
    results: &[SequenceResult],
    elapsed: Duration,
    out: &Path,
) -> Result<Vec<(String, Vec<u8>)>, HostError> {
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    let mut figures: Vec<(String, String)> = Vec::new();
    for pattern in Pattern::ALL {
        let p = pattern.name();
        let list = [
            (
                format!("temporal_magnitudes_{p}.png"),
                format!("Temporal mean |v_c| and |v_d| per scenario, {p}"),
                figures::temporal_magnitudes(results, config, pattern),
            ),
            (
                format!("aepe_vs_magnitude_{p}.png"),
                format!("Dense AEPE against motion magnitude per method, {p}"),
                figures::aepe_vs_magnitude(results, config, pattern),
            ),
            (
                format!("acs_over_time_{p}.png"),
                format!("Sparse ACS over time per method, {p}"),
                figures::acs_over_time(results, config, pattern),
            ),
        ];
        for (name, caption, figure) in list {
            let png = figure
                .to_png()
                .map_err(|e| HostError::io(out.join(&name), io::Error::other(e)))?;
            files.push((name.clone(), png));
            figures.push((name, caption));
        }
    }
    let mut images = Vec::new();
    for r in results
        .iter()
        .filter(|r| r.spec.scenario == Scenario::ZoomIn)
    {
        let Some(preview) = &r.preview else { continue };
        let p = r.spec.pattern.name();
        let (w, h) = preview.frame.size();
        let gray_rgb: Vec<u8> = preview
            .frame
            .pixels
            .iter()
            .flat_map(|&g| [g, g, g])
            .collect();
        let name = format!("frame_{p}.png");
        files.push((name.clone(), image_file::encode_png(w, h, &gray_rgb)?));
        images.push((name, format!("frame 0 of the {p} zoom-in sequence")));
        let name = format!("representation_{p}.png");
        files.push((
            name.clone(),
            image_file::encode_png(w, h, &preview.representation)?,
        ));
        images.push((
            name,
            format!(
                "ReynoldsFlow's representation [|v_d|, |v_c|, f] of the {p} zoom-in \
                 sequence's first pair (per-frame min-max)"
            ),
        ));
    }
    let ctx = report::ReportContext {
        config,
        elapsed,
        figures: &figures,
        images: &images,
    };
    files.push((
        "report.md".to_owned(),
        report::markdown(results, &ctx).into_bytes(),
    ));
    files.push(("results.csv".to_owned(), report::csv(results).into_bytes()));
    Ok(files)
}

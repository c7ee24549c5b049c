//! `reynoldsflow eval`: the controlled-scene evaluation against exact
//! ground truth (see [`reynoldsflow_eval`]), written as a markdown report, a CSV
//! and PNG figures.

use std::path::PathBuf;

use reynoldsflow_eval::{self as eval, protocol::EvalConfig};
use reynoldsflow_host::HostError;

/// Examples shown under `reynoldsflow eval --help`.
pub const EXAMPLES: &str = "\
Examples:
  reynoldsflow eval --out eval/
      every scene, level and method at 320x240; eval/report.md links the plots";

/// Arguments of `reynoldsflow eval`.
#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// Output directory (created if missing) for report.md, results.csv
    /// and the PNG figures.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// A reduced run (96x72, 3 frames, two levels) for tests.
    #[arg(long, hide = true)]
    pub quick: bool,
}

/// Run the subcommand.
pub fn run(args: &EvalArgs) -> Result<(), HostError> {
    let config = if args.quick {
        EvalConfig::quick()
    } else {
        EvalConfig::full()
    };
    let summary = eval::run(&config, &args.out)?;
    println!(
        "reynoldsflow eval: {} files in {} (evaluation {:.1} s, figures and report {:.1} s); see {}",
        summary.files.len(),
        args.out.display(),
        summary.compute.as_secs_f64(),
        summary.output.as_secs_f64(),
        args.out.join("report.md").display()
    );
    Ok(())
}

//! The `reynoldsflow` command line over `reynoldsflow-host`: one module per
//! subcommand; the flags' names for the library's settings in [`values`]. Errors print as one line,
//! `reynoldsflow: error: <what>: <problem>`; exit status 1 for a failed
//! run, 2 for a malformed command line.

use std::ffi::OsString;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub mod budget;
pub mod captured;
pub mod compare;
pub mod dataset;
pub mod eval;
pub mod limits;
pub mod pair;
mod progress;
pub mod run;
pub mod scheduler;
pub mod shards;
pub mod values;
pub mod verify;
pub mod webdataset;

const EXAMPLES: &str = "\
Examples:
  reynoldsflow run --out demo/
      the built-in moving scene: demo/000000.png ...
  reynoldsflow run clip.mp4 --out reps/ --keep-count
      one representation per frame of a video, named after the frame
  reynoldsflow dataset videos/ reps/
      a whole tree of videos and frame folders, resumable
  reynoldsflow pair f0.pgm f1.pgm --out out/
      fixed-point core, per-frame min-max bytes: out/{vcx,vcy,vdx,vdy}.npy, out/rep.png
  reynoldsflow budget --width 640 --height 480 --tile 80x480
      working memory and halo overhead of an engine for that tiling
  reynoldsflow eval --out eval/
      controlled scenes with exact ground truth, baselines, plots
  reynoldsflow verify clip.y4m device.rgb --scale fixed:8,32
      firmware CI: a device's output against run's, same input and flags; exit 0 only if identical";

/// The examples of `pair`.
const PAIR_EXAMPLES: &str = "\
Examples:
  reynoldsflow pair f0.pgm f1.pgm --out out/
      fixed-point core, per-frame min-max bytes: out/{vcx,vcy,vdx,vdy}.npy, out/rep.png
  reynoldsflow pair a.png b.png --out ref/ --engine float --scale fixed:8,32
      float64 reference, constant gains 8 (|v_d|) and 32 (|v_c|)";

/// ReynoldsFlow: curl-free and divergence-free motion fields of frame
/// pairs, and their RGB representation [|v_d|, |v_c|, frame n].
#[derive(Debug, Parser)]
#[command(name = "reynoldsflow", version, after_help = EXAMPLES)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Fields and representation of one frame pair.
    #[command(after_help = PAIR_EXAMPLES)]
    Pair(pair::PairArgs),
    /// Working memory and halo overhead of a tiling (for firmware budgets).
    Budget(budget::BudgetArgs),
    /// Every consecutive frame pair of a video, frame folder or stream, one
    /// output per pair (the built-in demo sequence when INPUT is omitted).
    #[command(after_help = run::EXAMPLES)]
    Run(run::RunArgs),
    /// Mirror a tree of videos and frame folders into folders of outputs,
    /// on all cores; rerun to resume.
    #[command(after_help = dataset::EXAMPLES)]
    Dataset(dataset::DatasetArgs),
    /// Controlled scenes with exact ground truth: ReynoldsFlow against
    /// Horn-Schunck and Lucas-Kanade; a markdown report with plots.
    #[command(after_help = eval::EXAMPLES)]
    Eval(eval::EvalArgs),
    /// A device's output against the representation recomputed from the
    /// same input with the same flags (firmware CI).
    ///
    /// The capture is raw RGB24, Y4M or a folder of PNGs, as run writes
    /// them; exit 0 only when identical (or within --tolerance).
    #[command(after_help = verify::EXAMPLES)]
    Verify(verify::VerifyArgs),
}

/// Parse `args` (program name first), run, and report.
pub fn run<I, T>(args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => return usage_error(&e),
    };
    // The checks of flags beyond clap's: a bad command line (2).
    let checked = match &cli.command {
        Command::Run(args) => args.output.check_types(args.out.as_os_str() == "-"),
        Command::Dataset(args) => dataset::check(args),
        _ => Ok(()),
    };
    if let Err(e) = checked {
        return bad_command_line(&values::message(&e));
    }
    let result = match &cli.command {
        Command::Pair(args) => pair::run(args),
        Command::Budget(args) => budget::run(args),
        Command::Run(args) => run::run(args),
        Command::Dataset(args) => dataset::run(args),
        Command::Eval(args) => eval::run(args),
        // Flag values refused before comparing are a bad command line (2), not a failed check (1).
        Command::Verify(args) => match verify::prepare(args) {
            Ok(plan) => verify::run(&plan),
            Err(e) => return bad_command_line(&values::message(&e)),
        },
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("reynoldsflow: error: {}", values::message(&e));
            ExitCode::FAILURE
        }
    }
}

/// Help and version go out as clap renders them; a malformed command line
/// becomes one line (clap's message without its usage block).
fn usage_error(e: &clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    match e.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            // Nothing useful to do if stdout is gone.
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        // No subcommand: the help is the message (on stderr).
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            let _ = e.print();
            return ExitCode::from(2);
        }
        _ => {}
    }
    let rendered = e.render().to_string();
    let parts: Vec<&str> = rendered
        .lines()
        .map(str::trim)
        .filter(|l| {
            !l.is_empty() && !l.starts_with("Usage:") && !l.starts_with("For more information")
        })
        .collect();
    let message = parts.join(" ");
    bad_command_line(message.strip_prefix("error: ").unwrap_or(&message))
}

/// A malformed command line: one line, exit status 2.
fn bad_command_line(message: &str) -> ExitCode {
    eprintln!("reynoldsflow: error: {message} (see --help)");
    ExitCode::from(2)
}

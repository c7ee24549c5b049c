//! `--max-pixels`: the input size limit of [`reynoldsflow_host::limits`], as a flag of
//! every subcommand that reads frames.

use reynoldsflow_host::limits::{self, Limits};

/// The input limits (shared by `pair`, `run` and `dataset`).
#[derive(Debug, clap::Args)]
#[command(next_help_heading = "Input limits")]
pub struct LimitArgs {
    /// Refuse frames of more than N pixels (width x height) as soon as a
    /// header states the size, before reading them, so a corrupt header
    /// cannot make the tool allocate gigabytes. The default is 8192x8192.
    #[arg(long, value_name = "N", default_value_t = limits::DEFAULT_MAX_PIXELS,
          value_parser = clap::value_parser!(u64).range(1..))]
    pub max_pixels: u64,
}

impl LimitArgs {
    /// The limits every input of the command is read within.
    pub fn limits(&self) -> Limits {
        Limits::new(self.max_pixels)
    }
}

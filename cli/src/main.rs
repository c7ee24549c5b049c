//! The `reynoldsflow` command: see `reynoldsflow --help` and
//! `reynoldsflow_cli`.

fn main() -> std::process::ExitCode {
    reynoldsflow_cli::run(std::env::args_os())
}

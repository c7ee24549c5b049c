//! The `reynoldsflow` command: see `reynoldsflow --help` and
//! `reynoldsflow_host::cli`.

fn main() -> std::process::ExitCode {
    reynoldsflow_host::cli::run(std::env::args_os())
}

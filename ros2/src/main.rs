//! `reynoldsflow-ros2`: see the library's documentation and `--help`.

use std::process::ExitCode;

use clap::Parser;
use reynoldsflow_ros2::args::Args;
use reynoldsflow_ros2::node;

fn main() -> ExitCode {
    let args = Args::parse();
    match node::run(&args) {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("reynoldsflow-ros2: {e}");
            ExitCode::FAILURE
        }
    }
}

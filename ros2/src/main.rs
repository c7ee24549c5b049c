//! `reynoldsflow-ros2`: see the library's documentation and `--help`.

use std::process::ExitCode;

use reynoldsflow_ros2::args::{Args, Exit};
use reynoldsflow_ros2::node;

fn main() -> ExitCode {
    let args = match Args::try_parse_from(std::env::args_os()) {
        Ok(args) => args,
        Err(exit @ (Exit::Help | Exit::Version)) => {
            println!("{exit}");
            return ExitCode::from(exit.code());
        }
        Err(exit) => {
            eprintln!("{exit}");
            return ExitCode::from(exit.code());
        }
    };
    match node::run(&args) {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("reynoldsflow-ros2: {e}");
            ExitCode::FAILURE
        }
    }
}

//! `reynoldsflow-demo`: the drone dashboard as numbered PNG frames
//! (headless), or live in an SDL window with `--features sdl --live`.
//!
//! ```text
//! cargo run --release -p reynoldsflow-demo -- --frames 60 --start 4 --out demo-frames
//! ```

use std::path::PathBuf;
use std::process::ExitCode;

use reynoldsflow_demo::{DemoError, render_sequence};

const USAGE: &str = "usage: reynoldsflow-demo [--frames N] [--start S] [--out DIR] [--live]

  --frames N   frames to render (default 1)
  --start S    first frame (default 30; the drone crosses frames 4 to 73)
  --out DIR    where frame-NNNN.png go (default demo-frames)
  --live       loop the crossing in an SDL window (needs --features sdl)";

struct Args {
    frames: usize,
    start: usize,
    out: PathBuf,
    live: bool,
}

fn parse() -> Result<Args, DemoError> {
    let mut args = Args {
        frames: 1,
        start: 30,
        out: PathBuf::from("demo-frames"),
        live: false,
    };
    let mut it = std::env::args().skip(1);
    let number = |flag: &str, value: Option<String>| -> Result<usize, DemoError> {
        value
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| DemoError::Usage(format!("{flag} needs a number\n\n{USAGE}")))
    };
    while let Some(arg) = it.next() {
        match arg.as_str() {
            "--frames" => args.frames = number("--frames", it.next())?,
            "--start" => args.start = number("--start", it.next())?,
            "--out" => {
                args.out = it.next().map(PathBuf::from).ok_or_else(|| {
                    DemoError::Usage(format!("--out needs a directory\n\n{USAGE}"))
                })?
            }
            "--live" => args.live = true,
            "-h" | "--help" => return Err(DemoError::Usage(USAGE.to_string())),
            other => {
                return Err(DemoError::Usage(format!(
                    "unknown argument {other}\n\n{USAGE}"
                )));
            }
        }
    }
    Ok(args)
}

fn main() -> ExitCode {
    let result = parse().and_then(|args| {
        if args.live {
            return live();
        }
        let reports = render_sequence(args.start, args.frames, &args.out)?;
        for r in &reports {
            let cue = r.regions.first().map_or_else(
                || "no cue".to_string(),
                |c| {
                    format!(
                        "cue 1 at {},{} {}x{}",
                        c.x_min,
                        c.y_min,
                        c.width(),
                        c.height()
                    )
                },
            );
            let path = r
                .path
                .as_deref()
                .map(|p| p.display().to_string())
                .unwrap_or_default();
            println!(
                "{path}: {cue}; drone at {},{}..{},{}",
                r.truth.x_min, r.truth.y_min, r.truth.x_max, r.truth.y_max
            );
        }
        Ok(())
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}

/// The dashboard in a window, looping over the drone's crossing (frames
/// 4 to 73), until the window is closed.
#[cfg(feature = "sdl")]
fn live() -> Result<(), DemoError> {
    use embedded_graphics::pixelcolor::Rgb565;
    use embedded_graphics_simulator::{
        OutputSettingsBuilder, SimulatorDisplay, SimulatorEvent, Window,
    };
    use reynoldsflow_demo::{draw::SCREEN, run_sequence};

    let mut window = Window::new(
        "ReynoldsFlow: find the drone",
        &OutputSettingsBuilder::new().scale(2).build(),
    );
    let mut display = SimulatorDisplay::<Rgb565>::new(SCREEN);
    loop {
        let mut quit = false;
        run_sequence(4, 70, &mut display, |display, _| {
            window.update(display);
            quit |= window.events().any(|e| matches!(e, SimulatorEvent::Quit));
            std::thread::sleep(std::time::Duration::from_millis(80));
            if quit {
                return Err(DemoError::Usage(String::new()));
            }
            Ok(())
        })
        .or_else(|e| if quit { Ok(()) } else { Err(e) })?;
        if quit {
            return Ok(());
        }
    }
}

#[cfg(not(feature = "sdl"))]
fn live() -> Result<(), DemoError> {
    Err(DemoError::Usage(
        "--live needs the `sdl` feature: cargo run -p reynoldsflow-demo --features sdl -- --live"
            .to_string(),
    ))
}

//! `reynoldsflow budget`: the working memory and halo overhead of a tiling,
//! for choosing an engine's `COLS` before writing firmware.

use clap::Args;
use reynoldsflow_core::{HALO, MAX_SIDE, first_stage_pixels, working_bytes};

use reynoldsflow_host::HostError;
use reynoldsflow_host::settings::{self, TileSize};

/// Arguments of `budget`.
#[derive(Debug, Args)]
pub struct BudgetArgs {
    /// Frame width in pixels.
    #[arg(long)]
    pub width: usize,
    /// Frame height in pixels.
    #[arg(long)]
    pub height: usize,
    /// Tile width × height (a tile wider or taller than the frame is the frame).
    #[arg(long, value_name = "TWxTH", value_parser = settings::parse_tile)]
    pub tile: TileSize,
}

/// Print `working_bytes=N overhead=X`: the bytes an `Engine<TW + 14>` owns
/// (everything but the two input frames), and the first stage's pixels per
/// output pixel.
pub fn run(args: &BudgetArgs) -> Result<(), HostError> {
    let (w, h) = (args.width, args.height);
    if !(1..=MAX_SIDE).contains(&w) || !(1..=MAX_SIDE).contains(&h) {
        return Err(HostError::invalid(
            "--width/--height",
            format!("frame sides must be 1..={MAX_SIDE}"),
        ));
    }
    let (tw, th) = (args.tile.width.min(w), args.tile.height.min(h));
    let (computed, output) = first_stage_pixels(w, h, tw, th);
    let overhead = computed as f64 / output as f64;
    println!(
        "working_bytes={} overhead={overhead:.4}",
        working_bytes(tw + 2 * HALO)
    );
    Ok(())
}

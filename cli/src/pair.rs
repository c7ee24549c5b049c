//! `reynoldsflow pair`: one frame pair to `vcx/vcy/vdx/vdy.npy` and
//! `rep.png`. Everything is computed and encoded in memory first, then
//! written in one atomic batch, so any error leaves `--out` untouched.

use std::path::PathBuf;

use reynoldsflow_core::Error as CoreError;

use super::run::ComputeArgs;
use reynoldsflow_host::{HostError, io::atomic, io::image_file, io::npy};

/// Arguments of `reynoldsflow pair`.
#[derive(Debug, clap::Args)]
pub struct PairArgs {
    /// Frame n (8-bit PGM/PPM, PNG or JPEG; colour becomes BT.601 luma).
    #[arg(value_name = "F0")]
    pub f0: PathBuf,
    /// Frame n + 1, same size.
    #[arg(value_name = "F1")]
    pub f1: PathBuf,
    /// Output directory (created if missing) for vcx.npy, vcy.npy, vdx.npy,
    /// vdy.npy (float64, shape (H, W)) and rep.png (RGB8).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// The engine and its parameters.
    #[command(flatten)]
    pub compute: ComputeArgs,
    /// Input limits.
    #[command(flatten)]
    pub limits: super::limits::LimitArgs,
}

/// Run the subcommand.
pub fn run(args: &PairArgs) -> Result<(), HostError> {
    let limits = args.limits.limits();
    let compute = args.compute.compute()?;
    let prev = image_file::read_gray(&args.f0, limits)?;
    let next = image_file::read_gray(&args.f1, limits)?;
    if prev.size() != next.size() {
        return Err(HostError::FrameSizes {
            prev_path: args.f0.clone(),
            prev: prev.size(),
            next_path: args.f1.clone(),
            next: next.size(),
        });
    }
    let output = compute.pair(&prev, &next).map_err(|e| match e {
        // What the core refuses of the frames themselves is about the input.
        HostError::Core(core @ (CoreError::EmptyFrame | CoreError::FrameTooLarge)) => {
            HostError::invalid(args.f0.display().to_string(), core.to_string())
        }
        e => e,
    })?;

    let p = &output.planes;
    let npy = |data: &[f64]| npy::encode(p.height(), p.width(), data);
    let (vcx, vcy, vdx, vdy) = (npy(&p.v_c.u), npy(&p.v_c.v), npy(&p.v_d.u), npy(&p.v_d.v));
    let png = image_file::encode_png(p.width(), p.height(), &output.rep)?;
    let files: [(&str, &[u8]); 5] = [
        ("vcx.npy", &vcx),
        ("vcy.npy", &vcy),
        ("vdx.npy", &vdx),
        ("vdy.npy", &vdy),
        ("rep.png", &png),
    ];
    atomic::write_files(&args.out, &files)
}

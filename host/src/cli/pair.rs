//! `reynoldsflow pair`: one frame pair to `vcx/vcy/vdx/vdy.npy` and
//! `rep.png`. Everything is computed and encoded in memory first, then
//! written in one atomic batch, so any error leaves `--out` untouched.

use std::path::PathBuf;

use reynoldsflow_core::{Error as CoreError, IntensityScale};

use super::values::{self, EngineKind, ScaleArg, TileSize};
use crate::outputs::PairFields;
use crate::{Gray, HostError, atomic, fixed_engine, image_io, npy, pipeline};

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
    /// Engine: the fixed-point core, or the float64 reference.
    #[arg(long, value_enum, default_value_t = EngineKind::Fixed)]
    pub engine: EngineKind,
    /// Magnitudes to bytes: per-frame min-max, or fixed gains KD (|v_d|)
    /// and KC (|v_c|); the fixed engine rounds gains to 1/65536.
    #[arg(long, value_name = "minmax|fixed:KD,KC", default_value = "minmax", value_parser = values::parse_scale)]
    pub scale: ScaleArg,
    /// Intensity scale s (f = pixel * s) as an exact ratio or decimal,
    /// 6144/2^32 <= s <= 1.
    #[arg(long, value_name = "S", default_value = "1/255", value_parser = values::parse_intensity_scale)]
    pub intensity_scale: IntensityScale,
    /// Tikhonov term lambda of the 2x2 solve (the fixed engine rounds it
    /// to 2^-32).
    #[arg(long, value_name = "L", default_value = "1e-4", value_parser = values::parse_lambda)]
    pub lambda: f64,
    /// Tile size for the fixed engine (width at most 128); default: strips
    /// of 128 columns. Every tiling gives the same output.
    #[arg(long, value_name = "TWxTH", value_parser = values::parse_tile)]
    pub tile: Option<TileSize>,
}

/// Run the subcommand.
pub fn run(args: &PairArgs) -> Result<(), HostError> {
    if args.tile.is_some() && args.engine == EngineKind::Float {
        return Err(HostError::invalid(
            "--tile",
            "only the fixed engine works in tiles; drop --tile or use --engine fixed",
        ));
    }
    let prev = image_io::read_gray(&args.f0)?;
    let next = image_io::read_gray(&args.f1)?;
    if prev.size() != next.size() {
        return Err(HostError::FrameSizes {
            prev_path: args.f0.clone(),
            prev: prev.size(),
            next_path: args.f1.clone(),
            next: next.size(),
        });
    }
    let output = match args.engine {
        EngineKind::Float => {
            pipeline::float_pair(&prev, &next, args.intensity_scale, args.lambda, args.scale)?
        }
        EngineKind::Fixed => run_fixed(args, &prev, &next)?,
    };

    let p = &output.planes;
    let npy = |data: &[f64]| npy::encode(p.height, p.width, data);
    let (vcx, vcy, vdx, vdy) = (npy(&p.vcx), npy(&p.vcy), npy(&p.vdx), npy(&p.vdy));
    let png = image_io::encode_png(p.width, p.height, &output.rep)?;
    let files: [(&str, &[u8]); 5] = [
        ("vcx.npy", &vcx),
        ("vcy.npy", &vcy),
        ("vdx.npy", &vdx),
        ("vdy.npy", &vdy),
        ("rep.png", &png),
    ];
    atomic::write_files(&args.out, &files)
}

fn run_fixed(args: &PairArgs, prev: &Gray, next: &Gray) -> Result<PairFields, HostError> {
    let params = pipeline::core_params(args.intensity_scale, args.lambda)?;
    let scaling = pipeline::core_scaling(args.scale)?;
    let tile = args.tile.map(|t| (t.width, t.height));
    let out = fixed_engine::compute_fixed(prev, next, params, tile, scaling)
        .map_err(|e| in_context(e, args))?;
    Ok(PairFields {
        planes: out.planes,
        rep: out.rep,
    })
}

/// Name the flag or file a core error is about.
fn in_context(e: HostError, args: &PairArgs) -> HostError {
    let HostError::Core(core) = e else { return e };
    let about = match core {
        CoreError::LambdaOutOfRange => {
            return pipeline::lambda_range(args.intensity_scale, args.lambda);
        }
        CoreError::ScaleOutOfRange => "--intensity-scale".to_owned(),
        CoreError::TileOutOfFrame | CoreError::TileTooWide { .. } => "--tile".to_owned(),
        CoreError::EmptyFrame | CoreError::FrameTooLarge => args.f0.display().to_string(),
        _ => return HostError::Core(core),
    };
    HostError::invalid(about, core.to_string())
}

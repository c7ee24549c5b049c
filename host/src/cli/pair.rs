//! `reynoldsflow pair`: one frame pair to `vcx/vcy/vdx/vdy.npy` and
//! `rep.png`. Everything is computed and encoded in memory first, then
//! written in one atomic batch, so any error leaves `--out` untouched.

use std::path::PathBuf;

use fixed::types::{U16F16, U32F32};
use reynoldsflow_core::{Error as CoreError, IntensityScale, Params, Scaling};

use super::values::{self, EngineKind, ScaleArg, TileSize};
use crate::reference::{self, FloatParams, FloatScaling};
use crate::{Gray, HostError, atomic, fixed_engine, image_io, npy};

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

/// What `pair` writes, before it is encoded.
struct PairOutput {
    width: usize,
    height: usize,
    fields: [(&'static str, Vec<f64>); 4],
    rep: Vec<u8>,
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
        EngineKind::Float => run_float(args, &prev, &next)?,
        EngineKind::Fixed => run_fixed(args, &prev, &next)?,
    };

    let (h, w) = (output.height, output.width);
    let npys = output
        .fields
        .map(|(name, data)| (name, npy::encode(h, w, &data)));
    let png = image_io::encode_png(w, h, &output.rep)?;
    let mut files: Vec<(&str, &[u8])> = npys
        .iter()
        .map(|(name, bytes)| (*name, bytes.as_slice()))
        .collect();
    files.push(("rep.png", &png));
    atomic::write_files(&args.out, &files)
}

fn run_float(args: &PairArgs, prev: &Gray, next: &Gray) -> Result<PairOutput, HostError> {
    let s = args.intensity_scale;
    let params = FloatParams {
        intensity_scale: f64::from(s.num()) / f64::from(s.den()),
        lambda: args.lambda,
    };
    let flow = reference::compute(prev, next, &params)?;
    let scaling = match args.scale {
        ScaleArg::MinMax => FloatScaling::PerFrameMinMax,
        ScaleArg::Fixed { k_d, k_c } => FloatScaling::Fixed { k_d, k_c },
    };
    let rep = reference::representation(&flow, prev, scaling);
    Ok(PairOutput {
        width: flow.width,
        height: flow.height,
        fields: [
            ("vcx.npy", flow.vcx),
            ("vcy.npy", flow.vcy),
            ("vdx.npy", flow.vdx),
            ("vdy.npy", flow.vdy),
        ],
        rep,
    })
}

/// A gain as the core's Q16.16, rounded to nearest.
fn core_gain(which: &str, k: f64) -> Result<U16F16, HostError> {
    U16F16::checked_from_num(k).ok_or_else(|| {
        HostError::invalid(
            "--scale",
            format!("{which} = {k} is beyond the fixed engine's range [0, 65536)"),
        )
    })
}

fn run_fixed(args: &PairArgs, prev: &Gray, next: &Gray) -> Result<PairOutput, HostError> {
    let lambda = U32F32::checked_from_num(args.lambda).ok_or_else(|| lambda_range(args))?;
    let params = Params {
        scale: args.intensity_scale,
        lambda,
    };
    let scaling = match args.scale {
        ScaleArg::MinMax => Scaling::PerFrameMinMax,
        ScaleArg::Fixed { k_d, k_c } => Scaling::Fixed {
            k_d: core_gain("KD", k_d)?,
            k_c: core_gain("KC", k_c)?,
        },
    };
    let tile = args.tile.map(|t| (t.width, t.height));
    let out = fixed_engine::compute_fixed(prev, next, params, tile, scaling)
        .map_err(|e| in_context(e, args))?;
    Ok(PairOutput {
        width: out.width,
        height: out.height,
        fields: [
            ("vcx.npy", out.vcx),
            ("vcy.npy", out.vcy),
            ("vdx.npy", out.vdx),
            ("vdy.npy", out.vdy),
        ],
        rep: out.rep,
    })
}

/// Name the flag or file a core error is about.
fn in_context(e: HostError, args: &PairArgs) -> HostError {
    let HostError::Core(core) = e else { return e };
    let about = match core {
        CoreError::LambdaOutOfRange => return lambda_range(args),
        CoreError::ScaleOutOfRange => "--intensity-scale".to_owned(),
        CoreError::TileOutOfFrame | CoreError::TileTooWide { .. } => "--tile".to_owned(),
        CoreError::EmptyFrame | CoreError::FrameTooLarge => args.f0.display().to_string(),
        _ => return HostError::Core(core),
    };
    HostError::invalid(about, core.to_string())
}

/// The fixed engine's λ range at the given intensity scale, from the core's
/// integer bounds (`params`): `Λ8 = round(131072 · λ / s²) ∈ [1, 2³¹)`, and λ
/// itself in Q32.32.
fn lambda_range(args: &PairArgs) -> HostError {
    let s = f64::from(args.intensity_scale.num()) / f64::from(args.intensity_scale.den());
    let low = (s * s / 262_144.0).max(0.5f64.powi(33));
    let high = 16_384.0 * s * s;
    HostError::invalid(
        "--lambda",
        format!(
            "{} is outside the fixed engine's range at this intensity scale (about {low:.2e} to {high:.2e}); \
             use --engine float or another --intensity-scale",
            args.lambda
        ),
    )
}

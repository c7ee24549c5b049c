//! One frame pair through the fixed-point core, collected into whole-frame
//! planes: the fields (Q16.16) and magnitudes (Q32.32) as exact f64 copies
//! of the core's values, and the RGB8 representation.

use fixed::types::{I16F16, U32F32};
use reynoldsflow_core::{
    Config, Engine, FieldPlanes, FieldSink, FramePair, Params, Plan, Scaling, represent,
};

use crate::{Gray, HostError};

/// Window columns of the host's engine: tiles up to
/// [`MAX_TILE_WIDTH`] = 128 columns, about 43 KiB of working memory.
/// Wider frames are cut into strips; every tiling gives the same bytes.
pub const ENGINE_COLS: usize = 142;

/// The host engine.
pub type HostEngine = Engine<ENGINE_COLS>;

/// Widest tile `compute_fixed` accepts (wider requests are refused with
/// [`reynoldsflow_core::Error::TileTooWide`] rather than silently cut).
pub const MAX_TILE_WIDTH: usize = HostEngine::MAX_TILE_WIDTH;

/// The core's output for a frame pair, row-major planes of `width · height`.
#[derive(Clone, Debug, PartialEq)]
pub struct FixedOutput {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `v_c` x, the exact value of the core's Q16.16 (`bits / 65536`).
    pub vcx: Vec<f64>,
    /// `v_c` y.
    pub vcy: Vec<f64>,
    /// `v_d` x.
    pub vdx: Vec<f64>,
    /// `v_d` y.
    pub vdy: Vec<f64>,
    /// `|v_d|` as the core computes it (the exact value of its Q32.32).
    pub m_d: Vec<f64>,
    /// `|v_c|`.
    pub m_c: Vec<f64>,
    /// The RGB8 representation, `3 · width · height` bytes.
    pub rep: Vec<u8>,
}

/// Run the core on `(prev, next)` with `params`, in full-height strips as
/// wide as the engine allows, or in `tile = (width, height)` tiles when
/// given. Fails when the frames differ in size, or the core refuses the
/// size, the parameters or the tile (e.g. wider than [`MAX_TILE_WIDTH`]).
pub fn compute_fixed(
    prev: &Gray,
    next: &Gray,
    params: Params,
    tile: Option<(usize, usize)>,
    scaling: Scaling,
) -> Result<FixedOutput, HostError> {
    if prev.size() != next.size() {
        return Err(HostError::SizeMismatch {
            prev: prev.size(),
            next: next.size(),
        });
    }
    let (width, height) = prev.size();
    let config = Config::new(width, height, params)?;
    let plan = match tile {
        None => Plan::strips(config)?,
        Some((tw, th)) => Plan::new(config, tw, th)?,
    };
    let frames = FramePair::packed(&config, &prev.pixels, &next.pixels)?;
    // Boxed: the engine is too large to keep on a test thread's stack for long.
    let mut engine = Box::new(HostEngine::new());

    let n = width * height;
    let (mut vcx, mut vcy, mut vdx, mut vdy) = (
        vec![I16F16::ZERO; n],
        vec![I16F16::ZERO; n],
        vec![I16F16::ZERO; n],
        vec![I16F16::ZERO; n],
    );
    let (mut m_d, mut m_c) = (vec![U32F32::ZERO; n], vec![U32F32::ZERO; n]);
    let mut rep = vec![0u8; 3 * n];
    let fields = FieldSink::new(
        &config,
        FieldPlanes {
            v_c_x: Some(&mut vcx),
            v_c_y: Some(&mut vcy),
            v_d_x: Some(&mut vdx),
            v_d_y: Some(&mut vdy),
            m_c: Some(&mut m_c),
            m_d: Some(&mut m_d),
        },
    )?;
    represent(&mut engine, &plan, &frames, scaling, &mut rep, fields)?;

    // Q16.16 → f64 is exact: 32 significant bits fit the 53-bit mantissa.
    let signed = |v: Vec<I16F16>| {
        v.into_iter()
            .map(|x| f64::from(x.to_bits()) / 65536.0)
            .collect()
    };
    // Magnitudes are Q32.32 below 2⁴⁸: exact in f64 as well.
    let unsigned = |v: Vec<U32F32>| v.into_iter().map(|x| x.to_num::<f64>()).collect();
    Ok(FixedOutput {
        width,
        height,
        vcx: signed(vcx),
        vcy: signed(vcy),
        vdx: signed(vdx),
        vdy: signed(vdy),
        m_d: unsigned(m_d),
        m_c: unsigned(m_c),
        rep,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(width: usize, height: usize, seed: usize) -> Gray {
        let pixels = (0..width * height)
            .map(|i| ((i * 7 + seed).wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        Gray::new(width, height, pixels).unwrap()
    }

    #[test]
    fn every_tiling_gives_the_same_output() {
        let (a, b) = (frame(150, 20, 0), frame(150, 20, 1));
        let strips = compute_fixed(&a, &b, Params::DEFAULT, None, Scaling::PerFrameMinMax).unwrap();
        for tile in [(1, 1), (7, 5), (128, 20), (64, 3)] {
            let tiled = compute_fixed(&a, &b, Params::DEFAULT, Some(tile), Scaling::PerFrameMinMax)
                .unwrap();
            assert!(tiled == strips, "tile {tile:?}");
        }
        assert!(strips.m_d.iter().any(|&m| m > 0.0));
    }

    #[test]
    fn refuses_wide_tiles_and_mismatched_frames() {
        let (a, b) = (frame(200, 4, 0), frame(200, 4, 1));
        let wide = compute_fixed(
            &a,
            &b,
            Params::DEFAULT,
            Some((129, 4)),
            Scaling::PerFrameMinMax,
        );
        assert!(matches!(
            wide,
            Err(HostError::Core(reynoldsflow_core::Error::TileTooWide {
                max: 128
            }))
        ));
        let c = frame(4, 200, 0);
        let mismatch = compute_fixed(&a, &c, Params::DEFAULT, None, Scaling::PerFrameMinMax);
        assert!(matches!(mismatch, Err(HostError::SizeMismatch { .. })));
    }
}

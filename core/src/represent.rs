//! Whole-frame convenience: the representation in either scaling mode.

use crate::{ByteScale, Engine, Error, ExtremesSink, FramePair, Plan, RgbSink, Scaling, Sink};

/// The byte scales of both channels for a `Scaling`, running the engine
/// once over the pair first when the mode needs the frame's extremes.
#[inline(always)]
pub fn byte_scales<const COLS: usize>(
    engine: &mut Engine<COLS>,
    plan: &Plan<COLS>,
    frames: &FramePair<'_>,
    scaling: Scaling,
) -> Result<(ByteScale, ByteScale), Error> {
    scaling.byte_scales(|| {
        let mut extremes = ExtremesSink::default();
        engine.run(plan, frames, &mut extremes).map(|()| extremes)
    })
}

/// Write the RGB8 representation of `frames` into `rgb` (`3 · W · H` bytes,
/// row-major), and hand every pixel to `also` as well (use `()` for
/// nothing). `PerFrameMinMax` runs the engine twice, `Fixed` once.
#[inline(always)]
pub fn represent<const COLS: usize, S: Sink>(
    engine: &mut Engine<COLS>,
    plan: &Plan<COLS>,
    frames: &FramePair<'_>,
    scaling: Scaling,
    rgb: &mut [u8],
    also: S,
) -> Result<(), Error> {
    let (scale_d, scale_c) = byte_scales(engine, plan, frames, scaling)?;
    let sink = RgbSink::new(plan.config(), rgb, scale_d, scale_c)?;
    engine.run(plan, frames, &mut (sink, also))
}

//! Whole-frame convenience: the representation in either scaling mode.

use crate::sink::check_len;
use crate::{ByteScale, Error, ExtremesSink, Job, Memory, RgbSink, Scaling, Sink, TileEngine};

/// The byte scales of both channels for a `Scaling`, running the engine
/// once over the job first when the mode needs the frame's extremes.
#[inline(always)]
pub fn byte_scales<M: Memory>(
    engine: &mut TileEngine<M>,
    job: &Job<'_>,
    scaling: Scaling,
) -> (ByteScale, ByteScale) {
    let extremes = || {
        let mut extremes = ExtremesSink::default();
        engine.run(job, &mut extremes);
        Ok::<_, core::convert::Infallible>(extremes)
    };
    match scaling.byte_scales(extremes) {
        Ok(scales) => scales,
        Err(never) => match never {},
    }
}

/// Write the RGB8 representation of the job's frames into `rgb`
/// (`3 · W · H` bytes, row-major), and hand every pixel to `also` as well
/// (use `()` for nothing). `PerFrameMinMax` runs the engine twice, `Fixed`
/// once. Fails, before computing anything, only when `rgb` is too short.
#[inline(always)]
pub fn represent<M: Memory, S: Sink>(
    engine: &mut TileEngine<M>,
    job: &Job<'_>,
    scaling: Scaling,
    rgb: &mut [u8],
    also: S,
) -> Result<(), Error> {
    check_len(job.config(), rgb.len(), 3)?;
    let (scale_d, scale_c) = byte_scales(engine, job, scaling);
    let sink = RgbSink::new(job.config(), rgb, scale_d, scale_c)?;
    engine.run(job, &mut (sink, also));
    Ok(())
}

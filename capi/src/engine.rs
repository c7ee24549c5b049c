//! The engine handle: a validated configuration, the core's engine in the
//! caller's working memory, the streaming byte scales, and the calls that
//! compute a whole pair.

use core::ffi::c_void;
use core::mem::replace;

use reynoldsflow_core::{
    ByteScale, ExtremesSink, Frame, FramePair, MemorySize, PreviousFrameMinMax, RgbSink, RowStream,
    Scaling, Sink, SliceEngine, byte_scales,
};

use crate::config::{Mode, Settings, rf_config};
use crate::cues::{CueHandle, rf_cues};
use crate::memory::{Carver, aligned_start, zeroed};
use crate::sinks::{FrameBuffers, Maybe, RowCallback, rf_row_fn};
use crate::status::*;
use crate::{cues, ffi};

/// An engine in caller memory (`rf_init`).
#[allow(non_camel_case_types)]
pub struct rf_engine {
    _opaque: [u8; 0],
}

/// What `rf_represent` writes: any of the buffers, each NULL (not wanted)
/// or at least its length for the frame. Lengths count elements.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[allow(non_camel_case_types)]
pub struct rf_outputs {
    /// RGB8 representation, row-major, `3 · width · height` bytes.
    pub rgb: *mut u8,
    /// Length of `rgb`.
    pub rgb_len: usize,
    /// `v_c` as (x, y) pairs, px, y down: `2 · width · height` floats.
    pub v_c: *mut f32,
    /// Length of `v_c`.
    pub v_c_len: usize,
    /// `v_d` as `v_c`.
    pub v_d: *mut f32,
    /// Length of `v_d`.
    pub v_d_len: usize,
    /// `|v_c|`, px: `width · height` floats.
    pub m_c: *mut f32,
    /// Length of `m_c`.
    pub m_c_len: usize,
    /// `|v_d|`, px: `width · height` floats.
    pub m_d: *mut f32,
    /// Length of `m_d`.
    pub m_d_len: usize,
}

/// "RFENGN01": marks a block `rf_init` set up.
const MAGIC: u64 = u64::from_le_bytes(*b"RFENGN01");

/// Where the core's engine is.
pub(crate) enum State {
    /// Between pairs.
    Idle(SliceEngine<'static>),
    /// Inside a row stream.
    Streaming(RowStream<SliceEngine<'static>>),
    /// Lent to a call in progress (seen only by a call from a callback).
    Busy,
}

/// Row buffers of the working memory, for row callbacks.
pub(crate) struct RowBuffers {
    pub(crate) rgb: &'static mut [[u8; 3]],
    /// `v_c`, then `v_d`: empty unless the rows carry fields.
    pub(crate) fields: &'static mut [[f32; 2]],
}

/// The block behind an `rf_engine` pointer. Its slices point into the
/// same block, after it: they live as long as the handle, which is the
/// caller's promise for the block.
pub(crate) struct Instance {
    magic: u64,
    pub(crate) settings: Settings,
    /// The streaming min–max: this pair's scales, the next pair's extremes.
    pub(crate) previous: PreviousFrameMinMax,
    pub(crate) state: State,
    pub(crate) rows: RowBuffers,
    /// Attached cues (`rf_attach_cues`), NULL for none.
    pub(crate) cues: *mut rf_cues,
}

/// Offsets of the engine's parts in its block.
struct Layout {
    carver: Carver,
    memory: MemorySize,
    words: usize,
    floats: usize,
    halves: usize,
    bytes: usize,
    row_rgb: usize,
    row_fields: (usize, usize),
}

impl Layout {
    fn of(settings: &Settings) -> Option<Self> {
        let w = settings.tile_width;
        let memory = MemorySize::for_tile_width(w)?;
        let mut carver = Carver::after_header::<Instance>();
        let words = carver.array::<i32>(memory.words)?;
        let floats = carver.array::<f32>(memory.floats)?;
        let fields = if settings.row_fields {
            w.checked_mul(2)?
        } else {
            0
        };
        let row_fields = (carver.array::<[f32; 2]>(fields)?, fields);
        let halves = carver.array::<i16>(memory.halves)?;
        let bytes = carver.array::<u8>(memory.bytes)?;
        let row_rgb = carver.array::<[u8; 3]>(w)?;
        Some(Self {
            carver,
            memory,
            words,
            floats,
            halves,
            bytes,
            row_rgb,
            row_fields,
        })
    }
}

/// The instance behind an engine handle.
///
/// # Safety
/// A non-NULL `engine` is a handle from `rf_init` whose block is still the
/// library's, and no other reference to it is live.
pub(crate) unsafe fn engine_instance<'a>(
    engine: *mut rf_engine,
) -> Result<&'a mut Instance, rf_status> {
    if engine.is_null() {
        return Err(RF_ERR_NULL_POINTER);
    }
    if !(engine as usize).is_multiple_of(Carver::ALIGN) {
        return Err(RF_ERR_BAD_HANDLE);
    }
    let instance = engine.cast::<Instance>();
    // SAFETY: aligned and non-NULL; a handle's block starts with an
    // initialised `Instance` (contract). The magic is read before any
    // reference exists, so a stray pointer is refused first.
    if unsafe { (&raw const (*instance).magic).read() } != MAGIC {
        return Err(RF_ERR_BAD_HANDLE);
    }
    // SAFETY: an initialised instance, the handle's alone (contract).
    Ok(unsafe { &mut *instance })
}

impl Instance {
    /// The attached cues (their block is not the engine's: the handle's
    /// lifetime is the caller's promise, not a borrow of the instance).
    pub(crate) fn cues<'c>(&self) -> Option<CueHandle<'c>> {
        // SAFETY: `rf_attach_cues` checked the handle, and the caller keeps
        // the cues' block valid and unshared while attached (contract).
        unsafe { cues::handle(self.cues) }.ok()
    }

    /// The engine between pairs, lent for one call (`Busy` meanwhile).
    pub(crate) fn take_engine(&mut self) -> Result<SliceEngine<'static>, rf_status> {
        match replace(&mut self.state, State::Busy) {
            State::Idle(engine) => Ok(engine),
            other => Err(self.refuse(other, RF_ERR_STREAM_ACTIVE)),
        }
    }

    /// The stream in progress, lent for one call (`Busy` meanwhile).
    pub(crate) fn take_stream(&mut self) -> Result<RowStream<SliceEngine<'static>>, rf_status> {
        match replace(&mut self.state, State::Busy) {
            State::Streaming(stream) => Ok(stream),
            other => Err(self.refuse(other, RF_ERR_NO_STREAM)),
        }
    }

    /// Put back a state a call cannot use, and say why: `wrong_state`, or
    /// busy when a call is in progress (a call from a row callback).
    fn refuse(&mut self, state: State, wrong_state: rf_status) -> rf_status {
        let busy = matches!(state, State::Busy);
        self.state = state;
        if busy { RF_ERR_BUSY } else { wrong_state }
    }

    /// The byte scales of this pair (per-frame min–max asks the engine for
    /// the frame's extremes first: a pass of its own).
    fn scales(
        &self,
        engine: &mut SliceEngine<'static>,
        frames: FramePair<'_>,
    ) -> Result<(ByteScale, ByteScale), rf_status> {
        Ok(match self.settings.mode {
            Mode::Fixed => self.settings.gains,
            Mode::PreviousFrameMinMax => self.previous.scales(),
            Mode::PerFrameMinMax => {
                let job = self.settings.plan.bind(frames)?;
                byte_scales(engine, &job, Scaling::PerFrameMinMax)
            }
        })
    }

    /// A pair is complete: the previous-frame min–max takes its extremes.
    pub(crate) fn end_pair(&mut self, extremes: ExtremesSink) {
        if self.settings.mode == Mode::PreviousFrameMinMax {
            *self.previous.tracker() = extremes;
            self.previous.end_frame();
        }
    }

    /// Forget the streaming scales' history and any stream in progress.
    pub(crate) fn restart(&mut self) {
        let (d, c) = self.settings.gains;
        self.previous = PreviousFrameMinMax::new(d, c);
    }
}

/// Run the engine over a pair into `sink`, beside the attached cues (then
/// closing their frame) and, for the previous-frame min–max, a tracker of
/// the pair's extremes, which it returns. Takes no instance: a row
/// callback may run inside, and no reference to the instance may be live
/// then (a callback that calls the library with the engine gets `RF_ERR_BUSY`).
fn run_pair<S: Sink>(
    engine: &mut SliceEngine<'static>,
    settings: &Settings,
    frames: FramePair<'_>,
    cues: *mut rf_cues,
    sink: S,
) -> Result<ExtremesSink, rf_status> {
    let job = settings.plan.bind(frames)?;
    let tracks = settings.mode == Mode::PreviousFrameMinMax;
    let mut extremes = ExtremesSink::default();
    // SAFETY: `rf_attach_cues` checked the handle; the caller keeps the
    // cues' block valid and unshared while attached (contract).
    let mut cues = unsafe { cues::handle(cues) }.ok();
    let cue_sink = Maybe(cues.as_mut().map(|h| &mut h.cues));
    engine.run(
        &job,
        &mut (sink, (Maybe(tracks.then_some(&mut extremes)), cue_sink)),
    );
    if let Some(cues) = &mut cues {
        cues.end_frame();
    }
    Ok(extremes)
}

/// The pair of frames behind two pointers, checked against the frame size.
///
/// # Safety
/// Each pointer is NULL (refused) or points to `len` readable bytes.
unsafe fn frame_pair<'a>(
    settings: &Settings,
    prev: *const u8,
    next: *const u8,
    len: usize,
    stride: usize,
) -> Result<FramePair<'a>, rf_status> {
    let (w, h) = (settings.config.width(), settings.config.height());
    let stride = if stride == 0 { w } else { stride };
    // SAFETY: the caller's contract.
    let (prev, next) = unsafe { (ffi::required(prev, len)?, ffi::required(next, len)?) };
    let frame = |pixels| Frame::new(pixels, w, h, stride);
    Ok(FramePair::new(
        &settings.config,
        frame(prev)?,
        frame(next)?,
    )?)
}

/// Write the default configuration for `width × height` frames: intensity
/// scale 1/255, λ 1e-4, per-frame min-max, gains 8 and 32, variant DC,
/// full-width tiles, no flags (the command line's defaults).
///
/// # Safety
/// `config` is NULL (refused) or points to writable memory for one `rf_config`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_config_init(
    config: *mut rf_config,
    width: u32,
    height: u32,
) -> rf_status {
    // SAFETY: the caller's contract.
    ffi::status(unsafe { ffi::write(config, rf_config::new(width, height)) })
}

/// Check `config` and store in `*bytes` the working memory `rf_init` needs
/// for it (any alignment): about `252 · (tile width + 14)` bytes plus a few
/// hundred. Fails as `rf_init` would on a bad configuration.
///
/// # Safety
/// `config` and `bytes` are NULL (refused) or valid pointers.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_workspace_size(
    config: *const rf_config,
    bytes: *mut usize,
) -> rf_status {
    let size = || {
        // SAFETY: the caller's contract.
        let settings = Settings::new(&unsafe { ffi::read(config) }?)?;
        Layout::of(&settings)
            .and_then(|l| l.carver.bytes())
            .ok_or(RF_ERR_FRAME_TOO_LARGE)
    };
    // SAFETY: the caller's contract.
    ffi::status(size().and_then(|n| unsafe { ffi::write(bytes, n) }))
}

/// Set up an engine for `config` in `memory` (`memory_len` bytes, at least
/// `rf_workspace_size`'s; any alignment) and store its handle in
/// `*engine`. The memory is the library's from here until the caller
/// reuses it (a static array on an MCU); the handle points into it.
/// After this, no call on the handle can fail on the configuration, and
/// none allocates.
///
/// # Safety
/// `memory` points to `memory_len` writable bytes that nothing else uses
/// while the handle is in use; `config` and `engine` are NULL (refused) or
/// valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_init(
    memory: *mut c_void,
    memory_len: usize,
    config: *const rf_config,
    engine: *mut *mut rf_engine,
) -> rf_status {
    let init = || {
        if memory.is_null() || engine.is_null() {
            return Err(RF_ERR_NULL_POINTER);
        }
        // SAFETY: the caller's contract.
        let settings = Settings::new(&unsafe { ffi::read(config) }?)?;
        let layout = Layout::of(&settings).ok_or(RF_ERR_FRAME_TOO_LARGE)?;
        let start = aligned_start(memory.cast(), memory_len, layout.carver.end())
            .ok_or(RF_ERR_BUFFER_TOO_SHORT)?;
        let m = layout.memory;
        // SAFETY: `start` is aligned to 8 and the block spans every part
        // (`aligned_start`); the parts do not overlap (`Carver`) and the
        // block is the library's for the handle's life (contract).
        let (words, floats, halves, bytes, rgb, fields) = unsafe {
            (
                zeroed(start, layout.words, m.words),
                zeroed(start, layout.floats, m.floats),
                zeroed(start, layout.halves, m.halves),
                zeroed(start, layout.bytes, m.bytes),
                zeroed(start, layout.row_rgb, settings.tile_width),
                zeroed(start, layout.row_fields.0, layout.row_fields.1),
            )
        };
        let core_engine = SliceEngine::new(words, floats, halves, bytes)?;
        let (d, c) = settings.gains;
        let instance = Instance {
            magic: MAGIC,
            settings,
            previous: PreviousFrameMinMax::new(d, c),
            state: State::Idle(core_engine),
            rows: RowBuffers { rgb, fields },
            cues: core::ptr::null_mut(),
        };
        let handle = start.cast::<Instance>();
        // SAFETY: aligned, in the block, not overlapping the arrays.
        unsafe { handle.write(instance) };
        // SAFETY: the caller's contract.
        unsafe { ffi::write(engine, handle.cast::<rf_engine>()) }
    };
    ffi::status(init())
}

/// Compute the pair `prev` → `next` (each `frame_len` bytes of 8-bit gray,
/// rows `stride` bytes apart; 0 is the width) into the buffers of
/// `outputs`. Per-frame min-max runs the engine twice when bytes are
/// wanted. Every buffer is checked before anything is computed.
///
/// # Safety
/// The engine is a handle from `rf_init`; the frames hold `frame_len`
/// readable bytes; `outputs` is NULL (refused) or valid, its buffers
/// writable for their lengths and not overlapping each other.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_represent(
    engine: *mut rf_engine,
    prev: *const u8,
    next: *const u8,
    frame_len: usize,
    stride: usize,
    outputs: *const rf_outputs,
) -> rf_status {
    // SAFETY: the caller's contract, argument by argument.
    ffi::status(unsafe { represent(engine, prev, next, frame_len, stride, outputs) })
}

/// `rf_represent`'s body.
///
/// # Safety
/// As `rf_represent`.
unsafe fn represent(
    engine: *mut rf_engine,
    prev: *const u8,
    next: *const u8,
    frame_len: usize,
    stride: usize,
    outputs: *const rf_outputs,
) -> Result<(), rf_status> {
    // SAFETY: the caller's contract.
    let (instance, out) = unsafe { (engine_instance(engine)?, ffi::read(outputs)?) };
    let config = instance.settings.config;
    // SAFETY: the caller's contract.
    let frames = unsafe { frame_pair(&instance.settings, prev, next, frame_len, stride) }?;
    let pixels = config.width() * config.height();
    let need = |len: usize, per: usize| {
        if len < pixels * per {
            Err(RF_ERR_BUFFER_TOO_SHORT)
        } else {
            Ok(())
        }
    };
    // SAFETY: the caller's contract: each buffer writable for its length.
    let (rgb, v_c, v_d, m_c, m_d) = unsafe {
        (
            ffi::optional_mut(out.rgb, out.rgb_len)?,
            ffi::optional_mut(out.v_c.cast::<[f32; 2]>(), out.v_c_len / 2)?,
            ffi::optional_mut(out.v_d.cast::<[f32; 2]>(), out.v_d_len / 2)?,
            ffi::optional_mut(out.m_c, out.m_c_len)?,
            ffi::optional_mut(out.m_d, out.m_d_len)?,
        )
    };
    for (len, per) in [
        (rgb.as_ref().map(|b| b.len()), 3),
        (v_c.as_ref().map(|b| b.len()), 1),
        (v_d.as_ref().map(|b| b.len()), 1),
        (m_c.as_ref().map(|b| b.len()), 1),
        (m_d.as_ref().map(|b| b.len()), 1),
    ] {
        len.map_or(Ok(()), |len| need(len, per))?;
    }
    let mut core_engine = instance.take_engine()?;
    let run = (|| {
        let buffers = FrameBuffers {
            width: config.width(),
            v_c,
            v_d,
            m_c,
            m_d,
        };
        let (settings, cues) = (instance.settings, instance.cues);
        let Some(rgb) = rgb else {
            let extremes = run_pair(&mut core_engine, &settings, frames, cues, buffers)?;
            instance.end_pair(extremes);
            return Ok(());
        };
        let (d, c) = instance.scales(&mut core_engine, frames)?;
        let bytes = RgbSink::new(&config, &mut *rgb, d, c)?;
        let extremes = run_pair(&mut core_engine, &settings, frames, cues, (bytes, buffers))?;
        instance.end_pair(extremes);
        let (pixels, _) = rgb.as_chunks_mut::<3>();
        settings.variant.apply(pixels);
        Ok(())
    })();
    instance.state = State::Idle(core_engine);
    run
}

/// Compute the pair as `rf_represent` does, but hand each output row
/// segment to `callback` (with `user`) instead of writing frame buffers:
/// the memory a frame of output would take is not needed. Segments come
/// tile by tile (a tile's rows top to bottom, tiles left to right), each
/// at most `tile_width` wide. Per-frame min-max runs the engine twice.
///
/// # Safety
/// As `rf_represent`; `callback` must not call the library with this engine.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_represent_rows(
    handle: *mut rf_engine,
    prev: *const u8,
    next: *const u8,
    frame_len: usize,
    stride: usize,
    callback: rf_row_fn,
    user: *mut c_void,
) -> rf_status {
    let run = || {
        // SAFETY: the caller's contract.
        let instance = unsafe { engine_instance(handle) }?;
        let settings = instance.settings;
        // SAFETY: the caller's contract.
        let frames = unsafe { frame_pair(&settings, prev, next, frame_len, stride) }?;
        let callback = callback.ok_or(RF_ERR_NULL_POINTER)?;
        let mut core_engine = instance.take_engine()?;
        let scales = match instance.scales(&mut core_engine, frames) {
            Ok(scales) => scales,
            Err(e) => {
                instance.state = State::Idle(core_engine);
                return Err(e);
            }
        };
        let (rows, cues) = (row_buffers(instance), instance.cues);
        let sink = RowCallback {
            scales,
            variant: settings.variant,
            rgb: &mut *rows.rgb,
            fields: &mut *rows.fields,
            callback,
            user,
        };
        // No reference to the instance from here to the end of the run.
        let result = run_pair(&mut core_engine, &settings, frames, cues, sink);
        // SAFETY: the same handle, checked above; the run's own use of it
        // ended (a callback's call saw `Busy` and returned).
        let instance = unsafe { engine_instance(handle) }?;
        instance.rows = rows;
        instance.state = State::Idle(core_engine);
        result.map(|extremes| instance.end_pair(extremes))
    };
    ffi::status(run())
}

/// Take the row buffers out of the instance (empty ones stay behind).
pub(crate) fn row_buffers(instance: &mut Instance) -> RowBuffers {
    RowBuffers {
        rgb: core::mem::take(&mut instance.rows.rgb),
        fields: core::mem::take(&mut instance.rows.fields),
    }
}

/// Feed every pair this engine computes from now on (whole frames and
/// streams) to `cues` too, and close their frame after each pair (read the
/// regions with `rf_cues_result`). NULL detaches. The cues must be for the
/// engine's frame size and stay valid while attached.
///
/// # Safety
/// The engine is a handle from `rf_init`; `cues` is NULL or a handle from
/// `rf_cues_init`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_attach_cues(engine: *mut rf_engine, cues: *mut rf_cues) -> rf_status {
    let attach = || {
        // SAFETY: the caller's contract.
        let instance = unsafe { engine_instance(engine) }?;
        if !matches!(instance.state, State::Idle(_)) {
            return Err(RF_ERR_STREAM_ACTIVE);
        }
        if !cues.is_null() {
            // SAFETY: the caller's contract.
            let handle = unsafe { cues::handle(cues) }?;
            let config = instance.settings.config;
            if handle.size() != (config.width(), config.height()) {
                return Err(RF_ERR_SIZE_MISMATCH);
            }
        }
        instance.cues = cues;
        Ok(())
    };
    ffi::status(attach())
}

/// Start over: the previous-frame min-max forgets the frames seen (the
/// next pair uses the fixed gains again) and a stream in progress is
/// cancelled, as after `rf_init`. Attached cues are left as they are.
///
/// # Safety
/// The engine is a handle from `rf_init`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_reset(engine: *mut rf_engine) -> rf_status {
    let reset = || {
        // SAFETY: the caller's contract.
        let instance = unsafe { engine_instance(engine) }?;
        crate::stream::cancel(instance)?;
        instance.restart();
        Ok(())
    };
    ffi::status(reset())
}

/// Bytes of the handle's own part of a workspace, at most, on any target
/// (with alignment slack and padding): what `RF_WORKSPACE_BYTES` adds to
/// the engine's 252 bytes a window column.
pub const RF_WORKSPACE_OVERHEAD: u32 = 512;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::RF_FLAG_ROW_FIELDS;

    /// The header's `RF_WORKSPACE_BYTES(tile_width, flags)`, in Rust.
    fn macro_bytes(tile_width: usize, flags: u32) -> usize {
        let per_column = if flags & RF_FLAG_ROW_FIELDS != 0 {
            19
        } else {
            3
        };
        252 * (tile_width + 14) + per_column * tile_width + RF_WORKSPACE_OVERHEAD as usize
    }

    #[test]
    fn the_static_size_macro_bounds_the_workspace_query() {
        assert!(
            core::mem::size_of::<Instance>() + Carver::ALIGN + 32 <= RF_WORKSPACE_OVERHEAD as usize
        );
        for width in [1u32, 2, 17, 32, 160, 320, 641, 4096, 65535] {
            for flags in [0, RF_FLAG_ROW_FIELDS] {
                let mut config = rf_config::new(width, 8);
                config.flags = flags;
                let mut bytes = 0;
                // SAFETY: valid pointers.
                assert_eq!(unsafe { rf_workspace_size(&config, &mut bytes) }, RF_OK);
                let bound = macro_bytes(width as usize, flags);
                assert!(
                    bytes <= bound && bound - bytes <= RF_WORKSPACE_OVERHEAD as usize,
                    "{width} {flags}: {bytes} {bound}"
                );
            }
        }
    }
}

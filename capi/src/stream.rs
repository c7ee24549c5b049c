//! Row streaming for C: frame rows in as the sensor delivers them, output
//! rows out through a callback as soon as the rows they depend on are in
//! (output row `y − 7` after input row `y`; the last eight with the last).

use core::ffi::c_void;
use reynoldsflow_core::{ExtremesSink, RowStream};

use crate::config::Mode;
use crate::engine::{Instance, State, engine_instance, rf_engine, row_buffers};
use crate::sinks::{Maybe, RowCallback, rf_row_fn};
use crate::status::*;
use crate::{cues, ffi};

/// Most output rows one `rf_stream_push` hands to its callback.
pub const RF_STREAM_MAX_ROWS_PER_PUSH: u32 = 8;

/// Start streaming a pair: the next `height` calls of `rf_stream_push`
/// bring its rows. Needs `RF_SCALING_FIXED` or
/// `RF_SCALING_PREVIOUS_FRAME_MINMAX` and working memory for the full
/// width (`tile_width` 0).
///
/// # Safety
/// The engine is a handle from `rf_init`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_stream_begin(engine: *mut rf_engine) -> rf_status {
    let begin = || {
        // SAFETY: the caller's contract.
        let instance = unsafe { engine_instance(engine) }?;
        if instance.settings.mode == Mode::PerFrameMinMax {
            return Err(RF_ERR_STREAM_NEEDS_KNOWN_SCALE);
        }
        let core_engine = instance.take_engine()?;
        match RowStream::owning_full_width(core_engine, instance.settings.config) {
            Ok(stream) => instance.state = State::Streaming(stream),
            Err((e, core_engine)) => {
                instance.state = State::Idle(core_engine);
                return Err(e.into());
            }
        }
        Ok(())
    };
    ffi::status(begin())
}

/// Push row `y` of `prev` and of `next` (each at least `row_len` ≥ width
/// bytes) into the stream; the output rows it completes go to `callback`
/// (with `user`), 0 to `RF_STREAM_MAX_ROWS_PER_PUSH` of them. The pair's
/// last row ends the stream: attached cues close their frame, and the
/// previous-frame min-max takes this pair's extremes for the next.
///
/// # Safety
/// The engine is a handle from `rf_init`; the rows hold `row_len` readable
/// bytes; `callback` must not call the library with this engine.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_stream_push(
    handle: *mut rf_engine,
    prev_row: *const u8,
    next_row: *const u8,
    row_len: usize,
    callback: rf_row_fn,
    user: *mut c_void,
) -> rf_status {
    let push = || {
        // SAFETY: the caller's contract.
        let instance = unsafe { engine_instance(handle) }?;
        // SAFETY: the caller's contract.
        let (prev, next) = unsafe {
            (
                ffi::required(prev_row, row_len)?,
                ffi::required(next_row, row_len)?,
            )
        };
        let callback = callback.ok_or(RF_ERR_NULL_POINTER)?;
        if row_len < instance.settings.config.width() {
            return Err(RF_ERR_BUFFER_TOO_SHORT);
        }
        let mut stream = instance.take_stream()?;
        let settings = instance.settings;
        let scales = match settings.mode {
            Mode::Fixed => settings.gains,
            _ => instance.previous.scales(),
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
        let tracks = settings.mode == Mode::PreviousFrameMinMax;
        // The pair's extremes so far live in the instance between pushes;
        // this push adds to a copy, so no reference to the instance is live
        // while the callback runs.
        let mut extremes = *instance.previous.tracker();
        // SAFETY: `rf_attach_cues` checked the handle; the caller keeps the
        // cues' block valid and unshared while attached (contract).
        let mut cues = unsafe { cues::handle(cues) }.ok();
        let cue_sink = Maybe(cues.as_mut().map(|h| &mut h.cues));
        let tracker = Maybe(tracks.then_some(&mut extremes));
        // Width and stream state were checked: the push cannot fail.
        let pushed = stream.push(prev, next, &mut (sink, (tracker, cue_sink)));
        let finished = stream.is_finished();
        if finished && let Some(cues) = &mut cues {
            cues.end_frame();
        }
        // SAFETY: the same handle, checked above; the push's own use of it
        // ended (a callback's call saw `Busy` and returned).
        let instance = unsafe { engine_instance(handle) }?;
        instance.rows = rows;
        *instance.previous.tracker() = extremes;
        if finished {
            if tracks {
                instance.previous.end_frame();
            }
            instance.state = State::Idle(stream.into_engine());
        } else {
            instance.state = State::Streaming(stream);
        }
        pushed.map_err(rf_status::from)
    };
    ffi::status(push())
}

/// Abandon a stream in progress (none: nothing to do). Attached cues
/// forget the partial frame and their history (`rf_cues_reset`); the
/// previous-frame min-max keeps the last complete pair's scales.
///
/// # Safety
/// The engine is a handle from `rf_init`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_stream_cancel(engine: *mut rf_engine) -> rf_status {
    // SAFETY: the caller's contract.
    ffi::status(unsafe { engine_instance(engine) }.and_then(cancel))
}

/// Input rows the stream in progress has received (0 when none is).
///
/// # Safety
/// The engine is a handle from `rf_init`; `rows` is NULL (refused) or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_stream_rows_in(engine: *mut rf_engine, rows: *mut u32) -> rf_status {
    let count = || {
        // SAFETY: the caller's contract.
        let instance = unsafe { engine_instance(engine) }?;
        let n = match &instance.state {
            State::Streaming(stream) => stream.rows_in() as u32,
            _ => 0,
        };
        // SAFETY: the caller's contract.
        unsafe { ffi::write(rows, n) }
    };
    ffi::status(count())
}

/// End a stream in progress, if any, forgetting its partial frame.
pub(crate) fn cancel(instance: &mut Instance) -> Result<(), rf_status> {
    match instance.take_stream() {
        Ok(stream) => {
            instance.state = State::Idle(stream.into_engine());
            *instance.previous.tracker() = ExtremesSink::default();
            if let Some(mut cues) = instance.cues() {
                cues.reset();
            }
            Ok(())
        }
        Err(RF_ERR_NO_STREAM) => Ok(()),
        Err(e) => Err(e),
    }
}

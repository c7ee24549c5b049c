//! Motion cues for C: `reynoldsflow-cues`' `MotionCues` in the caller's
//! memory, on the smallest of three grids that covers the frame. Cells are
//! 16 px on every grid (as in the GStreamer element), so the regions do not
//! depend on which grid holds them.

use core::ffi::c_void;

use fixed::types::{U16F16, U32F32};
use reynoldsflow_core::{Config, Pixels, Sink};
use reynoldsflow_cues::{CueParams, Field, MotionCues, Region, Threshold, grid_cells};

use crate::config::{Settings, rf_config};
use crate::ffi;
use crate::memory::{Carver, aligned_start};
use crate::status::*;

/// Cell side of every grid, px.
const CELL: usize = 16;

/// Regions kept per frame, strongest first.
pub const RF_MAX_REGIONS: u32 = 8;
const REGIONS: usize = RF_MAX_REGIONS as usize;

/// Largest frame side the cues cover, px (the large grid's 128 cells).
pub const RF_CUES_MAX_SIDE: u32 = 2048;
const _: () = assert!(RF_CUES_MAX_SIDE as usize == CELL * 128);

/// Frames up to 320 × 240: 9.6 KB.
type Small = MotionCues<CELL, 20, 15, REGIONS>;
/// Frames up to 640 × 480: 38 KB.
type Medium = MotionCues<CELL, 40, 30, REGIONS>;
/// Frames up to 2048 × 2048: 512 KB.
type Large = MotionCues<CELL, 128, 128, REGIONS>;

/// Which magnitude the cues threshold.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum rf_cue_field {
    /// `|v_c|`: smooth, one compact blob per small mover (the default).
    RF_CUE_FIELD_CURL_FREE = 0,
    /// `|v_d|`.
    RF_CUE_FIELD_DIVERGENCE_FREE = 1,
}

/// When a pixel counts as moving: its magnitude strictly above the level.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum rf_cue_threshold {
    /// The level is `level` px.
    RF_CUE_ABSOLUTE = 0,
    /// `k` times the previous frames' (smoothed) mean magnitude, at least `level`.
    RF_CUE_MEAN_MULTIPLE = 1,
    /// `k` times the previous frames' (smoothed) peak magnitude, at least `level`.
    RF_CUE_PEAK_FRACTION = 2,
}

/// What the cues look for; `rf_cue_params_init` writes the defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
#[allow(non_camel_case_types)]
pub struct rf_cue_params {
    /// An `rf_cue_field`; default `RF_CUE_FIELD_CURL_FREE`.
    pub field: u32,
    /// An `rf_cue_threshold`; default `RF_CUE_ABSOLUTE`.
    pub threshold: u32,
    /// The absolute level, or the relative modes' smallest level, px
    /// (0 or more; saturates at 2^32); default 1.0.
    pub level: f64,
    /// The relative modes' multiple, in `[0, 65536)`; default 0.
    pub k: f64,
    /// Regions of fewer moving pixels are dropped; default 4.
    pub min_area: u32,
    /// The relative modes follow frames as `r += (x - r) / 2^smoothing`
    /// (0 to 63); default 0.
    pub smoothing: u32,
}

/// One region of moving pixels of the last completed frame. Coordinates
/// are frame pixels, inclusive; magnitudes are Q32.32 px (divide by 2^32).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub struct rf_region {
    /// Leftmost column.
    pub x_min: u16,
    /// Top row.
    pub y_min: u16,
    /// Rightmost column.
    pub x_max: u16,
    /// Bottom row.
    pub y_max: u16,
    /// Moving pixels.
    pub area: u32,
    /// Grid cells the region spans.
    pub cells: u32,
    /// Largest magnitude, Q32.32 px.
    pub peak_q32: u64,
    /// Mean magnitude, Q32.32 px.
    pub mean_q32: u64,
}

/// The last completed frame as a whole.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub struct rf_cue_frame {
    /// Pairs completed since `rf_cues_init` or `rf_cues_reset`.
    pub frames: u32,
    /// Pixels seen in the last frame.
    pub pixels: u32,
    /// Regions found (at least `min_area` px), kept or not.
    pub regions_found: u32,
    /// Regions kept (at most `RF_MAX_REGIONS`).
    pub regions_kept: u32,
    /// The level the frame was compared with, Q32.32 px.
    pub level_q32: u64,
    /// Mean magnitude over the frame, Q32.32 px.
    pub mean_q32: u64,
    /// Largest magnitude, Q32.32 px.
    pub peak_q32: u64,
}

/// A motion-cue state in caller memory (`rf_cues_init`).
#[allow(non_camel_case_types)]
pub struct rf_cues {
    _opaque: [u8; 0],
}

/// The defaults (what `rf_cue_params_init` writes): `|v_c|` above 1 px,
/// regions of 4 px or more, as the GStreamer element.
const DEFAULT_CUE_PARAMS: rf_cue_params = rf_cue_params {
    field: rf_cue_field::RF_CUE_FIELD_CURL_FREE as u32,
    threshold: rf_cue_threshold::RF_CUE_ABSOLUTE as u32,
    level: 1.0,
    k: 0.0,
    min_area: 4,
    smoothing: 0,
};

impl Default for rf_cue_params {
    fn default() -> Self {
        DEFAULT_CUE_PARAMS
    }
}

impl rf_cue_params {
    fn validated(&self) -> Result<CueParams, rf_status> {
        let field = match self.field {
            0 => Field::CurlFree,
            1 => Field::DivergenceFree,
            _ => return Err(RF_ERR_BAD_CUE_PARAMS),
        };
        if self.level.is_nan() || self.level < 0.0 {
            return Err(RF_ERR_BAD_CUE_PARAMS);
        }
        let level = U32F32::saturating_from_num(self.level);
        let k = || U16F16::checked_from_num(self.k).ok_or(RF_ERR_BAD_CUE_PARAMS);
        let threshold = match self.threshold {
            0 => Threshold::Absolute(level),
            1 => Threshold::MeanMultiple {
                k: k()?,
                floor: level,
            },
            2 => Threshold::PeakFraction {
                k: k()?,
                floor: level,
            },
            _ => return Err(RF_ERR_BAD_CUE_PARAMS),
        };
        let smoothing = u8::try_from(self.smoothing)
            .ok()
            .filter(|&s| s <= 63)
            .ok_or(RF_ERR_BAD_CUE_PARAMS)?;
        Ok(CueParams {
            field,
            threshold,
            min_area: self.min_area,
            smoothing,
        })
    }
}

/// Which grid a cue state holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
enum Grid {
    Small,
    Medium,
    Large,
}

impl Grid {
    /// The smallest grid that covers frames of `config`'s size.
    fn for_frame(config: &Config) -> Result<Self, rf_status> {
        let cells = (
            grid_cells(config.width(), CELL),
            grid_cells(config.height(), CELL),
        );
        Ok(match cells {
            (w, h) if w <= 20 && h <= 15 => Grid::Small,
            (w, h) if w <= 40 && h <= 30 => Grid::Medium,
            (w, h) if w <= 128 && h <= 128 => Grid::Large,
            _ => return Err(RF_ERR_CUES_FRAME_TOO_LARGE),
        })
    }

    /// The block's layout: the header, then the grid's cue state.
    fn carver(self) -> (Carver, usize) {
        let mut carver = Carver::after_header::<Header>();
        let offset = match self {
            Grid::Small => carver.array::<Small>(1),
            Grid::Medium => carver.array::<Medium>(1),
            Grid::Large => carver.array::<Large>(1),
        };
        // One value of at most 512 KB after a small header: no overflow.
        (carver, offset.unwrap_or(0))
    }
}

/// "RFCUES01": marks a block `rf_cues_init` set up.
const MAGIC: u64 = u64::from_le_bytes(*b"RFCUES01");

/// The start of a cue block.
#[repr(C)]
struct Header {
    magic: u64,
    frames: u32,
    width: u16,
    height: u16,
    grid: Grid,
    /// Offset of the cue state from the header.
    offset: u32,
}

/// The cue state of a handle, borrowed.
pub(crate) enum Cues<'a> {
    Small(&'a mut Small),
    Medium(&'a mut Medium),
    Large(&'a mut Large),
}

impl Cues<'_> {
    fn end_frame(&mut self) {
        match self {
            Cues::Small(c) => c.end_frame(),
            Cues::Medium(c) => c.end_frame(),
            Cues::Large(c) => c.end_frame(),
        };
    }

    fn reset(&mut self) {
        match self {
            Cues::Small(c) => c.reset(),
            Cues::Medium(c) => c.reset(),
            Cues::Large(c) => c.reset(),
        }
    }

    fn regions(&self) -> (&[Region], reynoldsflow_cues::FrameLevel) {
        match self {
            Cues::Small(c) => (c.regions(), *c.last_frame()),
            Cues::Medium(c) => (c.regions(), *c.last_frame()),
            Cues::Large(c) => (c.regions(), *c.last_frame()),
        }
    }
}

impl Sink for Cues<'_> {
    fn reads_fields(&self) -> bool {
        false
    }

    #[inline(always)]
    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        match self {
            Cues::Small(c) => c.row(y, x, pixels),
            Cues::Medium(c) => c.row(y, x, pixels),
            Cues::Large(c) => c.row(y, x, pixels),
        }
    }
}

/// A cue handle: its header and its state.
pub(crate) struct CueHandle<'a> {
    header: &'a mut Header,
    pub(crate) cues: Cues<'a>,
}

impl CueHandle<'_> {
    /// The frame size the cues were made for.
    pub(crate) fn size(&self) -> (usize, usize) {
        (
            usize::from(self.header.width),
            usize::from(self.header.height),
        )
    }

    /// A pair is complete: find its regions.
    pub(crate) fn end_frame(&mut self) {
        self.cues.end_frame();
        self.header.frames = self.header.frames.saturating_add(1);
    }

    /// Forget everything (a cancelled stream's pixels too).
    pub(crate) fn reset(&mut self) {
        self.cues.reset();
        self.header.frames = 0;
    }
}

/// The handle behind an `rf_cues` pointer.
///
/// # Safety
/// A non-NULL `cues` is a handle from `rf_cues_init` whose block is still
/// the library's, and no other reference to it is live.
pub(crate) unsafe fn handle<'a>(cues: *mut rf_cues) -> Result<CueHandle<'a>, rf_status> {
    if cues.is_null() {
        return Err(RF_ERR_NULL_POINTER);
    }
    if !(cues as usize).is_multiple_of(Carver::ALIGN) {
        return Err(RF_ERR_BAD_HANDLE);
    }
    let header = cues.cast::<Header>();
    // SAFETY: aligned and non-NULL; a block from `rf_cues_init` starts with
    // an initialised header (the caller's contract). The magic is read
    // before any reference to the header exists.
    if unsafe { (&raw const (*header).magic).read() } != MAGIC {
        return Err(RF_ERR_BAD_HANDLE);
    }
    // SAFETY: an initialised header, the handle's alone (contract).
    let header = unsafe { &mut *header };
    // SAFETY: `rf_cues_init` wrote a state of this grid at this offset.
    let state = unsafe { cues.cast::<u8>().add(header.offset as usize) };
    // SAFETY (each arm): the header's grid names the type written there.
    let cues = match header.grid {
        // SAFETY: see above.
        Grid::Small => Cues::Small(unsafe { &mut *state.cast::<Small>() }),
        // SAFETY: see above.
        Grid::Medium => Cues::Medium(unsafe { &mut *state.cast::<Medium>() }),
        // SAFETY: see above.
        Grid::Large => Cues::Large(unsafe { &mut *state.cast::<Large>() }),
    };
    Ok(CueHandle { header, cues })
}

/// Write the default cue parameters (`|v_c|` above 1 px, regions of at
/// least 4 px).
///
/// # Safety
/// `params` is NULL (refused) or points to writable memory for one
/// `rf_cue_params`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_cue_params_init(params: *mut rf_cue_params) -> rf_status {
    // SAFETY: the caller's contract.
    ffi::status(unsafe { ffi::write(params, DEFAULT_CUE_PARAMS) })
}

/// Bytes of memory `rf_cues_init` needs for frames of `config`'s size
/// (any alignment; about 9.6 KB up to 320 × 240, 38 KB up to 640 × 480,
/// 512 KB up to 2048 × 2048).
///
/// # Safety
/// `config` and `bytes` are NULL (refused) or valid pointers.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_cues_size(config: *const rf_config, bytes: *mut usize) -> rf_status {
    let size = || {
        // SAFETY: the caller's contract.
        let settings = Settings::new(&unsafe { ffi::read(config) }?)?;
        let (carver, _) = Grid::for_frame(&settings.config)?.carver();
        carver.bytes().ok_or(RF_ERR_FRAME_TOO_LARGE)
    };
    // SAFETY: the caller's contract.
    ffi::status(size().and_then(|n| unsafe { ffi::write(bytes, n) }))
}

/// Set up motion cues for frames of `config`'s size in `memory`
/// (`memory_len` bytes, at least `rf_cues_size`'s), and store the handle
/// in `*cues`. The memory is the library's until it is reused; the handle
/// points into it. Attach the cues to an engine with `rf_attach_cues`.
///
/// # Safety
/// `memory` points to `memory_len` writable bytes that nothing else uses
/// while the handle is in use; the other pointers are NULL (refused) or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_cues_init(
    memory: *mut c_void,
    memory_len: usize,
    config: *const rf_config,
    params: *const rf_cue_params,
    cues: *mut *mut rf_cues,
) -> rf_status {
    let init = || {
        if memory.is_null() || cues.is_null() {
            return Err(RF_ERR_NULL_POINTER);
        }
        // SAFETY: the caller's contract.
        let settings = Settings::new(&unsafe { ffi::read(config) }?)?;
        // SAFETY: the caller's contract.
        let params = unsafe { ffi::read(params) }?.validated()?;
        let config = settings.config;
        let grid = Grid::for_frame(&config)?;
        let (carver, offset) = grid.carver();
        let start = aligned_start(memory.cast(), memory_len, carver.end())
            .ok_or(RF_ERR_BUFFER_TOO_SHORT)?;
        // SAFETY: `start` is aligned to 8 and the block holds the header and
        // the state at `offset` (`aligned_start` checked the span); the
        // block is the library's from here on (contract). Every write goes
        // through raw pointers: no reference to uninitialised memory.
        unsafe {
            let state = start.add(offset);
            let result = match grid {
                Grid::Small => Small::new(&config, params).map(|c| state.cast::<Small>().write(c)),
                Grid::Medium => {
                    Medium::new(&config, params).map(|c| state.cast::<Medium>().write(c))
                }
                Grid::Large => Large::new(&config, params).map(|c| state.cast::<Large>().write(c)),
            };
            // The grid was chosen to cover the frame.
            result.map_err(|_| RF_ERR_CUES_FRAME_TOO_LARGE)?;
            start.cast::<Header>().write(Header {
                magic: MAGIC,
                frames: 0,
                width: config.width() as u16,
                height: config.height() as u16,
                grid,
                offset: offset as u32,
            });
            ffi::write(cues, start.cast::<rf_cues>())
        }
    };
    ffi::status(init())
}

/// Forget the frames seen: the relative levels start again.
///
/// # Safety
/// `cues` is NULL (refused) or a handle from `rf_cues_init`, not in use by a
/// call of another thread.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_cues_reset(cues: *mut rf_cues) -> rf_status {
    // SAFETY: the caller's contract.
    ffi::status(unsafe { handle(cues) }.map(|mut h| h.reset()))
}

/// The regions of the last completed pair, strongest first: up to
/// `capacity` of them into `regions` (NULL with `capacity` 0 to ask only
/// for the frame), their number in `*count`, the frame's figures in `*frame`
/// (NULL: not wanted).
///
/// # Safety
/// `cues` is NULL (refused) or a handle from `rf_cues_init`; `regions`
/// holds `capacity` writable `rf_region`s; `count` and `frame` are NULL
/// or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rf_cues_result(
    cues: *mut rf_cues,
    regions: *mut rf_region,
    capacity: usize,
    count: *mut usize,
    frame: *mut rf_cue_frame,
) -> rf_status {
    let result = || {
        // SAFETY: the caller's contract.
        let handle = unsafe { handle(cues) }?;
        // SAFETY: the caller's contract.
        let out = unsafe { ffi::optional_mut(regions, capacity) }?;
        if count.is_null() {
            return Err(RF_ERR_NULL_POINTER);
        }
        let (kept, level) = handle.cues.regions();
        let out = out.unwrap_or(&mut []);
        for (o, r) in out.iter_mut().zip(kept) {
            *o = rf_region {
                x_min: r.x_min,
                y_min: r.y_min,
                x_max: r.x_max,
                y_max: r.y_max,
                area: r.area,
                cells: u32::from(r.cells),
                peak_q32: r.peak.to_bits(),
                mean_q32: r.mean.to_bits(),
            };
        }
        let written = out.len().min(kept.len());
        // SAFETY: the caller's contract.
        unsafe { ffi::write(count, written) }?;
        if !frame.is_null() {
            let summary = rf_cue_frame {
                frames: handle.header.frames,
                pixels: level.pixels,
                regions_found: level.regions_found,
                regions_kept: kept.len() as u32,
                level_q32: level.level.to_bits(),
                mean_q32: level.mean.to_bits(),
                peak_q32: level.peak.to_bits(),
            };
            // SAFETY: the caller's contract.
            unsafe { ffi::write(frame, summary) }?;
        }
        Ok(())
    };
    ffi::status(result())
}

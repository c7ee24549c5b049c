//! Motion cues: where in the frame something moves, as a short list of
//! regions with a pixel-exact bounding box, area, peak and mean magnitude,
//! found in the same pass as the engine (a [`Sink`], so it composes with the
//! RGB sink as `(rgb, &mut cues)`) with memory fixed at compile time.
//!
//! # Why a grid, and what "connected" means here
//!
//! With tiles the sink receives row segments tile after tile, not in raster
//! order, so a raster-order one-pass labeller would give results that depend
//! on the tiling. Instead every pixel whose magnitude is above the threshold
//! is accumulated into its cell of a `CELL × CELL` grid (`GW × GH` cells),
//! and each cell keeps statistics whose update is commutative: the pixel
//! count, the pixel-exact bounding box, the peak and the sum. Whatever order
//! the rows arrive in, every cell ends the frame with the same numbers. At
//! [`MotionCues::end_frame`] the regions are the **8-connected components of
//! occupied cells** (a cell is occupied when at least one of its pixels is
//! above the threshold), each with the union of its cells' statistics.
//!
//! So, for above-threshold pixels:
//! - two pixels 8-adjacent to each other are always in one region (they lie
//!   in the same or in 8-adjacent cells): a region is a union of whole
//!   pixel-level 8-connected components;
//! - pixels in the same cell are in one region even when they do not touch,
//!   and so are pixels of 8-adjacent cells: gaps narrower than one cell may
//!   be bridged, gaps of a whole empty cell (≥ `CELL` px in x or y) never are;
//! - boxes, areas, peaks and means are those of the region's pixels exactly,
//!   not of its cells.
//!
//! The result is identical for every tiling and every strip split of the
//! engine, bit for bit (tested in the demo crate's `cues` tests).
//!
//! # Choosing the field and the level
//!
//! Measured on the demo's scenes (`examples/demo/tests`): `|v_c|` suits
//! small movers best; it is smooth, so a 5 × 3 px drone gives one compact
//! blob whose box lies within 2 px of the true one. `|v_d|` is dominated by
//! sensor noise on flat or textured background (SPEC §7). A level relative
//! to the peak always finds the frame's strongest response, whatever it is,
//! so give it a `floor`; a level relative to the mean follows a global gain
//! change of the lighting. A moving light is motion of light: every mode
//! reports a bright, fast one.
//!
//! # Numbers and bounds
//!
//! - Magnitudes arrive as the engine's `f32` pixels (non-negative and
//!   finite). The sink compares and accumulates them in its own integer
//!   format, `U32F32`: each magnitude is taken as `⌊m · 2³²⌋ / 2³²` in one
//!   place (`magnitude_bits`), exact for every `f32` from `2⁻⁹` px to
//!   below `2³²` px, truncated to a multiple of `2⁻³²` px below `2⁻⁹`,
//!   saturated at `U32F32::MAX` from `2³²` px; a NaN or a negative value
//!   (never the engine's) is 0, so it never counts as moving. Levels and
//!   peaks are exact in that format, so the cues are integer arithmetic
//!   from there on, the same on every target.
//! - Sums are of those magnitudes **truncated to Q16.16** (`bits >> 16`, each
//!   below `2⁴⁸`), in `u64`: a cell, a region and the whole frame hold at
//!   most `65535² < 2^32` pixels, so a sum of magnitudes below `2¹⁶` px
//!   stays below `2^64` and is exact (`|v_c|` is always below `2¹⁴` px:
//!   `|V| < 2^23.5` and `s ≤ 1`); a larger sum saturates at `u64::MAX`.
//!   A mean is `⌊sum / count⌋` in Q16.16, returned as `U32F32`: the mean of
//!   the magnitudes within `2^-16` px.
//! - Counts are `u32` (a frame has fewer than `2^32` pixels); coordinates
//!   `u16` ([`MAX_SIDE`](reynoldsflow_core::MAX_SIDE)). Accumulators saturate if the sink
//!   is fed more pixels than a frame holds, so nothing overflows or panics.
//!
//! # Memory
//!
//! `32 · GW · GH` bytes of cells, `N · size_of::<Region>()` (32 bytes each)
//! for the regions kept, and about 120 bytes of frame state:
//! [`MotionCues::WORKING_BYTES`]. For a 320 × 240 frame, 16-px cells
//! (20 × 15) take 9.6 KiB and 8-px cells (40 × 30) 38.4 KiB.
//!
//! # Cost
//!
//! Per pixel: one compare, one shift-add and a max for the frame's level,
//! and for pixels above the threshold an add, a max and two min/max of the
//! run that is merged into its cell once per cell-wide run. At the end of a
//! frame: three passes over the cells (union–find with path halving) and an
//! insertion into the sorted list of at most `N` regions per region.

use core::fmt;

use fixed::types::{U16F16, U32F32};
use heapless::Vec;

use reynoldsflow_core::{Config, FlowPixel, Pixels, Sink};

/// Which of the representation's two fields a cue or a view reads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Field {
    /// The divergence-free field `v_d` and `|v_d|` (the representation's R).
    #[default]
    DivergenceFree,
    /// The curl-free field `v_c` and `|v_c|` (the representation's G).
    CurlFree,
}

impl Field {
    /// The field's magnitude at a pixel (`m_d` or `m_c`), px, as the
    /// engine gives it (the cues compare it in their `U32F32`: module doc).
    #[inline(always)]
    pub fn magnitude(self, px: &FlowPixel) -> f32 {
        match self {
            Field::DivergenceFree => px.m_d,
            Field::CurlFree => px.m_c,
        }
    }

    /// The field's vector at a pixel (`v_d` or `v_c`), px, y down.
    #[inline(always)]
    pub fn vector(self, px: &FlowPixel) -> [f32; 2] {
        match self {
            Field::DivergenceFree => px.v_d,
            Field::CurlFree => px.v_c,
        }
    }
}

/// When a pixel counts as moving: its magnitude is strictly **above** the
/// frame's level (so a zero magnitude never counts).
///
/// The relative modes take their reference from the frames already
/// completed (so they stream: the level is known before the first pixel
/// arrives): the frame mean or peak, smoothed over frames as
/// [`CueParams::smoothing`] says. Before the first
/// [`MotionCues::end_frame`] the reference is 0 and the level is `floor`.
/// The level is `max(floor, ⌊k · reference⌋)`, saturating at `U32F32::MAX`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Threshold {
    /// A fixed magnitude, px.
    Absolute(U32F32),
    /// `k` times the previous frame's mean magnitude (over every pixel).
    MeanMultiple {
        /// The multiple.
        k: U16F16,
        /// The smallest level, px.
        floor: U32F32,
    },
    /// `k` times the previous frame's peak magnitude (`k < 1` to be useful).
    PeakFraction {
        /// The fraction.
        k: U16F16,
        /// The smallest level, px.
        floor: U32F32,
    },
}

/// What the cues look for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CueParams {
    /// The magnitude thresholded.
    pub field: Field,
    /// The level a magnitude must exceed.
    pub threshold: Threshold,
    /// Regions of fewer above-threshold pixels are dropped (not counted,
    /// not kept). 0 and 1 keep every region.
    pub min_area: u32,
    /// How the relative modes' reference follows the frames: after each
    /// frame `r ← r + (x − r) / 2^smoothing`, in exact integers (the
    /// difference shifted right, toward the old reference), where `x` is the
    /// frame's mean or peak and the first frame sets `r = x`. 0 uses the last
    /// frame alone; 1 weighs it ½, 2 weighs it ¼ (an exponential average).
    /// A frame's peak varies with the speed of what moves; smoothing it
    /// keeps the level, and so the boxes, steadier (the demo uses 1).
    /// Capped at 63.
    pub smoothing: u8,
}

/// Why a [`MotionCues`] was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CueError {
    /// The grid does not cover the frame: it needs at least this many cells.
    GridTooSmall {
        /// Cells needed across (`⌈width / CELL⌉`).
        columns: usize,
        /// Cells needed down (`⌈height / CELL⌉`).
        rows: usize,
    },
}

impl fmt::Display for CueError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CueError::GridTooSmall { columns, rows } => write!(
                f,
                "motion-cue grid too small: the frame needs {columns} x {rows} cells"
            ),
        }
    }
}

impl core::error::Error for CueError {}

/// Cells a grid needs along a side of `pixels` for cells of `cell` px
/// (`⌈pixels / cell⌉`), for choosing `GW` and `GH` in a `const`.
pub const fn grid_cells(pixels: usize, cell: usize) -> usize {
    pixels.div_ceil(cell)
}

/// One region of moving pixels. Coordinates are frame pixels, inclusive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Region {
    /// Leftmost column of an above-threshold pixel.
    pub x_min: u16,
    /// Top row.
    pub y_min: u16,
    /// Rightmost column (inclusive).
    pub x_max: u16,
    /// Bottom row (inclusive).
    pub y_max: u16,
    /// Above-threshold pixels (not the box's area).
    pub area: u32,
    /// Occupied grid cells the region spans.
    pub cells: u16,
    /// Largest magnitude, px (exact).
    pub peak: U32F32,
    /// Mean magnitude of the region's pixels, px (within 2⁻¹⁶, see module).
    pub mean: U32F32,
}

impl Region {
    /// Box width, px.
    pub const fn width(&self) -> u16 {
        self.x_max.saturating_sub(self.x_min).saturating_add(1)
    }

    /// Box height, px.
    pub const fn height(&self) -> u16 {
        self.y_max.saturating_sub(self.y_min).saturating_add(1)
    }

    /// The order in which regions are kept: higher peak first, then larger
    /// area, then higher mean, then top-to-bottom, left-to-right.
    fn stronger_than(&self, other: &Region) -> bool {
        let key = |r: &Region| {
            (
                core::cmp::Reverse(r.peak),
                core::cmp::Reverse(r.area),
                core::cmp::Reverse(r.mean),
                r.y_min,
                r.x_min,
                r.y_max,
                r.x_max,
            )
        };
        key(self) < key(other)
    }
}

/// What a completed frame looked like as a whole.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrameLevel {
    /// The level the frame's pixels were compared with, px.
    pub level: U32F32,
    /// Mean magnitude over every pixel the sink saw, px (within 2⁻¹⁶).
    pub mean: U32F32,
    /// Largest magnitude seen, px.
    pub peak: U32F32,
    /// Pixels seen.
    pub pixels: u32,
    /// Regions found (at least `min_area` pixels), kept or not.
    pub regions_found: u32,
}

/// The relative modes' reference: smoothed frame mean and peak, `U32F32`
/// bits (module doc of [`CueParams::smoothing`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Reference {
    mean: u64,
    peak: u64,
    /// Whether a frame has been completed since the start or a reset.
    set: bool,
}

/// `r + (x − r) / 2^s` rounded toward `r`, in u64 without overflow.
fn follow(r: u64, x: u64, s: u8) -> u64 {
    let s = u32::from(s.min(63));
    if x >= r {
        r + ((x - r) >> s)
    } else {
        r - ((r - x) >> s)
    }
}

/// Exact statistics of the above-threshold pixels of one cell (then, at the
/// end of a frame, of a region whose root the cell is). 32 bytes.
#[derive(Clone, Copy, Debug)]
struct Cell {
    /// Σ ⌊m · 2¹⁶⌋ (saturating; exact below 2⁶⁴, module doc).
    sum: u64,
    /// Largest magnitude, `U32F32` bits.
    peak: u64,
    /// Above-threshold pixels.
    count: u32,
    x_min: u16,
    y_min: u16,
    x_max: u16,
    y_max: u16,
    /// Union–find parent (flat cell index, ≤ own index); end of frame only.
    parent: u16,
    /// Occupied cells merged into this root; end of frame only.
    cells: u16,
}

impl Cell {
    const EMPTY: Self = Self {
        sum: 0,
        peak: 0,
        count: 0,
        x_min: u16::MAX,
        y_min: u16::MAX,
        x_max: 0,
        y_max: 0,
        parent: 0,
        cells: 0,
    };

    const fn occupied(&self) -> bool {
        self.count > 0
    }

    /// Take the statistics of another cell (or run) into this one.
    fn merge(&mut self, other: &Cell) {
        self.sum = self.sum.saturating_add(other.sum);
        self.peak = self.peak.max(other.peak);
        self.count = self.count.saturating_add(other.count);
        self.x_min = self.x_min.min(other.x_min);
        self.y_min = self.y_min.min(other.y_min);
        self.x_max = self.x_max.max(other.x_max);
        self.y_max = self.y_max.max(other.y_max);
        self.cells = self.cells.saturating_add(other.cells);
    }

    fn region(&self) -> Region {
        let mean_q16 = self.sum.checked_div(u64::from(self.count)).unwrap_or(0);
        Region {
            x_min: self.x_min,
            y_min: self.y_min,
            x_max: self.x_max,
            y_max: self.y_max,
            area: self.count,
            cells: self.cells,
            peak: U32F32::from_bits(self.peak),
            // The mean is at most the largest term, below 2⁴⁸ (module doc),
            // so << 16 does not overflow.
            mean: U32F32::from_bits(mean_q16 << 16),
        }
    }
}

/// The motion-cue sink: a `GW × GH` grid of `CELL × CELL`-px cells and the
/// `N` strongest regions of the last completed frame (module doc).
///
/// Use: build once per frame size, feed it every pixel of a frame through
/// the engine (alone or in a tuple with other sinks), then call
/// [`end_frame`](Self::end_frame), which returns the regions and prepares
/// the next frame.
///
/// ```
/// use reynoldsflow_core::fixed::types::U32F32;
/// use reynoldsflow_core::{Config, Engine, FramePair, Params, Plan};
/// use reynoldsflow_cues::{CueParams, Field, MotionCues, Threshold, grid_cells};
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// const W: usize = 48;
/// const H: usize = 32;
/// const CELL: usize = 8;
/// // A dark 4×4 square moving 2 px right over flat gray.
/// let frame = |x0: usize| -> Vec<u8> {
///     (0..W * H)
///         .map(|i| if (x0..x0 + 4).contains(&(i % W)) && (12..16).contains(&(i / W)) { 30 } else { 160 })
///         .collect()
/// };
/// let (prev, next) = (frame(20), frame(22));
///
/// let config = Config::new(W, H, Params::DEFAULT)?;
/// let params = CueParams {
///     field: Field::CurlFree,
///     threshold: Threshold::Absolute(U32F32::from_num(1)),
///     min_area: 1,
///     smoothing: 0,
/// };
/// let mut cues =
///     MotionCues::<CELL, { grid_cells(W, CELL) }, { grid_cells(H, CELL) }, 4>::new(&config, params)?;
/// let mut engine = Engine::<30>::new(); // 16-px tiles
/// let plan = Plan::new(config, 16, 16)?;
/// engine.run(&plan.bind(FramePair::packed(&config, &prev, &next)?)?, &mut cues);
/// let regions = cues.end_frame();
/// assert_eq!(regions.len(), 1);
/// let r = regions[0];
/// // Around the square's old and new places (columns 20–25, rows 12–15).
/// assert!(r.x_min <= 20 && r.x_max >= 25 && r.y_min <= 12 && r.y_max >= 15);
/// # Ok(()) }
/// ```
pub struct MotionCues<const CELL: usize, const GW: usize, const GH: usize, const N: usize> {
    cells: [[Cell; GW]; GH],
    regions: Vec<Region, N>,
    params: CueParams,
    /// This frame's level, `U32F32` bits.
    level: u64,
    /// Σ ⌊m · 2¹⁶⌋ over every pixel seen this frame (saturating, module doc).
    frame_sum: u64,
    /// Largest magnitude seen this frame, bits.
    frame_peak: u64,
    frame_pixels: u32,
    last: FrameLevel,
    reference: Reference,
}

impl<const CELL: usize, const GW: usize, const GH: usize, const N: usize>
    MotionCues<CELL, GW, GH, N>
{
    /// Bytes of memory the sink owns (`32 · GW · GH` for the cells, 32 per
    /// region kept, and the frame state).
    pub const WORKING_BYTES: usize = core::mem::size_of::<Self>();

    const CHECKS: () = {
        assert!(CELL >= 1, "cells need at least one pixel");
        assert!(GW >= 1 && GH >= 1, "the grid needs at least one cell");
        assert!(
            GW * GH <= u16::MAX as usize + 1,
            "at most 65536 cells (indices are u16)"
        );
        assert!(N >= 1, "keep at least one region");
    };

    /// A sink for frames of `config`'s size; fails when `GW × GH` cells of
    /// `CELL` px do not cover the frame.
    pub fn new(config: &Config, params: CueParams) -> Result<Self, CueError> {
        let () = Self::CHECKS;
        let (columns, rows) = (
            grid_cells(config.width(), CELL),
            grid_cells(config.height(), CELL),
        );
        if columns > GW || rows > GH {
            return Err(CueError::GridTooSmall { columns, rows });
        }
        let mut cues = Self {
            cells: [[Cell::EMPTY; GW]; GH],
            regions: Vec::new(),
            params,
            level: 0,
            frame_sum: 0,
            frame_peak: 0,
            frame_pixels: 0,
            last: FrameLevel::default(),
            reference: Reference::default(),
        };
        cues.level = cues.next_level();
        Ok(cues)
    }

    /// The parameters in use.
    pub const fn params(&self) -> &CueParams {
        &self.params
    }

    /// Change the parameters, between frames: the level is recomputed at
    /// once (the relative modes keep their reference, the smoothed
    /// statistics of the frames completed so far).
    pub fn set_params(&mut self, params: CueParams) {
        self.params = params;
        self.level = self.next_level();
    }

    /// The level the current frame's magnitudes are compared with.
    pub fn level(&self) -> U32F32 {
        U32F32::from_bits(self.level)
    }

    /// The strongest regions of the last completed frame, strongest first.
    pub fn regions(&self) -> &[Region] {
        &self.regions
    }

    /// The last completed frame's level, mean, peak and region count.
    pub const fn last_frame(&self) -> &FrameLevel {
        &self.last
    }

    /// Forget the current frame's pixels and the relative modes' reference
    /// (as if just built).
    pub fn reset(&mut self) {
        // Cell by cell: no grid-sized temporary on the stack.
        self.cells.as_flattened_mut().fill(Cell::EMPTY);
        self.regions.clear();
        self.frame_sum = 0;
        self.frame_peak = 0;
        self.frame_pixels = 0;
        self.last = FrameLevel::default();
        self.reference = Reference::default();
        self.level = self.next_level();
    }

    /// The level for the next frame, from the last completed one.
    fn next_level(&self) -> u64 {
        let (k, floor, reference) = match self.params.threshold {
            Threshold::Absolute(level) => return level.to_bits(),
            Threshold::MeanMultiple { k, floor } => (k, floor, self.reference.mean),
            Threshold::PeakFraction { k, floor } => (k, floor, self.reference.peak),
        };
        mul_q16(reference, k.to_bits()).max(floor.to_bits())
    }

    /// The frame is complete: find its regions (returned, strongest first,
    /// at most `N`), set the next frame's level, and clear the grid.
    pub fn end_frame(&mut self) -> &[Region] {
        let found = self.label_and_collect();
        let mean_q16 = self
            .frame_sum
            .checked_div(u64::from(self.frame_pixels))
            .unwrap_or(0);
        self.last = FrameLevel {
            level: U32F32::from_bits(self.level),
            mean: U32F32::from_bits(mean_q16 << 16),
            peak: U32F32::from_bits(self.frame_peak),
            pixels: self.frame_pixels,
            regions_found: found,
        };
        let (mean, peak) = (self.last.mean.to_bits(), self.last.peak.to_bits());
        self.reference = match self.reference {
            Reference { set: false, .. } => Reference {
                mean,
                peak,
                set: true,
            },
            r => Reference {
                mean: follow(r.mean, mean, self.params.smoothing),
                peak: follow(r.peak, peak, self.params.smoothing),
                set: true,
            },
        };
        self.frame_sum = 0;
        self.frame_peak = 0;
        self.frame_pixels = 0;
        self.level = self.next_level();
        &self.regions
    }

    /// Label the occupied cells' 8-connected components, keep the strongest
    /// `N` regions, clear the grid; returns the number of regions found.
    fn label_and_collect(&mut self) -> u32 {
        self.regions.clear();
        let cells = self.cells.as_flattened_mut();
        // 1. Union–find in raster order with the W, NW, N, NE neighbours.
        //    The root of a set is its smallest index, so parent ≤ index.
        for i in 0..cells.len() {
            let Some(cell) = cells.get_mut(i) else { break };
            if !cell.occupied() {
                continue;
            }
            cell.parent = i as u16;
            cell.cells = 1;
            let (cx, cy) = (i % GW, i / GW);
            let neighbours = [
                (cx > 0).then(|| i - 1),
                (cx > 0 && cy > 0).then(|| i - GW - 1),
                (cy > 0).then(|| i - GW),
                (cx + 1 < GW && cy > 0).then(|| i - GW + 1),
            ];
            for j in neighbours.into_iter().flatten() {
                if cells.get(j).is_some_and(Cell::occupied) {
                    union(cells, i, j);
                }
            }
        }
        // 2. Point every cell straight at its root (parents come first), and
        //    3. merge each cell's statistics into its root.
        for i in 0..cells.len() {
            let Some(&cell) = cells.get(i) else { break };
            if !cell.occupied() {
                continue;
            }
            let parent = usize::from(cell.parent);
            let root = cells.get(parent).map_or(i, |p| usize::from(p.parent));
            if root == i {
                continue;
            }
            if let Some(c) = cells.get_mut(i) {
                c.parent = root as u16;
            }
            if let Some(r) = cells.get_mut(root) {
                r.merge(&cell);
            }
        }
        // 4. Roots are regions; keep the strongest.
        let mut found = 0u32;
        let min_area = self.params.min_area;
        for (i, cell) in cells.iter_mut().enumerate() {
            if cell.occupied() && usize::from(cell.parent) == i && cell.count >= min_area {
                found = found.saturating_add(1);
                keep_strongest(&mut self.regions, cell.region());
            }
            *cell = Cell::EMPTY;
        }
        found
    }

    /// Accumulate one row segment's magnitudes.
    #[inline(always)]
    fn accumulate(&mut self, y: usize, x: usize, magnitudes: &[f32]) {
        let level = self.level;
        let mut row = self.cells.get_mut(y / CELL);
        let (mut seg_sum, mut seg_peak) = (0u64, 0u64);
        let mut rest = magnitudes;
        let mut x0 = x;
        while !rest.is_empty() {
            // The run of `rest` inside cell column x0 / CELL.
            let run_len = (CELL - x0 % CELL).min(rest.len());
            let Some((run, tail)) = rest.split_at_checked(run_len) else {
                break;
            };
            let mut acc = Cell::EMPTY;
            for (k, &m) in run.iter().enumerate() {
                let m = magnitude_bits(m);
                // m >> 16 < 2⁴⁸: a row of ≤ 65535 px sums below 2⁶⁴ (and
                // saturates for any other input).
                seg_sum = seg_sum.saturating_add(m >> 16);
                seg_peak = seg_peak.max(m);
                if m > level {
                    acc.sum = acc.sum.saturating_add(m >> 16);
                    acc.peak = acc.peak.max(m);
                    acc.count = acc.count.saturating_add(1);
                    let xk = (x0 + k) as u16;
                    acc.x_min = acc.x_min.min(xk);
                    acc.x_max = acc.x_max.max(xk);
                }
            }
            if acc.occupied() {
                acc.y_min = y as u16;
                acc.y_max = y as u16;
                if let Some(cell) = row.as_mut().and_then(|r| r.get_mut(x0 / CELL)) {
                    cell.merge(&acc);
                }
            }
            rest = tail;
            x0 += run_len;
        }
        self.frame_sum = self.frame_sum.saturating_add(seg_sum);
        self.frame_peak = self.frame_peak.max(seg_peak);
        self.frame_pixels = self
            .frame_pixels
            .saturating_add(u32::try_from(magnitudes.len()).unwrap_or(u32::MAX));
    }
}

impl<const CELL: usize, const GW: usize, const GH: usize, const N: usize> Sink
    for MotionCues<CELL, GW, GH, N>
{
    // Magnitudes only: the engine skips the fields' conversions.
    fn reads_fields(&self) -> bool {
        false
    }

    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        match self.params.field {
            Field::DivergenceFree => self.accumulate(y, x, pixels.m_d),
            Field::CurlFree => self.accumulate(y, x, pixels.m_c),
        }
    }
}

/// An engine magnitude (`f32` px) as the cues' `U32F32` bits: `⌊m · 2³²⌋`,
/// saturating (module doc). The one place where the engine's `f32` enters
/// the cues' integers.
///
/// `m · 2³²` is exact in `f32` (a power-of-two scale; it overflows to `+∞`
/// only beyond `2⁹⁶` px), and Rust's `as` truncates toward zero, saturates
/// at 0 and `u64::MAX` (`U32F32::MAX`'s bits) and takes NaN to 0: defined
/// for every input, without a panic (`U32F32::saturating_from_num` would
/// round to nearest instead, and panics on NaN).
#[inline(always)]
fn magnitude_bits(m: f32) -> u64 {
    (m * 4_294_967_296.0) as u64
}

/// `⌊a · k / 2¹⁶⌋` for a `U32F32` `a` and a `U16F16` `k`, saturating at
/// `u64::MAX`, without a 128-bit product.
fn mul_q16(a: u64, k: u32) -> u64 {
    let (hi, lo) = (a >> 32, a & 0xFFFF_FFFF);
    let k = u64::from(k);
    // a·k/2¹⁶ = hi·k·2¹⁶ + lo·k/2¹⁶; both products fit u64 (32 × 32 bits).
    let high = (hi * k).saturating_mul(1 << 16);
    high.saturating_add((lo * k) >> 16)
}

/// The root of cell `i` (path halving: parents only move to smaller indices).
fn find(cells: &mut [Cell], mut i: usize) -> usize {
    loop {
        let Some(parent) = cells.get(i).map(|c| usize::from(c.parent)) else {
            return i;
        };
        if parent == i {
            return i;
        }
        let grand = cells.get(parent).map_or(parent, |c| usize::from(c.parent));
        if let Some(c) = cells.get_mut(i) {
            c.parent = grand as u16;
        }
        i = grand;
    }
}

/// Join the sets of cells `i` and `j`; the smaller root becomes the root.
fn union(cells: &mut [Cell], i: usize, j: usize) {
    let (a, b) = (find(cells, i), find(cells, j));
    let (root, child) = (a.min(b), a.max(b));
    if let Some(c) = cells.get_mut(child) {
        c.parent = root as u16;
    }
}

/// Insert `region` into `list` (strongest first) if it is among the `N`
/// strongest; ties keep the earlier region (raster order of roots).
fn keep_strongest<const N: usize>(list: &mut Vec<Region, N>, region: Region) {
    let at = list
        .iter()
        .position(|r| region.stronger_than(r))
        .unwrap_or(list.len());
    if at >= N {
        return;
    }
    if list.is_full() {
        list.pop();
    }
    // Room was made above, so the insertion cannot fail.
    let _ = list.insert(at, region);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rows::Rows;
    use reynoldsflow_core::Params;
    use std::vec::Vec as StdVec;

    /// A pixel of `|v_d| = m`, `|v_c| = m / 2` (the tests' values are exact
    /// in `f32`).
    fn px(m: f64) -> FlowPixel {
        FlowPixel {
            m_d: m as f32,
            m_c: (m / 2.0) as f32,
            ..FlowPixel::default()
        }
    }

    fn absolute(level: f64) -> CueParams {
        CueParams {
            field: Field::DivergenceFree,
            threshold: Threshold::Absolute(U32F32::from_num(level)),
            min_area: 1,
            smoothing: 0,
        }
    }

    /// Feed a `w × h` magnitude image as `tw × th` tiles in row-major tile
    /// order (top to bottom within each), like the engine.
    fn feed<const C: usize, const GW: usize, const GH: usize, const N: usize>(
        cues: &mut MotionCues<C, GW, GH, N>,
        image: &[f64],
        w: usize,
        (tw, th): (usize, usize),
    ) {
        let h = image.len() / w;
        for ty in (0..h).step_by(th) {
            for tx in (0..w).step_by(tw) {
                for y in ty..(ty + th).min(h) {
                    let row: StdVec<FlowPixel> = (tx..(tx + tw).min(w))
                        .map(|x| px(image[y * w + x]))
                        .collect();
                    cues.row(y, tx, Rows::of(&row).pixels());
                }
            }
        }
    }

    fn image(w: usize, h: usize, blobs: &[(usize, usize, usize, usize, f64)]) -> StdVec<f64> {
        let mut img = std::vec![0.0; w * h];
        for &(x0, y0, bw, bh, m) in blobs {
            for y in y0..y0 + bh {
                for x in x0..x0 + bw {
                    img[y * w + x] = m;
                }
            }
        }
        img
    }

    #[test]
    fn grid_must_cover_the_frame() {
        let config = Config::new(33, 16, Params::DEFAULT).unwrap();
        let too_small = MotionCues::<8, 4, 2, 4>::new(&config, absolute(1.0));
        assert_eq!(
            too_small.err(),
            Some(CueError::GridTooSmall {
                columns: 5,
                rows: 2
            })
        );
        assert!(MotionCues::<8, 5, 2, 4>::new(&config, absolute(1.0)).is_ok());
        assert!(MotionCues::<8, 9, 9, 4>::new(&config, absolute(1.0)).is_ok());
        assert_eq!(grid_cells(33, 8), 5);
        assert_eq!(grid_cells(32, 8), 4);
    }

    #[test]
    fn one_blob_has_exact_statistics() {
        let (w, h) = (40, 30);
        let mut img = image(w, h, &[(13, 7, 5, 3, 2.0)]);
        img[8 * w + 15] = 3.5;
        img[0] = 0.5; // below the level
        let config = Config::new(w, h, Params::DEFAULT).unwrap();
        let mut cues = MotionCues::<8, 5, 4, 4>::new(&config, absolute(1.0)).unwrap();
        feed(&mut cues, &img, w, (w, h));
        let regions = cues.end_frame();
        assert_eq!(regions.len(), 1);
        let r = regions[0];
        assert_eq!((r.x_min, r.y_min, r.x_max, r.y_max), (13, 7, 17, 9));
        assert_eq!((r.width(), r.height(), r.area), (5, 3, 15));
        assert_eq!(r.peak, U32F32::from_num(3.5));
        // ⌊(14 · 2 + 3.5) · 2¹⁶ / 15⌋ in Q16.16.
        assert_eq!(r.mean, U32F32::from_bits((2_064_384u64 / 15) << 16));
        assert_eq!(r.cells, 4); // columns 8-15 and 16-23, rows 0-7 and 8-15
        let last = cues.last_frame();
        assert_eq!(last.pixels, (w * h) as u32);
        assert_eq!(last.peak, U32F32::from_num(3.5));
        assert_eq!(last.regions_found, 1);
        // The grid is clear for the next frame.
        assert!(cues.end_frame().is_empty());
    }

    #[test]
    fn strictly_above_the_level() {
        let (w, h) = (16, 16);
        let img = image(w, h, &[(2, 2, 2, 2, 1.0)]);
        let config = Config::new(w, h, Params::DEFAULT).unwrap();
        let mut cues = MotionCues::<8, 2, 2, 4>::new(&config, absolute(1.0)).unwrap();
        feed(&mut cues, &img, w, (w, h));
        assert!(cues.end_frame().is_empty());
        let mut zero = MotionCues::<8, 2, 2, 4>::new(&config, absolute(0.0)).unwrap();
        feed(&mut zero, &img, w, (w, h));
        assert_eq!(zero.end_frame().len(), 1);
    }

    #[test]
    fn connectivity_is_that_of_cells() {
        let (w, h) = (48, 24);
        let config = Config::new(w, h, Params::DEFAULT).unwrap();
        let run = |blobs: &[(usize, usize, usize, usize, f64)]| {
            let mut cues = MotionCues::<8, 6, 3, 8>::new(&config, absolute(1.0)).unwrap();
            feed(&mut cues, &image(w, h, blobs), w, (7, 5));
            StdVec::from(cues.end_frame())
        };
        // Two specks in one cell that do not touch: one region.
        assert_eq!(run(&[(0, 0, 1, 1, 2.0), (6, 6, 1, 1, 2.0)]).len(), 1);
        // Specks in diagonally adjacent cells, 8 px apart: one region.
        assert_eq!(run(&[(7, 7, 1, 1, 2.0), (15, 15, 1, 1, 2.0)]).len(), 1);
        // In adjacent cells 8 px apart: one region; with a whole empty cell
        // column between them (9 px apart): two.
        assert_eq!(run(&[(7, 0, 1, 1, 2.0), (15, 0, 1, 1, 3.0)]).len(), 1);
        let two = run(&[(7, 0, 1, 1, 2.0), (16, 0, 1, 1, 3.0)]);
        assert_eq!(two.len(), 2);
        assert_eq!(two[0].x_min, 16); // the stronger first
        assert_eq!((two[1].x_min, two[1].area), (7, 1));
        // An NE-SW diagonal chain of cells is one region.
        assert_eq!(
            run(&[(40, 0, 1, 1, 2.0), (33, 9, 1, 1, 2.0), (25, 17, 1, 1, 2.0)]).len(),
            1
        );
        // A U shape whose arms join only at the bottom: one region, found
        // through the union of two provisional sets.
        let u = run(&[(0, 0, 1, 20, 2.0), (40, 0, 1, 20, 2.0), (0, 20, 41, 1, 2.0)]);
        assert_eq!(u.len(), 1);
        assert_eq!(
            (u[0].x_min, u[0].y_min, u[0].x_max, u[0].y_max),
            (0, 0, 40, 20)
        );
        assert_eq!(u[0].area, 20 + 20 + 41);
        assert_eq!(u[0].cells, 3 + 3 + 4);
    }

    #[test]
    fn tiling_does_not_change_the_regions() {
        let (w, h) = (61, 37);
        // A deterministic scatter of blobs of different strengths.
        let mut blobs = StdVec::new();
        let mut s = 0x1234_5678u32;
        for _ in 0..25 {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            let (x, y) = (s as usize % (w - 4), (s >> 8) as usize % (h - 4));
            blobs.push((
                x,
                y,
                1 + (s >> 16) as usize % 4,
                1 + (s >> 20) as usize % 4,
                1.0 + (s >> 24) as f64 / 16.0,
            ));
        }
        let img = image(w, h, &blobs);
        let config = Config::new(w, h, Params::DEFAULT).unwrap();
        let run = |tile| {
            let mut cues = MotionCues::<4, 16, 10, 6>::new(&config, absolute(1.5)).unwrap();
            feed(&mut cues, &img, w, tile);
            (StdVec::from(cues.end_frame()), *cues.last_frame())
        };
        let whole = run((w, h));
        assert!(whole.0.len() == 6 && whole.1.regions_found > 6, "{whole:?}");
        for tile in [(1, h), (1, 1), (3, 2), (7, 5), (w, 1), (16, 16), (60, 36)] {
            assert_eq!(run(tile), whole, "tile {tile:?}");
        }
    }

    #[test]
    fn capacity_keeps_the_strongest() {
        let (w, h) = (64, 8);
        // Eight separated specks, peaks 1.5, 2.5, ... in a shuffled order.
        let order = [3, 7, 0, 5, 1, 6, 2, 4];
        let blobs: StdVec<_> = order
            .iter()
            .enumerate()
            .map(|(slot, &rank)| (slot * 8 + 2, 3, 2, 2, 1.5 + rank as f64))
            .collect();
        let img = image(w, h, &blobs);
        let config = Config::new(w, h, Params::DEFAULT).unwrap();
        let mut cues = MotionCues::<4, 16, 2, 3>::new(&config, absolute(1.0)).unwrap();
        feed(&mut cues, &img, w, (5, 3));
        let peaks: StdVec<f64> = cues.end_frame().iter().map(|r| r.peak.to_num()).collect();
        assert_eq!(peaks, [8.5, 7.5, 6.5]);
        assert_eq!(cues.last_frame().regions_found, 8);
        // min_area drops small regions before they are counted.
        let mut big = MotionCues::<4, 16, 2, 3>::new(
            &config,
            CueParams {
                min_area: 5,
                ..absolute(1.0)
            },
        )
        .unwrap();
        feed(&mut big, &img, w, (w, h));
        assert!(big.end_frame().is_empty());
        assert_eq!(big.last_frame().regions_found, 0);
    }

    #[test]
    fn equal_strengths_keep_raster_order() {
        let (w, h) = (64, 8);
        let blobs: StdVec<_> = (0..8).map(|i| (i * 8 + 2, 3, 2, 2, 2.0)).collect();
        let img = image(w, h, &blobs);
        let config = Config::new(w, h, Params::DEFAULT).unwrap();
        let mut cues = MotionCues::<4, 16, 2, 3>::new(&config, absolute(1.0)).unwrap();
        feed(&mut cues, &img, w, (1, 1));
        let xs: StdVec<u16> = cues.end_frame().iter().map(|r| r.x_min).collect();
        assert_eq!(xs, [2, 10, 18]);
    }

    #[test]
    fn relative_levels_follow_the_previous_frame() {
        let (w, h) = (32, 32);
        let config = Config::new(w, h, Params::DEFAULT).unwrap();
        let floor = U32F32::from_num(0.25);
        let mut mean = MotionCues::<8, 4, 4, 4>::new(
            &config,
            CueParams {
                field: Field::DivergenceFree,
                threshold: Threshold::MeanMultiple {
                    k: U16F16::from_num(4),
                    floor,
                },
                min_area: 1,
                smoothing: 0,
            },
        )
        .unwrap();
        assert_eq!(mean.level(), floor);
        // Everything at 1.0 except one 4×4 blob at 9.0: mean 1.125.
        let img = {
            let mut img = image(w, h, &[(10, 10, 4, 4, 9.0)]);
            img.iter_mut().filter(|m| **m == 0.0).for_each(|m| *m = 1.0);
            img
        };
        feed(&mut mean, &img, w, (w, h));
        // First frame: level 0.25, so the whole frame is one region.
        assert_eq!(mean.end_frame().len(), 1);
        assert_eq!(mean.last_frame().mean, U32F32::from_num(1.125));
        assert_eq!(mean.level(), U32F32::from_num(4.5));
        feed(&mut mean, &img, w, (w, h));
        let r = mean.end_frame()[0];
        assert_eq!((r.x_min, r.y_min, r.area), (10, 10, 16));

        let mut peak = MotionCues::<8, 4, 4, 4>::new(
            &config,
            CueParams {
                field: Field::CurlFree, // m_c = m_d / 2 in these pixels
                threshold: Threshold::PeakFraction {
                    k: U16F16::from_num(0.5),
                    floor,
                },
                min_area: 1,
                smoothing: 0,
            },
        )
        .unwrap();
        feed(&mut peak, &img, w, (w, h));
        peak.end_frame();
        assert_eq!(peak.last_frame().peak, U32F32::from_num(4.5));
        assert_eq!(peak.level(), U32F32::from_num(2.25));
        feed(&mut peak, &img, w, (3, 3));
        assert_eq!(peak.end_frame()[0].area, 16);
        peak.reset();
        assert_eq!(peak.level(), floor);
    }

    #[test]
    fn smoothing_averages_the_reference_over_frames() {
        let (w, h) = (16, 16);
        let config = Config::new(w, h, Params::DEFAULT).unwrap();
        let mut cues = MotionCues::<8, 2, 2, 2>::new(
            &config,
            CueParams {
                field: Field::DivergenceFree,
                threshold: Threshold::PeakFraction {
                    k: U16F16::from_num(0.5),
                    floor: U32F32::ZERO,
                },
                min_area: 1,
                smoothing: 1,
            },
        )
        .unwrap();
        let mut levels = StdVec::new();
        for peak in [8.0, 4.0, 4.0, 12.0] {
            feed(&mut cues, &image(w, h, &[(3, 3, 1, 1, peak)]), w, (w, h));
            cues.end_frame();
            levels.push(cues.level().to_num::<f64>());
        }
        // References 8, 6, 5, 8.5: the first frame sets it, then halfway.
        assert_eq!(levels, [4.0, 3.0, 2.5, 4.25]);
        cues.reset();
        assert_eq!(cues.level(), U32F32::ZERO);
    }

    #[test]
    fn follow_moves_toward_the_new_value_exactly() {
        assert_eq!(follow(8, 4, 1), 6);
        assert_eq!(follow(4, 8, 2), 5);
        assert_eq!(follow(5, 6, 1), 5); // rounded toward the old value
        assert_eq!(follow(6, 5, 1), 6);
        assert_eq!(follow(7, 3, 0), 3);
        assert_eq!(follow(0, u64::MAX, 1), u64::MAX >> 1);
        assert_eq!(follow(u64::MAX, 0, 255), u64::MAX - 1); // s capped at 63
    }

    #[test]
    fn level_products_saturate_and_round_down() {
        assert_eq!(mul_q16(3 << 32, 2 << 16), 6 << 32);
        assert_eq!(mul_q16(1, 1 << 15), 0);
        assert_eq!(mul_q16(u64::MAX, u32::MAX), u64::MAX);
        assert_eq!(mul_q16(1 << 47, 1 << 16), 1 << 47);
        for (a, k) in [(123_456_789_012u64, 98_765u32), (u64::MAX >> 17, 65_535)] {
            let exact = (u128::from(a) * u128::from(k)) >> 16;
            assert_eq!(u128::from(mul_q16(a, k)), exact);
        }
    }

    #[test]
    fn magnitudes_enter_as_truncated_saturated_u32f32() {
        let bits = |m: f32| U32F32::from_bits(magnitude_bits(m));
        // Exact wherever U32F32 holds the f32: from 2⁻⁹ px up to below 2³² px,
        // and any multiple of 2⁻³² px.
        for m in [
            1.0f32,
            3.5,
            0.1,
            0.003,
            2f32.powi(-9),
            12_345.678,
            4_294_967_040.0,
        ] {
            assert_eq!(bits(m), U32F32::from_num(m), "{m}");
            assert_eq!(bits(m).to_num::<f32>(), m, "{m}");
        }
        assert_eq!(magnitude_bits(2f32.powi(-32)), 1);
        assert_eq!(magnitude_bits(3.0 * 2f32.powi(-32)), 3);
        // Below 2⁻⁹ px: truncated to a multiple of 2⁻³² px.
        let tiny = 1e-6f32; // 4294.967296 units of 2⁻³²
        assert_eq!(magnitude_bits(tiny), 4294);
        assert_eq!(magnitude_bits(2f32.powi(-33)), 0);
        assert_eq!(magnitude_bits(f32::from_bits(1)), 0); // smallest subnormal
        // Saturated from 2³² px; NaN, negatives and zeros are 0.
        for m in [2f32.powi(32), 1e30, f32::MAX, f32::INFINITY] {
            assert_eq!(bits(m), U32F32::MAX, "{m}");
        }
        for m in [0.0f32, -0.0, -1.0, f32::NEG_INFINITY, f32::NAN] {
            assert_eq!(magnitude_bits(m), 0, "{m}");
        }
    }

    #[test]
    fn extreme_magnitudes_do_not_overflow() {
        let (w, h) = (64, 64);
        let config = Config::new(w, h, Params::DEFAULT).unwrap();
        let mut cues = MotionCues::<64, 1, 1, 1>::new(&config, absolute(0.0)).unwrap();
        // Above any real magnitude: saturated at U32F32::MAX.
        let max = FlowPixel {
            m_d: f32::MAX,
            ..FlowPixel::default()
        };
        for y in 0..h {
            cues.row(y, 0, Rows::of(&[max; 64]).pixels());
        }
        let r = cues.end_frame()[0];
        assert_eq!(r.area, 64 * 64);
        assert_eq!(r.peak, U32F32::MAX);
        // Every term is U32F32::MAX truncated to Q16.16, and so is the mean.
        assert_eq!(r.mean, U32F32::from_bits(u64::MAX >> 16 << 16));
        assert_eq!(cues.last_frame().mean, r.mean);
        // Fed more than a frame, nothing panics.
        for _ in 0..3 {
            for y in 0..h {
                cues.row(y, 0, Rows::of(&[max; 64]).pixels());
            }
        }
        assert_eq!(cues.end_frame()[0].area, 3 * 64 * 64);
        // Values the engine never gives: NaN and negatives count as 0 (not
        // above a level of 0), infinity as U32F32::MAX.
        let m_d = |m_d| FlowPixel {
            m_d,
            ..FlowPixel::default()
        };
        let odd = [m_d(f32::NAN), m_d(-2.0), m_d(f32::INFINITY), m_d(1.0)];
        cues.row(5, 10, Rows::of(&odd).pixels());
        let r = cues.end_frame()[0];
        assert_eq!((r.x_min, r.x_max, r.area), (12, 13, 2));
        assert_eq!(r.peak, U32F32::MAX);
        assert_eq!(cues.last_frame().pixels, 4);
    }

    #[test]
    fn memory_is_as_documented() {
        assert_eq!(core::mem::size_of::<Cell>(), 32);
        assert_eq!(core::mem::size_of::<Region>(), 32);
        let bytes = MotionCues::<16, 20, 15, 8>::WORKING_BYTES;
        assert_eq!(bytes, 32 * 300 + 8 * 32 + 120, "{bytes}"); // 64-bit host
    }
}

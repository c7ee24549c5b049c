//! Motion cues of a stream of pairs, for the front ends that report them
//! (the GStreamer element's region metas and messages, the ROS 2 node's
//! detections): the cues crate's [`MotionCues`] on one grid, its settings
//! checked once, and the pair's kept magnitudes replayed into it row by
//! row ([`PairEngine::magnitudes`](crate::engine::PairEngine::magnitudes)).
//! Each region comes out as a [`CueBox`], which each front end writes in
//! its own message type.

use reynoldsflow_core::fixed::types::U32F32;
use reynoldsflow_core::{Config, Params, Pixels, Sink};
use reynoldsflow_cues::{CueError, CueParams, Field, MotionCues, Region, Threshold};

use crate::HostError;
use crate::engine::Magnitudes;
use crate::settings::{Setting, Settings};

/// Cell side, px: 16-px cells keep a small mover in one or two cells at
/// 640 × 480 and keep the grid's labelling cheap.
pub const CELL: usize = 16;
/// Grid cells along each side.
pub const GRID: usize = 128;
/// Largest frame side the cues cover, px.
pub const MAX_SIDE: usize = CELL * GRID;
/// Regions kept per frame, strongest first.
pub const REGIONS: usize = 8;

/// The grid (512 KiB of cells, so it lives on the heap).
pub type Grid = MotionCues<CELL, GRID, GRID, REGIONS>;

/// What the cues look for, from `settings`: `|v_c|` (smooth, one compact
/// blob per small mover; the cues crate's module doc) above
/// `cue_threshold` px, regions of at least `cue_min_area` px. A NaN or
/// negative threshold is refused; thresholds beyond the magnitudes'
/// Q32.32 saturate.
pub fn params(settings: &Settings) -> Result<CueParams, HostError> {
    let threshold = settings.cue_threshold;
    if threshold.is_nan() || threshold < 0.0 {
        return Err(HostError::setting(
            Setting::CueThreshold,
            format!("{threshold}; give a level in px, 0 or more"),
        ));
    }
    Ok(CueParams {
        field: Field::CurlFree,
        threshold: Threshold::Absolute(U32F32::saturating_from_num(threshold)),
        min_area: settings.cue_min_area,
        smoothing: 0,
    })
}

/// The cues of one stream: the grid, rebuilt when the frame size changes.
pub struct Cues {
    params: CueParams,
    grid: Option<((usize, usize), Box<Grid>)>,
}

impl Cues {
    /// Cues of the checked `settings` ([`params`]).
    pub fn new(settings: &Settings) -> Result<Self, HostError> {
        Ok(Self {
            params: params(settings)?,
            grid: None,
        })
    }

    /// The regions of a pair, strongest first, from its magnitudes; fails
    /// for a frame wider or taller than [`MAX_SIDE`].
    pub fn regions(&mut self, pair: &Magnitudes<'_>) -> Result<&[Region], CueError> {
        let (width, height) = (pair.width, pair.height);
        let grid = match self.grid.take() {
            Some((size, grid)) if size == (width, height) => grid,
            _ => {
                let config = Config::new(width, height, Params::DEFAULT).map_err(|_| {
                    CueError::GridTooSmall {
                        columns: width.div_ceil(CELL),
                        rows: height.div_ceil(CELL),
                    }
                })?;
                new_grid(config, self.params)?
            }
        };
        let grid = &mut self.grid.insert(((width, height), grid)).1;
        // Whole rows in raster order: the regions are the same for any order
        // of tiles the engine ran (the cues crate's doc). The cues read the
        // magnitudes only.
        for y in 0..height {
            let row = y * width..(y + 1) * width;
            let pixels = Pixels {
                m_d: &pair.m_d[row.clone()],
                m_c: &pair.m_c[row.clone()],
                luma: &pair.luma[row],
                fields: None,
            };
            grid.row(y, 0, pixels);
        }
        Ok(grid.end_frame())
    }

    /// The level the last pair's magnitudes were compared with, px.
    pub fn level(&self) -> f64 {
        self.grid
            .as_ref()
            .map_or(0.0, |(_, grid)| grid.last_frame().level.to_num())
    }
}

/// A grid for frames of `config`'s size, built on a thread with room for
/// it: the cues crate builds it by value (512 KiB), and an unoptimised
/// build copies it more than once on its way to the heap, past the 2 MiB
/// of stack a test's (or a small streaming) thread has.
fn new_grid(config: Config, params: CueParams) -> Result<Box<Grid>, CueError> {
    let build = move || Grid::new(&config, params).map(Box::new);
    std::thread::scope(|scope| {
        let roomy = std::thread::Builder::new().stack_size(16 << 20);
        match roomy.spawn_scoped(scope, build) {
            Ok(thread) => thread
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic)),
            Err(_) => build(),
        }
    })
}

/// A region as the front ends report it: its box in pixels, its area
/// (moving pixels) and its peak and mean `|v_c|`, px.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CueBox {
    /// Left column.
    pub x: u32,
    /// Top row.
    pub y: u32,
    /// Columns covered.
    pub width: u32,
    /// Rows covered.
    pub height: u32,
    /// Moving pixels.
    pub area: u32,
    /// Largest magnitude.
    pub peak: f64,
    /// Mean magnitude.
    pub mean: f64,
}

impl CueBox {
    /// The box of `region`.
    pub fn of(region: &Region) -> Self {
        Self {
            x: region.x_min.into(),
            y: region.y_min.into(),
            width: region.width().into(),
            height: region.height().into(),
            area: region.area,
            peak: region.peak.to_num(),
            mean: region.mean.to_num(),
        }
    }

    /// The box's centre: it covers pixels `[x, x + width)`, so its centre
    /// is half a box from its left edge.
    pub fn center(&self) -> (f64, f64) {
        (
            f64::from(self.x) + f64::from(self.width) / 2.0,
            f64::from(self.y) + f64::from(self.height) / 2.0,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pair's magnitudes, `|v_c| = 3` inside the box.
    fn moving_box(width: usize, height: usize, x: (usize, usize), y: (usize, usize)) -> Vec<f32> {
        (0..width * height)
            .map(|i| {
                let (px, py) = (i % width, i / width);
                let inside = (x.0..=x.1).contains(&px) && (y.0..=y.1).contains(&py);
                if inside { 3.0 } else { 0.0 }
            })
            .collect()
    }

    fn magnitudes<'a>(
        w: usize,
        h: usize,
        m_c: &'a [f32],
        zeros: &'a [f32],
        luma: &'a [u8],
    ) -> Magnitudes<'a> {
        Magnitudes {
            width: w,
            height: h,
            m_d: zeros,
            m_c,
            luma,
        }
    }

    #[test]
    fn a_moving_box_is_one_region_with_its_pixel_box() {
        {
            let mut cues = Cues::new(&Settings::default()).unwrap();
            let (w, h) = (64, 40);
            let (m_c, zeros, luma) = (
                moving_box(w, h, (10, 19), (5, 8)),
                vec![0.0; w * h],
                vec![0; w * h],
            );
            let regions = cues
                .regions(&magnitudes(w, h, &m_c, &zeros, &luma))
                .unwrap();
            assert_eq!(regions.len(), 1);
            let b = CueBox::of(&regions[0]);
            assert_eq!((b.x, b.y, b.width, b.height, b.area), (10, 5, 10, 4, 40));
            assert_eq!((b.peak, b.mean), (3.0, 3.0));
            assert_eq!(b.center(), (15.0, 7.0));
            assert_eq!(cues.level(), 1.0);
            // A new size rebuilds the grid; nothing moving is nothing.
            let (w, h) = (32, 32);
            let (still, luma) = (vec![0.0; w * h], vec![0; w * h]);
            assert!(
                cues.regions(&magnitudes(w, h, &still, &still, &luma))
                    .unwrap()
                    .is_empty()
            );
            // Beyond the grid.
            let (w, h) = (MAX_SIDE + 16, 1);
            let (wide, luma) = (vec![0.0; w * h], vec![0; w * h]);
            assert!(matches!(
                cues.regions(&magnitudes(w, h, &wide, &wide, &luma)),
                Err(CueError::GridTooSmall { .. })
            ));
        }
    }

    #[test]
    fn bad_thresholds_name_the_setting() {
        for bad in [f64::NAN, -1.0] {
            let settings = Settings {
                cue_threshold: bad,
                ..Settings::default()
            };
            let err = Cues::new(&settings).err().unwrap();
            assert!(
                matches!(
                    err,
                    HostError::Setting {
                        setting: Setting::CueThreshold,
                        ..
                    }
                ),
                "{err}"
            );
        }
        let far = Settings {
            cue_threshold: f64::INFINITY,
            ..Settings::default()
        };
        assert!(params(&far).is_ok());
    }
}

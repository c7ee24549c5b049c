//! Motion cues as `vision_msgs/Detection2DArray`: the moving regions of
//! each output, found by the cues crate's [`MotionCues`] on the pair's
//! magnitudes with the element's grid and defaults, one `Detection2D` per
//! region (box in pixels, class `motion`, score its peak `|v_c|`).
//!
//! vision_msgs is the standard the ROS perception stack reads (detectors,
//! trackers, rviz plugins), so the cues go where a detector's boxes go.

use reynoldsflow_core::fixed::types::U32F32;
use reynoldsflow_core::{Config, FlowPixel, Params, Pixels, Sink};
use reynoldsflow_cues::{CueError, CueParams, Field, MotionCues, Region, Threshold};

use crate::msg::{
    BoundingBox2D, Detection2D, Detection2DArray, Header, ObjectHypothesis,
    ObjectHypothesisWithPose, Point2D, Pose2D,
};

/// Cell side, px (the element's: a small mover stays in one or two cells
/// at 640 × 480, and labelling the grid stays cheap).
const CELL: usize = 16;
/// Cells along each side: frames up to 2048 px a side.
const GRID: usize = 128;
/// Regions kept per frame, strongest first.
const REGIONS: usize = 8;
/// Largest frame side the cues cover, px.
pub const MAX_SIDE: usize = CELL * GRID;
/// The class of every detection.
pub const CLASS: &str = "motion";

/// The grid (512 KiB of cells, so it lives on the heap).
type Grid = MotionCues<CELL, GRID, GRID, REGIONS>;

/// What makes a pixel move, as the element's `cue-threshold` and
/// `cue-min-area`.
#[derive(Clone, Copy, Debug)]
pub struct CueSettings {
    /// `|v_c|` above this, px.
    pub threshold: f64,
    /// Regions of fewer moving pixels are dropped.
    pub min_area: u32,
}

/// The cue finder of one stream, rebuilt when the frame size changes.
pub struct Cues {
    params: CueParams,
    grid: Option<((usize, usize), Box<Grid>)>,
    /// One row of each magnitude (the engine hands the sink rows).
    rows: (Vec<f32>, Vec<f32>, Vec<u8>),
}

impl Cues {
    /// Checked settings (a NaN threshold is refused; values beyond the
    /// magnitudes' Q32.32 saturate).
    pub fn new(settings: CueSettings) -> Result<Self, String> {
        if settings.threshold.is_nan() || settings.threshold < 0.0 {
            return Err(format!(
                "--cue-threshold {}: give a level in px, 0 or more",
                settings.threshold
            ));
        }
        Ok(Self {
            params: CueParams {
                // |v_c|: smooth, one compact blob per small mover (the
                // cues crate's module doc).
                field: Field::CurlFree,
                threshold: Threshold::Absolute(U32F32::saturating_from_num(settings.threshold)),
                min_area: settings.min_area,
                smoothing: 0,
            },
            grid: None,
            rows: Default::default(),
        })
    }

    /// The regions of a `width × height` pair's `pixels` (row-major).
    pub fn regions(
        &mut self,
        width: usize,
        height: usize,
        pixels: &[FlowPixel],
    ) -> Result<Vec<Region>, CueError> {
        let grid = match self.grid.take() {
            Some((size, grid)) if size == (width, height) => grid,
            _ => {
                let config = Config::new(width, height, Params::DEFAULT)
                    .map_err(|_| grid_error(width, height))?;
                Box::new(Grid::new(&config, self.params)?)
            }
        };
        let grid = &mut self.grid.insert(((width, height), grid)).1;
        let (m_d, m_c, luma) = &mut self.rows;
        // Whole rows in raster order: the regions are the same for any
        // order of tiles (the cues crate's doc).
        for (y, row) in pixels.chunks(width).take(height).enumerate() {
            m_d.clear();
            m_d.extend(row.iter().map(|p| p.m_d));
            m_c.clear();
            m_c.extend(row.iter().map(|p| p.m_c));
            luma.clear();
            luma.extend(row.iter().map(|p| p.luma));
            let fields = None; // the cues read the magnitudes only
            grid.row(
                y,
                0,
                Pixels {
                    m_d,
                    m_c,
                    luma,
                    fields,
                },
            );
        }
        Ok(grid.end_frame().to_vec())
    }
}

fn grid_error(width: usize, height: usize) -> CueError {
    CueError::GridTooSmall {
        columns: width.div_ceil(CELL),
        rows: height.div_ceil(CELL),
    }
}

/// The message of `regions`, under the header of their image.
pub fn detections(header: &Header, regions: &[Region]) -> Detection2DArray {
    let detections = regions
        .iter()
        .enumerate()
        .map(|(rank, r)| {
            let (w, h) = (f64::from(r.width()), f64::from(r.height()));
            Detection2D {
                header: header.clone(),
                results: vec![ObjectHypothesisWithPose {
                    hypothesis: ObjectHypothesis {
                        class_id: CLASS.into(),
                        score: r.peak.to_num(),
                    },
                    pose: Default::default(),
                }],
                bbox: BoundingBox2D {
                    // The box covers pixels [x_min, x_max]: its centre is
                    // half a box from its left edge.
                    center: Pose2D {
                        position: Point2D {
                            x: f64::from(r.x_min) + w / 2.0,
                            y: f64::from(r.y_min) + h / 2.0,
                        },
                        theta: 0.0,
                    },
                    size_x: w,
                    size_y: h,
                },
                id: rank.to_string(),
            }
        })
        .collect();
    Detection2DArray {
        header: header.clone(),
        detections,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `width × height` pair's pixels, `|v_c| = 3` inside the box.
    fn moving_box(
        width: usize,
        height: usize,
        x: (usize, usize),
        y: (usize, usize),
    ) -> Vec<FlowPixel> {
        (0..width * height)
            .map(|i| {
                let (px, py) = (i % width, i / width);
                let inside = (x.0..=x.1).contains(&px) && (y.0..=y.1).contains(&py);
                FlowPixel {
                    m_c: if inside { 3.0 } else { 0.0 },
                    ..FlowPixel::default()
                }
            })
            .collect()
    }

    /// Run `test` with room for the grid, which the cues crate builds by
    /// value (512 KiB; an unoptimised build copies it more than once on the
    /// way to its box, past a test thread's 2 MiB of stack).
    fn with_stack(test: fn()) {
        std::thread::Builder::new()
            .stack_size(16 << 20)
            .spawn(test)
            .unwrap()
            .join()
            .unwrap();
    }

    #[test]
    fn a_moving_box_is_one_detection_with_its_pixel_box() {
        with_stack(moving_box_detection);
    }

    fn moving_box_detection() {
        let mut cues = Cues::new(CueSettings {
            threshold: 1.0,
            min_area: 4,
        })
        .unwrap();
        let pixels = moving_box(64, 40, (10, 19), (5, 8));
        let regions = cues.regions(64, 40, &pixels).unwrap();
        assert_eq!(regions.len(), 1);
        let header = Header {
            frame_id: "cam".into(),
            ..Header::default()
        };
        let msg = detections(&header, &regions);
        let d = &msg.detections[0];
        assert_eq!(msg.header, header);
        assert_eq!((d.bbox.size_x, d.bbox.size_y), (10.0, 4.0));
        assert_eq!(
            (d.bbox.center.position.x, d.bbox.center.position.y),
            (15.0, 7.0)
        );
        assert_eq!(d.results[0].hypothesis.class_id, "motion");
        assert_eq!(d.results[0].hypothesis.score, 3.0);
        assert_eq!(d.id, "0");
        // A new size rebuilds the grid; still nothing moving is nothing.
        let still = moving_box(32, 32, (40, 40), (40, 40));
        assert!(cues.regions(32, 32, &still).unwrap().is_empty());
    }

    #[test]
    fn frames_beyond_the_grid_and_bad_thresholds_are_refused() {
        with_stack(refusals);
    }

    fn refusals() {
        let mut cues = Cues::new(CueSettings {
            threshold: 1.0,
            min_area: 1,
        })
        .unwrap();
        let wide = vec![FlowPixel::default(); MAX_SIDE + 16];
        assert!(matches!(
            cues.regions(MAX_SIDE + 16, 1, &wide),
            Err(CueError::GridTooSmall { .. })
        ));
        for bad in [f64::NAN, -1.0] {
            let err = Cues::new(CueSettings {
                threshold: bad,
                min_area: 1,
            })
            .err()
            .unwrap();
            assert!(err.contains("--cue-threshold"), "{err}");
        }
    }
}

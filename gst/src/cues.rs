//! The element's motion cues: the core's [`MotionCues`] on a grid that
//! covers frames up to [`MAX_SIDE`] px a side, and how its regions travel
//! downstream (a region-of-interest meta each) and to the application (one
//! element message per frame).

use reynoldsflow_core::Config;
use reynoldsflow_core::fixed::types::U32F32;
use reynoldsflow_cues::{CueError, CueParams, Field, MotionCues, Region, Threshold};

/// Cell side, px: 16-px cells keep a small mover in one or two cells at
/// 640 × 480 and keep the grid's labelling cheap.
pub const CELL: usize = 16;
/// Grid cells along each side.
pub const GRID: usize = 128;
/// Largest frame side the cues cover, px.
pub const MAX_SIDE: usize = CELL * GRID;
/// Regions kept per frame, strongest first.
pub const REGIONS: usize = 8;

/// The cue sink of the element (512 KiB of cells, so it lives on the heap).
pub type Cues = MotionCues<CELL, GRID, GRID, REGIONS>;

/// The `roi_type` of the element's region-of-interest metas.
pub const ROI_TYPE: &str = "motion";
/// Name of the structure of each meta's parameters and of the message's regions.
pub const REGION_STRUCTURE: &str = "reynoldsflow-region";
/// Name of the element message's structure.
pub const MESSAGE_STRUCTURE: &str = "reynoldsflow-cues";

/// What the cues look for: `|v_c|` (smooth, one compact blob per small
/// mover; the `cues` module doc of `reynoldsflow-cues`) above `threshold`
/// px, regions of at least `min_area` px. NaN is refused, naming the
/// property: GLib 2.74 and later refuse it at the property already, older
/// ones clamp, which lets it through (and `fixed` panics on NaN).
/// Thresholds beyond the magnitudes' Q32.32 saturate.
pub fn params(threshold: f64, min_area: u32) -> Result<CueParams, String> {
    if threshold.is_nan() {
        return Err("cue-threshold is NaN; give a level in px, 0 or more".into());
    }
    Ok(CueParams {
        field: Field::CurlFree,
        threshold: Threshold::Absolute(U32F32::saturating_from_num(threshold)),
        min_area,
        smoothing: 0,
    })
}

/// A cue sink for frames of `config`'s size, built on the heap.
pub fn new_cues(config: &Config, params: CueParams) -> Result<Box<Cues>, CueError> {
    Cues::new(config, params).map(Box::new)
}

/// A region as a structure: box, area (moving pixels), peak and mean
/// magnitude (px).
pub fn region_structure(r: &Region) -> gst::Structure {
    gst::Structure::builder(REGION_STRUCTURE)
        .field("x", u32::from(r.x_min))
        .field("y", u32::from(r.y_min))
        .field("width", u32::from(r.width()))
        .field("height", u32::from(r.height()))
        .field("area", r.area)
        .field("peak", r.peak.to_num::<f64>())
        .field("mean", r.mean.to_num::<f64>())
        .build()
}

/// Add one region-of-interest meta per region to `buffer`, its parameters
/// the region's structure.
pub fn add_metas(buffer: &mut gst::BufferRef, regions: &[Region]) {
    for (id, r) in regions.iter().enumerate() {
        let rect = (
            u32::from(r.x_min),
            u32::from(r.y_min),
            u32::from(r.width()),
            u32::from(r.height()),
        );
        let mut meta = gst_video::VideoRegionOfInterestMeta::add(buffer, ROI_TYPE, rect);
        meta.set_id(id as i32);
        meta.add_param(region_structure(r));
    }
}

/// The frame's element message: the output's timestamp, the level the
/// magnitudes were compared with, and the regions, strongest first.
pub fn message_structure(
    pts: Option<gst::ClockTime>,
    level: U32F32,
    regions: &[Region],
) -> gst::Structure {
    gst::Structure::builder(MESSAGE_STRUCTURE)
        .field("timestamp", pts)
        .field("level", level.to_num::<f64>())
        .field(
            "regions",
            gst::Array::new(regions.iter().map(region_structure)),
        )
        .build()
}

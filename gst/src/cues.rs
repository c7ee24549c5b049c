//! How the element's motion cues travel: a region-of-interest meta per
//! region downstream, and one element message per frame to the
//! application. The cues themselves (grid, settings, regions) are the
//! host's ([`reynoldsflow_host::cues`]), as the ROS 2 node's are.

use reynoldsflow_cues::Region;
use reynoldsflow_host::cues::CueBox;
pub use reynoldsflow_host::cues::{CELL, GRID, MAX_SIDE, REGIONS};

/// The `roi_type` of the element's region-of-interest metas.
pub const ROI_TYPE: &str = "motion";
/// Name of the structure of each meta's parameters and of the message's regions.
pub const REGION_STRUCTURE: &str = "reynoldsflow-region";
/// Name of the element message's structure.
pub const MESSAGE_STRUCTURE: &str = "reynoldsflow-cues";

/// A region as a structure: box, area (moving pixels), peak and mean
/// magnitude (px).
pub fn region_structure(r: &Region) -> gst::Structure {
    let b = CueBox::of(r);
    gst::Structure::builder(REGION_STRUCTURE)
        .field("x", b.x)
        .field("y", b.y)
        .field("width", b.width)
        .field("height", b.height)
        .field("area", b.area)
        .field("peak", b.peak)
        .field("mean", b.mean)
        .build()
}

/// Add one region-of-interest meta per region to `buffer`, its parameters
/// the region's structure.
pub fn add_metas(buffer: &mut gst::BufferRef, regions: &[Region]) {
    for (id, r) in regions.iter().enumerate() {
        let b = CueBox::of(r);
        let rect = (b.x, b.y, b.width, b.height);
        let mut meta = gst_video::VideoRegionOfInterestMeta::add(buffer, ROI_TYPE, rect);
        meta.set_id(id as i32);
        meta.add_param(region_structure(r));
    }
}

/// The frame's element message: the output's timestamp, the level the
/// magnitudes were compared with (px), and the regions, strongest first.
pub fn message_structure(
    pts: Option<gst::ClockTime>,
    level: f64,
    regions: &[Region],
) -> gst::Structure {
    gst::Structure::builder(MESSAGE_STRUCTURE)
        .field("timestamp", pts)
        .field("level", level)
        .field(
            "regions",
            gst::Array::new(regions.iter().map(region_structure)),
        )
        .build()
}

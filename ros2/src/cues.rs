//! Motion cues as `vision_msgs/Detection2DArray`: the moving regions of
//! each output, found by the host's cues (`reynoldsflow_host::cues`, the
//! GStreamer element's too) on the pair's magnitudes, one `Detection2D`
//! per region (box in pixels, class `motion`, score its peak `|v_c|`).
//!
//! vision_msgs is the standard the ROS perception stack reads (detectors,
//! trackers, rviz plugins), so the cues go where a detector's boxes go.

use reynoldsflow_cues::Region;
use reynoldsflow_host::cues::CueBox;
pub use reynoldsflow_host::cues::MAX_SIDE;

use crate::msg::{
    BoundingBox2D, Detection2D, Detection2DArray, Header, ObjectHypothesis,
    ObjectHypothesisWithPose, Point2D, Pose2D,
};

/// The class of every detection.
pub const CLASS: &str = "motion";

/// The message of `regions`, under the header of their image.
pub fn detections(header: &Header, regions: &[Region]) -> Detection2DArray {
    let detections = regions
        .iter()
        .enumerate()
        .map(|(rank, r)| {
            let b = CueBox::of(r);
            let (x, y) = b.center();
            Detection2D {
                header: header.clone(),
                results: vec![ObjectHypothesisWithPose {
                    hypothesis: ObjectHypothesis {
                        class_id: CLASS.into(),
                        score: b.peak,
                    },
                    pose: Default::default(),
                }],
                bbox: BoundingBox2D {
                    center: Pose2D {
                        position: Point2D { x, y },
                        theta: 0.0,
                    },
                    size_x: f64::from(b.width),
                    size_y: f64::from(b.height),
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
    use reynoldsflow_host::cues::Cues;
    use reynoldsflow_host::engine::Magnitudes;
    use reynoldsflow_host::settings::Settings;

    use super::*;

    #[test]
    fn a_moving_box_is_one_detection_with_its_pixel_box() {
        let (w, h) = (64, 40);
        // |v_c| = 3 in columns 10..=19 of rows 5..=8.
        let m_c: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if (10..20).contains(&x) && (5..9).contains(&y) {
                    3.0
                } else {
                    0.0
                }
            })
            .collect();
        let (m_d, luma) = (vec![0.0; w * h], vec![0; w * h]);
        let pair = Magnitudes {
            width: w,
            height: h,
            m_d: &m_d,
            m_c: &m_c,
            luma: &luma,
        };
        let mut cues = Cues::new(&Settings::default()).unwrap();
        let regions = cues.regions(&pair).unwrap().to_vec();
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
    }
}

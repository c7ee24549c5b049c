//! The ROS 2 messages the node reads and writes, as they travel (CDR,
//! field for field in the `.msg` order): `sensor_msgs/Image` and the
//! `vision_msgs/Detection2DArray` of the motion cues, with the
//! `std_msgs`, `builtin_interfaces` and `geometry_msgs` types inside them.
//! Jazzy layouts (sensor_msgs 5.3, vision_msgs 4.1; unchanged since Humble).
//!
//! Our own definitions rather than ros2-client's: its `Time` goes through
//! nanoseconds and back, and a stamp must leave exactly as it came.

use std::fmt;

use ros2_client::{Message, MessageTypeName};
use serde::de::{SeqAccess, Visitor};
use serde::ser::SerializeTuple;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// `builtin_interfaces/Time`, as received: compared field by field
/// (seconds, then nanoseconds), which is time order for valid stamps.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct Time {
    /// Seconds (since the epoch, or since start for simulated clocks).
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

impl fmt::Display for Time {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{:09}", self.sec, self.nanosec)
    }
}

/// `std_msgs/Header`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Header {
    /// When the frame was taken.
    pub stamp: Time,
    /// The camera's coordinate frame.
    pub frame_id: String,
}

/// `sensor_msgs/Image`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Image {
    /// Stamp and frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Pixel layout, e.g. `mono8`, `bgr8` (sensor_msgs/image_encodings).
    pub encoding: String,
    /// Byte order of multi-byte pixels (unused by the 8-bit encodings).
    pub is_bigendian: u8,
    /// Bytes from one row to the next.
    pub step: u32,
    /// `step · height` bytes. As bytes, not a sequence of `u8`: the CDR
    /// codec then copies a frame in one go instead of byte by byte.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

impl Message for Image {}

impl Image {
    /// The ROS type.
    pub fn type_name() -> MessageTypeName {
        MessageTypeName::new("sensor_msgs", "Image")
    }
}

/// `vision_msgs/Detection2DArray`: the motion cues of one output.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Detection2DArray {
    /// The header of the image the cues belong to.
    pub header: Header,
    /// One per moving region, strongest first.
    pub detections: Vec<Detection2D>,
}

impl Message for Detection2DArray {}

impl Detection2DArray {
    /// The ROS type.
    pub fn type_name() -> MessageTypeName {
        MessageTypeName::new("vision_msgs", "Detection2DArray")
    }
}

/// `vision_msgs/Detection2D`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Detection2D {
    /// Same as the array's.
    pub header: Header,
    /// Class hypotheses.
    pub results: Vec<ObjectHypothesisWithPose>,
    /// The box, in pixels.
    pub bbox: BoundingBox2D,
    /// An identifier of the detection.
    pub id: String,
}

/// `vision_msgs/ObjectHypothesisWithPose`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ObjectHypothesisWithPose {
    /// Class and score.
    pub hypothesis: ObjectHypothesis,
    /// A 3-D pose (none here: identity, zero covariance).
    pub pose: PoseWithCovariance,
}

/// `vision_msgs/ObjectHypothesis`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ObjectHypothesis {
    /// Class name.
    pub class_id: String,
    /// Score of the class.
    pub score: f64,
}

/// `vision_msgs/BoundingBox2D`: centre and size.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BoundingBox2D {
    /// Centre (and rotation, 0 here).
    pub center: Pose2D,
    /// Width.
    pub size_x: f64,
    /// Height.
    pub size_y: f64,
}

/// `vision_msgs/Pose2D`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose2D {
    /// Position.
    pub position: Point2D,
    /// Rotation, radians.
    pub theta: f64,
}

/// `vision_msgs/Point2D`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Point2D {
    /// Column coordinate.
    pub x: f64,
    /// Row coordinate.
    pub y: f64,
}

/// `geometry_msgs/PoseWithCovariance`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// Pose.
    pub pose: Pose,
    /// Row-major 6×6 covariance.
    pub covariance: Covariance,
}

/// `geometry_msgs/Pose`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position.
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/Point`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/Quaternion`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    /// The identity, as the `.msg` defaults it (`w = 1`).
    fn default() -> Self {
        Self {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

/// `float64[36]`: a fixed array travels as its elements alone. By hand,
/// since serde derives arrays up to 32 elements only.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Covariance(pub [f64; 36]);

impl Default for Covariance {
    fn default() -> Self {
        Self([0.0; 36])
    }
}

impl Serialize for Covariance {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut tuple = serializer.serialize_tuple(36)?;
        for v in &self.0 {
            tuple.serialize_element(v)?;
        }
        tuple.end()
    }
}

impl<'de> Deserialize<'de> for Covariance {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Elements;
        impl<'de> Visitor<'de> for Elements {
            type Value = Covariance;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("36 float64")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Covariance, A::Error> {
                let mut out = [0.0; 36];
                for (i, v) in out.iter_mut().enumerate() {
                    *v = seq
                        .next_element()?
                        .ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
                }
                Ok(Covariance(out))
            }
        }
        deserializer.deserialize_tuple(36, Elements)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CDR little-endian bytes of `value`, as ros2-client's publisher
    /// writes them (without the 4-byte encapsulation header).
    fn cdr<T: Serialize>(value: &T) -> Vec<u8> {
        cdr_encoding::to_vec::<T, byteorder::LittleEndian>(value).unwrap()
    }

    #[test]
    fn an_image_travels_in_the_msg_order() {
        let image = Image {
            header: Header {
                stamp: Time { sec: 3, nanosec: 7 },
                frame_id: "cam".into(),
            },
            height: 1,
            width: 2,
            encoding: "mono8".into(),
            is_bigendian: 0,
            step: 2,
            data: vec![9, 8],
        };
        let bytes = cdr(&image);
        let expected: Vec<u8> = [
            &3i32.to_le_bytes()[..],
            &7u32.to_le_bytes(),
            &4u32.to_le_bytes(), // "cam" and its NUL
            b"cam\0",
            &1u32.to_le_bytes(),
            &2u32.to_le_bytes(),
            &6u32.to_le_bytes(),
            b"mono8\0",
            &[0], // is_bigendian, at offset 34
            &[0], // padding to 36 for step
            &2u32.to_le_bytes(),
            &2u32.to_le_bytes(),
            &[9, 8],
        ]
        .concat();
        assert_eq!(bytes, expected);
        let back: Image = cdr_encoding::from_bytes::<Image, byteorder::LittleEndian>(&bytes)
            .unwrap()
            .0;
        assert_eq!(back, image);
    }

    #[test]
    fn a_covariance_is_36_doubles_without_a_length() {
        let mut c = Covariance::default();
        c.0[35] = 2.5;
        let bytes = cdr(&c);
        assert_eq!(bytes.len(), 36 * 8);
        assert_eq!(&bytes[35 * 8..], &2.5f64.to_le_bytes());
        let back: Covariance =
            cdr_encoding::from_bytes::<Covariance, byteorder::LittleEndian>(&bytes)
                .unwrap()
                .0;
        assert_eq!(back, c);
    }

    #[test]
    fn stamps_order_by_seconds_then_nanoseconds() {
        let t = |sec, nanosec| Time { sec, nanosec };
        assert!(t(1, 999_999_999) < t(2, 0));
        assert!(t(2, 1) > t(2, 0));
        assert_eq!(t(5, 42).to_string(), "5.000000042");
    }
}

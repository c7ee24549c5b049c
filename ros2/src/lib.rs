//! `reynoldsflow-ros2`: a ROS 2 node that subscribes to camera images
//! (`sensor_msgs/Image`) and publishes the ReynoldsFlow representation of
//! each consecutive pair, the bytes of `reynoldsflow run` on the same
//! frames, and optionally motion cues (`vision_msgs/Detection2DArray`).
//!
//! Built on ros2-client (RustDDS): pure Rust, so it needs no ROS install
//! to build and runs beside ROS 2 nodes of any DDS vendor on the graph.
//!
//! | module | what |
//! |---|---|
//! | [`args`] | the command line |
//! | [`discovery`] | `ROS_DOMAIN_ID` and the discovery range |
//! | [`msg`] | the messages on the wire |
//! | [`luma`] | an image message to the engine's gray frame |
//! | [`pairing`] | frames to pairs, outputs to headers, restarts |
//! | [`compute`] | a pair to its image, through the host crate |
//! | [`cues`] | motion cues as detections |
//! | [`log`] | stderr and `/rosout` |
//! | [`shutdown`] | SIGINT and SIGTERM |
//! | [`node`] | the DDS entities and the loop |
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod args;
pub mod compute;
pub mod cues;
pub mod discovery;
pub mod log;
pub mod luma;
pub mod msg;
pub mod node;
pub mod pairing;
pub mod shutdown;

//! `reynoldsflow-ros2`: a ROS 2 node that subscribes to camera images
//! (`sensor_msgs/Image`) and publishes the ReynoldsFlow representation of
//! each consecutive pair, the bytes of `reynoldsflow run` on the same
//! frames, and optionally motion cues (`vision_msgs/Detection2DArray`).
//!
//! Built on ros2-client (RustDDS): pure Rust, so it needs no ROS install
//! to build and runs beside ROS 2 nodes of any DDS vendor on the graph.
//! Which frame pairs with which and which header each output carries is
//! the host's pair stream (`reynoldsflow_host::pair_stream`), each pair's
//! image its pair engine (`reynoldsflow_host::engine::PairEngine`) and the cues
//! its `cues`, as in the GStreamer element.
//!
//! | module | what |
//! |---|---|
//! | [`args`] | the command line |
//! | [`discovery`] | `ROS_DOMAIN_ID` and the discovery range |
//! | [`msg`] | the messages on the wire |
//! | [`luma`] | an image message to the engine's gray frame |
//! | [`cues`] | motion cues as detections |
//! | [`log`] | stderr and `/rosout` |
//! | [`shutdown`] | SIGINT and SIGTERM |
//! | [`node`] | the DDS entities and the loop |
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod args;
pub mod cues;
pub mod discovery;
pub mod log;
pub mod luma;
pub mod msg;
pub mod node;
pub mod shutdown;

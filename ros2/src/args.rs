//! The command line: topics, QoS, and the computation's flags with the
//! names, defaults, parsers and checks of `reynoldsflow run` (the host's
//! value parsers), and first-frame handling as the GStreamer element's.

use clap::Parser;
use reynoldsflow_core::IntensityScale;
use reynoldsflow_host::outputs::Variant;
use reynoldsflow_host::settings::{self, FirstFrame, ScaleArg, Setting, Settings, parse_choice};
use ros2_client::Name;

/// Shown by `--help` below the flags.
const AFTER_HELP: &str = "\
Environment:
  ROS_DOMAIN_ID                     the DDS domain [default: 0]
  ROS_AUTOMATIC_DISCOVERY_RANGE     LOCALHOST keeps discovery and traffic on 127.0.0.1
  ROS_LOCALHOST_ONLY=1              the same (the pre-Jazzy variable)

Examples:
  reynoldsflow-ros2 --input /camera/image_raw
      /camera/image_raw (mono8, rgb8, bgr8, rgba8, bgra8) to /reynoldsflow/image (rgb8)
  reynoldsflow-ros2 --input image --cues --threads 2 --first-frame repeat
      also vision_msgs/Detection2DArray on reynoldsflow/cues; one output per frame
  reynoldsflow-ros2 --scale fixed:8,32 --variant dc0 --reliable
      fixed gains, the [|v_d|, 0, f] variant, reliable QoS";

/// `reynoldsflow-ros2`: the ReynoldsFlow representation of a camera topic.
#[derive(Debug, Parser)]
#[command(name = "reynoldsflow-ros2", version, about, after_help = AFTER_HELP)]
pub struct Args {
    /// sensor_msgs/Image to read: mono8, or rgb8, bgr8, rgba8, bgra8 (to
    /// BT.601 luma, as `reynoldsflow run` reads colour). Relative names are
    /// in --namespace.
    #[arg(
        long,
        value_name = "TOPIC",
        default_value = "image",
        help_heading = "Topics"
    )]
    pub input: String,
    /// Where the representation goes: sensor_msgs/Image, rgb8, the size of
    /// the input, with the header (stamp, frame_id) of the pair's first
    /// frame (of each frame with --first-frame repeat or black).
    #[arg(
        long,
        value_name = "TOPIC",
        default_value = "reynoldsflow/image",
        help_heading = "Topics"
    )]
    pub output: String,
    /// Also publish motion cues (vision_msgs/Detection2DArray, one
    /// detection per moving region, same header as the image) on TOPIC.
    #[arg(long, value_name = "TOPIC", num_args = 0..=1, require_equals = false,
          default_missing_value = "reynoldsflow/cues", help_heading = "Topics")]
    pub cues: Option<String>,
    /// The node's name.
    #[arg(
        long,
        value_name = "NAME",
        default_value = "reynoldsflow",
        help_heading = "Topics"
    )]
    pub node_name: String,
    /// The node's namespace (absolute).
    #[arg(long, value_name = "NS", default_value = "/", help_heading = "Topics")]
    pub namespace: String,

    /// Reliable QoS on both topics [default: the sensor-data profile, best
    /// effort]. A reliable reader does not match a best-effort camera.
    #[arg(long, help_heading = "QoS")]
    pub reliable: bool,
    /// History depth (keep last N) of the reader and the writers.
    #[arg(long, value_name = "N", default_value_t = 5,
          value_parser = clap::value_parser!(i32).range(1..=1000), help_heading = "QoS")]
    pub depth: i32,

    /// Magnitudes to bytes: per-frame min-max, or fixed gains KD (|v_d|)
    /// and KC (|v_c|), the same for every frame; the fixed engine rounds
    /// gains to 1/65536.
    #[arg(long, value_name = "minmax|fixed:KD,KC", default_value = "minmax",
          value_parser = settings::parse_scale, help_heading = "Computation")]
    pub scale: ScaleArg,
    /// Intensity scale s (f = pixel * s) as an exact ratio or decimal,
    /// 6144/2^32 <= s <= 1.
    #[arg(long, value_name = "S", default_value = "1/255",
          value_parser = settings::parse_intensity_scale, help_heading = "Computation")]
    pub intensity_scale: IntensityScale,
    /// Tikhonov term lambda of the 2x2 solve (rounded to 2^-32).
    #[arg(long, value_name = "L", default_value = "1e-4",
          value_parser = settings::parse_lambda, help_heading = "Computation")]
    pub lambda: f64,
    /// The image: dc = [|v_d|, |v_c|, f] (the ReynoldsFlow
    /// representation); dc0 = [|v_d|, 0, f]; cd = [|v_c|, |v_d|, f];
    /// hsv = colour wheel of v_R.
    #[arg(long, value_parser = parse_choice::<Variant>, default_value = "dc", help_heading = "Computation")]
    pub variant: Variant,
    /// Threads that compute each pair [default: all cores]. The output
    /// does not depend on it.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=1024),
          help_heading = "Computation")]
    pub threads: Option<u32>,
    /// What the first frame of a stream (and of each restart: a new size,
    /// encoding, or a stamp going back) gives: drop = nothing (N frames,
    /// N-1 outputs); repeat = a copy of the first result; black = an
    /// all-zero image. Then one output per frame, labelled with it.
    #[arg(long, value_parser = parse_choice::<FirstFrame>, default_value = "drop", help_heading = "Computation")]
    pub first_frame: FirstFrame,

    /// With --cues: a pixel moves when |v_c| is above this, px.
    #[arg(long, value_name = "PX", default_value_t = 1.0, help_heading = "Cues")]
    pub cue_threshold: f64,
    /// With --cues: regions of fewer moving pixels are dropped.
    #[arg(long, value_name = "N", default_value_t = 4, help_heading = "Cues")]
    pub cue_min_area: u32,
}

/// The node's flag for a host setting, as its messages name it (the
/// settings it has no flag for keep the host's names).
pub fn flag(setting: Setting) -> &'static str {
    match setting {
        Setting::Scale => "--scale",
        Setting::IntensityScale => "--intensity-scale",
        Setting::Lambda => "--lambda",
        Setting::Variant => "--variant",
        Setting::Threads => "--threads",
        Setting::FirstFrame => "--first-frame",
        Setting::CueThreshold => "--cue-threshold",
        Setting::CueMinArea => "--cue-min-area",
        setting => setting.name(),
    }
}

/// The topics, resolved to absolute names.
#[derive(Clone, Debug)]
pub struct Topics {
    /// Read.
    pub input: Name,
    /// Written.
    pub output: Name,
    /// Written when asked.
    pub cues: Option<Name>,
}

impl Args {
    /// The computation's settings (checked when the engine is built).
    pub fn settings(&self) -> Settings {
        Settings {
            scale: self.scale,
            intensity_scale: self.intensity_scale,
            lambda: self.lambda,
            variant: self.variant,
            threads: self.threads.map(|n| n as usize),
            first_frame: self.first_frame,
            cue_threshold: self.cue_threshold,
            cue_min_area: self.cue_min_area,
            ..Settings::default()
        }
    }

    /// The topics, relative ones in `--namespace`.
    pub fn topics(&self) -> Result<Topics, String> {
        let resolve = |flag: &str, topic: &str| {
            resolve(&self.namespace, topic).map_err(|why| format!("{flag} {topic}: {why}"))
        };
        Ok(Topics {
            input: resolve("--input", &self.input)?,
            output: resolve("--output", &self.output)?,
            cues: self
                .cues
                .as_deref()
                .map(|t| resolve("--cues", t))
                .transpose()?,
        })
    }
}

/// `topic` as an absolute name: itself when it starts with `/`, else in
/// `namespace`. (ros2-client 0.12 puts a relative name in the root
/// namespace under `rt//`, which no ROS 2 peer reads; absolute names avoid it.)
pub fn resolve(namespace: &str, topic: &str) -> Result<Name, String> {
    let full = if topic.starts_with('/') {
        topic.to_owned()
    } else {
        format!("{}/{topic}", namespace.trim_end_matches('/'))
    };
    if !full.starts_with('/') {
        return Err(format!("namespace '{namespace}' must start with /"));
    }
    Name::parse(&full).map_err(|e| {
        format!(
            "not a ROS 2 topic name ({e:?}): letters, digits and _ between single slashes, \
             no token starting with a digit"
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_issues_and_the_clis() {
        let args = Args::try_parse_from(["reynoldsflow-ros2"]).unwrap();
        let topics = args.topics().unwrap();
        assert_eq!(topics.input.to_string(), "/image");
        assert_eq!(topics.output.to_string(), "/reynoldsflow/image");
        assert!(topics.cues.is_none());
        assert!(!args.reliable);
        assert_eq!(args.first_frame, FirstFrame::Drop);
        assert!(matches!(args.scale, ScaleArg::MinMax));
        assert_eq!(args.lambda, 1e-4);
        assert_eq!(args.intensity_scale, IntensityScale::PER_255);
    }

    #[test]
    fn flags_parse_as_the_clis() {
        let args = Args::try_parse_from([
            "reynoldsflow-ros2",
            "--namespace",
            "/drone1",
            "--input",
            "camera/image_raw",
            "--cues",
            "--scale",
            "fixed:8,32",
            "--variant",
            "cd",
            "--threads",
            "1",
            "--first-frame",
            "black",
        ])
        .unwrap();
        let topics = args.topics().unwrap();
        assert_eq!(topics.input.to_string(), "/drone1/camera/image_raw");
        assert_eq!(topics.output.to_string(), "/drone1/reynoldsflow/image");
        assert_eq!(
            topics.cues.unwrap().to_string(),
            "/drone1/reynoldsflow/cues"
        );
        assert!(matches!(
            args.scale,
            ScaleArg::Fixed {
                k_d: 8.0,
                k_c: 32.0
            }
        ));
        assert_eq!(args.variant, Variant::Cd);
        assert_eq!(args.settings().threads, Some(1));
        // The CLI's own messages for bad values.
        let err = Args::try_parse_from(["reynoldsflow-ros2", "--lambda=-1"]).unwrap_err();
        assert!(err.to_string().contains("--lambda"), "{err}");
        let err = Args::try_parse_from(["reynoldsflow-ros2", "--threads", "0"]).unwrap_err();
        assert!(err.to_string().contains("--threads"), "{err}");
    }

    #[test]
    fn bad_topics_are_refused_naming_the_flag() {
        let args = Args::try_parse_from(["reynoldsflow-ros2", "--output", "9lives"]).unwrap();
        let err = args.topics().unwrap_err();
        assert!(err.starts_with("--output 9lives:"), "{err}");
        assert!(resolve("/", "a//b").is_err());
        assert!(resolve("relative", "b").is_err());
        assert_eq!(resolve("/ns/", "/abs/x").unwrap().to_string(), "/abs/x");
    }
}

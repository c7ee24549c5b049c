//! The command line: topics, QoS, and the computation's flags with the
//! names, defaults, parsers and checks of `reynoldsflow run` (the host's
//! settings and value parsers), and first-frame handling as the GStreamer
//! element's. Parsed with lexopt; `--help` lists every flag.

use std::ffi::OsString;
use std::fmt;

use lexopt::prelude::*;
use reynoldsflow_host::outputs::Variant;
use reynoldsflow_host::settings::{self, FirstFrame, Setting, Settings, parse_choice};
use ros2_client::Name;

/// `--input` when not given.
const DEFAULT_INPUT: &str = "image";
/// `--output` when not given.
const DEFAULT_OUTPUT: &str = "reynoldsflow/image";
/// `--cues` without a topic.
const DEFAULT_CUES: &str = "reynoldsflow/cues";
/// `--node-name` when not given.
const DEFAULT_NODE_NAME: &str = "reynoldsflow";
/// `--namespace` when not given.
const DEFAULT_NAMESPACE: &str = "/";
/// `--depth` when not given.
const DEFAULT_DEPTH: i32 = 5;

/// `reynoldsflow-ros2`: the ReynoldsFlow representation of a camera topic.
#[derive(Clone, Debug)]
pub struct Args {
    /// sensor_msgs/Image to read.
    pub input: String,
    /// Where the representation goes.
    pub output: String,
    /// Where the motion cues go, when asked.
    pub cues: Option<String>,
    /// The node's name.
    pub node_name: String,
    /// The node's namespace (absolute).
    pub namespace: String,
    /// Reliable QoS on both topics.
    pub reliable: bool,
    /// History depth (keep last N), 1 to 1000.
    pub depth: i32,
    /// The computation: scale, intensity scale, λ, variant, threads,
    /// first frame, cue threshold and area; the rest at the host's defaults.
    pub settings: Settings,
}

impl Default for Args {
    fn default() -> Self {
        Self {
            input: DEFAULT_INPUT.into(),
            output: DEFAULT_OUTPUT.into(),
            cues: None,
            node_name: DEFAULT_NODE_NAME.into(),
            namespace: DEFAULT_NAMESPACE.into(),
            reliable: false,
            depth: DEFAULT_DEPTH,
            settings: Settings::default(),
        }
    }
}

/// Why a command line gives no [`Args`]: help or the version asked for, or
/// a usage error. Its text is what to print ([`Exit::code`] says where).
#[derive(Debug, PartialEq)]
pub enum Exit {
    /// `-h`, `--help`.
    Help,
    /// `-V`, `--version`.
    Version,
    /// A flag or a value refused.
    Usage(String),
}

impl Exit {
    /// The process's exit code: 0 for help and version, 2 for a usage error.
    pub fn code(&self) -> u8 {
        match self {
            Exit::Usage(_) => 2,
            Exit::Help | Exit::Version => 0,
        }
    }
}

impl fmt::Display for Exit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Exit::Help => f.write_str(&help()),
            Exit::Version => write!(f, "reynoldsflow-ros2 {}", env!("CARGO_PKG_VERSION")),
            Exit::Usage(why) => write!(f, "error: {why}\n\nFor more information, try '--help'."),
        }
    }
}

/// The flags: name, value name (none for a switch), heading, help.
const FLAGS: &[(&str, &str, &str, &str)] = &[
    (
        "input",
        "<TOPIC>",
        "Topics",
        "sensor_msgs/Image to read: mono8, or rgb8, bgr8, rgba8, bgra8 (to BT.601 luma, as `reynoldsflow run` reads colour). Relative names are in --namespace",
    ),
    (
        "output",
        "<TOPIC>",
        "Topics",
        "Where the representation goes: sensor_msgs/Image, rgb8, the size of the input, with the header (stamp, frame_id) of the pair's first frame (of each frame with --first-frame repeat or black)",
    ),
    (
        "cues",
        "[<TOPIC>]",
        "Topics",
        "Also publish motion cues (vision_msgs/Detection2DArray, one detection per moving region, same header as the image) on TOPIC",
    ),
    ("node-name", "<NAME>", "Topics", "The node's name"),
    (
        "namespace",
        "<NS>",
        "Topics",
        "The node's namespace (absolute)",
    ),
    (
        "reliable",
        "",
        "QoS",
        "Reliable QoS on both topics [default: the sensor-data profile, best effort]. A reliable reader does not match a best-effort camera",
    ),
    (
        "depth",
        "<N>",
        "QoS",
        "History depth (keep last N) of the reader and the writers",
    ),
    (
        "scale",
        "<minmax|fixed:KD,KC>",
        "Computation",
        "Magnitudes to bytes: per-frame min-max, or fixed gains KD (|v_d|) and KC (|v_c|), the same for every frame; the fixed engine rounds gains to 1/65536",
    ),
    (
        "intensity-scale",
        "<S>",
        "Computation",
        "Intensity scale s (f = pixel * s) as an exact ratio or decimal, 6144/2^32 <= s <= 1",
    ),
    (
        "lambda",
        "<L>",
        "Computation",
        "Tikhonov term lambda of the 2x2 solve (rounded to 2^-32)",
    ),
    (
        "variant",
        "<VARIANT>",
        "Computation",
        "The image: dc = [|v_d|, |v_c|, f] (the ReynoldsFlow representation); dc0 = [|v_d|, 0, f]; cd = [|v_c|, |v_d|, f]; hsv = colour wheel of v_R",
    ),
    (
        "threads",
        "<N>",
        "Computation",
        "Threads that compute each pair [default: all cores]. The output does not depend on it",
    ),
    (
        "first-frame",
        "<FIRST_FRAME>",
        "Computation",
        "What the first frame of a stream (and of each restart: a new size, encoding, or a stamp going back) gives: drop = nothing (N frames, N-1 outputs); repeat = a copy of the first result; black = an all-zero image. Then one output per frame, labelled with it",
    ),
    (
        "cue-threshold",
        "<PX>",
        "Cues",
        "With --cues: a pixel moves when |v_c| is above this, px",
    ),
    (
        "cue-min-area",
        "<N>",
        "Cues",
        "With --cues: regions of fewer moving pixels are dropped",
    ),
];

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

/// A flag's default as `--help` shows it, if it has one to show.
fn default_of(flag: &str) -> Option<String> {
    let d = Settings::default();
    Some(match flag {
        "input" => DEFAULT_INPUT.into(),
        "output" => DEFAULT_OUTPUT.into(),
        "node-name" => DEFAULT_NODE_NAME.into(),
        "namespace" => DEFAULT_NAMESPACE.into(),
        "depth" => DEFAULT_DEPTH.to_string(),
        "scale" => d.scale.to_string(),
        "intensity-scale" => format!("{}/{}", d.intensity_scale.num(), d.intensity_scale.den()),
        "lambda" => format!("{:e}", d.lambda),
        "variant" => d.variant.name().into(),
        "first-frame" => d.first_frame.name().into(),
        "cue-threshold" => d.cue_threshold.to_string(),
        "cue-min-area" => d.cue_min_area.to_string(),
        _ => return None,
    })
}

/// The text of `--help`: the flags under their headings, each with its
/// default (the host's, for the computation's).
pub fn help() -> String {
    let mut out = format!(
        "{}\n\nUsage: reynoldsflow-ros2 [OPTIONS]\n\nOptions:\n  -h, --help     Print help\n  -V, --version  Print version\n",
        env!("CARGO_PKG_DESCRIPTION")
    );
    for heading in ["Topics", "QoS", "Computation", "Cues"] {
        let flags: Vec<_> = FLAGS.iter().filter(|f| f.2 == heading).collect();
        let width = flags
            .iter()
            .map(|f| usage(f.0, f.1).len())
            .max()
            .unwrap_or(0);
        out.push_str(&format!("\n{heading}:\n"));
        for &&(name, value, _, text) in &flags {
            let default = default_of(name).map_or(String::new(), |d| format!(" [default: {d}]"));
            out.push_str(&format!(
                "      {:width$}  {text}{default}\n",
                usage(name, value)
            ));
        }
    }
    out.push('\n');
    out.push_str(AFTER_HELP);
    out
}

/// `--name <VALUE>` as `--help` and the messages write it.
fn usage(name: &str, value: &str) -> String {
    match value {
        "" => format!("--{name}"),
        value => format!("--{name} {value}"),
    }
}

/// A refused value, in clap's words.
fn invalid(name: &str, value: &str, why: impl fmt::Display) -> Exit {
    let spec = FLAGS.iter().find(|f| f.0 == name).map_or(name, |f| f.1);
    Exit::Usage(format!(
        "invalid value '{value}' for '--{name} {spec}': {why}"
    ))
}

/// A value the host's parser checked, or its message.
fn checked<T>(name: &str, value: &str, parsed: Result<T, String>) -> Result<T, Exit> {
    parsed.map_err(|why| invalid(name, value, why))
}

/// An integer flag's value in `range`.
fn integer<T>(name: &str, value: &str, range: std::ops::RangeInclusive<T>) -> Result<T, Exit>
where
    T: std::str::FromStr + PartialOrd + fmt::Display,
    T::Err: fmt::Display,
{
    let n: T = value.parse().map_err(|e| invalid(name, value, e))?;
    if !range.contains(&n) {
        return Err(invalid(
            name,
            value,
            format!("{n} is not in {}..={}", range.start(), range.end()),
        ));
    }
    Ok(n)
}

impl Args {
    /// The command line `args` (the program's name first), checked.
    pub fn try_parse_from<I>(args: I) -> Result<Self, Exit>
    where
        I: IntoIterator,
        I::Item: Into<OsString>,
    {
        let mut parser = lexopt::Parser::from_iter(args);
        let mut a = Args::default();
        let mut seen: Vec<String> = Vec::new();
        while let Some(arg) = parser.next().map_err(usage_error)? {
            let name = match arg {
                Short('h') | Long("help") => return Err(Exit::Help),
                Short('V') | Long("version") => return Err(Exit::Version),
                Long(name) if FLAGS.iter().any(|f| f.0 == name) => name.to_owned(),
                Short(c) => return Err(unexpected(&format!("-{c}"))),
                Long(name) => return Err(unexpected(&format!("--{name}"))),
                Value(v) => return Err(unexpected(&v.to_string_lossy())),
            };
            if seen.contains(&name) {
                let spec = FLAGS.iter().find(|f| f.0 == name).map_or("", |f| f.1);
                return Err(Exit::Usage(format!(
                    "the argument '{}' cannot be used multiple times",
                    usage(&name, spec)
                )));
            }
            seen.push(name.clone());
            let s = &mut a.settings;
            match name.as_str() {
                "reliable" => a.reliable = true,
                "cues" => {
                    // An optional value: `--cues=T`, or `--cues T` where T is no flag.
                    let attached = parser.optional_value();
                    let next = match attached {
                        Some(v) => Some(v),
                        None => parser.try_raw_args().and_then(|mut raw| {
                            raw.next_if(|v| !v.to_string_lossy().starts_with('-'))
                        }),
                    };
                    a.cues = Some(match next {
                        Some(v) => text(&name, v)?,
                        None => DEFAULT_CUES.into(),
                    });
                }
                _ => {
                    let value = parser.value().map_err(|_| {
                        let spec = FLAGS.iter().find(|f| f.0 == name).map_or("", |f| f.1);
                        Exit::Usage(format!(
                            "a value is required for '{}' but none was supplied",
                            usage(&name, spec)
                        ))
                    })?;
                    let v = text(&name, value)?;
                    let v = v.as_str();
                    match name.as_str() {
                        "input" => a.input = v.into(),
                        "output" => a.output = v.into(),
                        "node-name" => a.node_name = v.into(),
                        "namespace" => a.namespace = v.into(),
                        "depth" => a.depth = integer(&name, v, 1..=1000)?,
                        "scale" => s.scale = checked(&name, v, settings::parse_scale(v))?,
                        "intensity-scale" => {
                            s.intensity_scale =
                                checked(&name, v, settings::parse_intensity_scale(v))?
                        }
                        "lambda" => s.lambda = checked(&name, v, settings::parse_lambda(v))?,
                        "variant" => s.variant = checked(&name, v, parse_choice::<Variant>(v))?,
                        "threads" => s.threads = Some(integer::<u32>(&name, v, 1..=1024)? as usize),
                        "first-frame" => {
                            s.first_frame = checked(&name, v, parse_choice::<FirstFrame>(v))?
                        }
                        "cue-threshold" => {
                            s.cue_threshold = v.parse().map_err(|e| invalid(&name, v, e))?
                        }
                        "cue-min-area" => {
                            s.cue_min_area = v.parse().map_err(|e| invalid(&name, v, e))?
                        }
                        other => unreachable!("--{other} is in FLAGS and handled above"),
                    }
                }
            }
        }
        Ok(a)
    }

    /// The computation's settings (checked when the engine is built).
    pub fn settings(&self) -> Settings {
        self.settings.clone()
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

/// A value as text, or the message clap gives for one that is not UTF-8.
fn text(name: &str, value: OsString) -> Result<String, Exit> {
    value
        .into_string()
        .map_err(|v| invalid(name, &v.to_string_lossy(), "invalid UTF-8"))
}

/// An argument the node does not take.
fn unexpected(arg: &str) -> Exit {
    Exit::Usage(format!(
        "unexpected argument '{arg}' found\n\nUsage: reynoldsflow-ros2 [OPTIONS]"
    ))
}

/// lexopt's own refusals (a value given to a switch), in clap's words.
fn usage_error(e: lexopt::Error) -> Exit {
    match e {
        lexopt::Error::UnexpectedValue { option, value } => Exit::Usage(format!(
            "unexpected value '{}' for '{option}' found; no more were expected",
            value.to_string_lossy()
        )),
        e => Exit::Usage(e.to_string()),
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
    use reynoldsflow_host::settings::ScaleArg;

    use super::*;

    #[test]
    fn defaults_are_the_hosts_settings() {
        let args = Args::try_parse_from(["reynoldsflow-ros2"]).unwrap();
        assert_eq!(args.settings(), Settings::default());
        let topics = args.topics().unwrap();
        assert_eq!(topics.input.to_string(), "/image");
        assert_eq!(topics.output.to_string(), "/reynoldsflow/image");
        assert!(topics.cues.is_none());
        assert!(!args.reliable);
        assert_eq!(args.depth, 5);
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
            "--variant=cd",
            "--threads",
            "1",
            "--first-frame",
            "black",
            "--cue-threshold",
            "0.5",
            "--cue-min-area=9",
            "--reliable",
            "--depth",
            "7",
            "--lambda",
            "2e-4",
            "--intensity-scale",
            "2/255",
        ])
        .unwrap();
        let topics = args.topics().unwrap();
        assert_eq!(topics.input.to_string(), "/drone1/camera/image_raw");
        assert_eq!(topics.output.to_string(), "/drone1/reynoldsflow/image");
        assert_eq!(
            topics.cues.unwrap().to_string(),
            "/drone1/reynoldsflow/cues"
        );
        let s = args.settings();
        assert_eq!(
            s.scale,
            ScaleArg::Fixed {
                k_d: 8.0,
                k_c: 32.0
            }
        );
        assert_eq!(s.variant, Variant::Cd);
        assert_eq!(s.threads, Some(1));
        assert_eq!(s.first_frame, FirstFrame::Black);
        assert_eq!((s.cue_threshold, s.cue_min_area), (0.5, 9));
        assert_eq!((s.lambda, s.intensity_scale.den()), (2e-4, 255));
        assert_eq!((args.reliable, args.depth), (true, 7));
        // `--cues TOPIC` and `--cues=TOPIC`; a flag after `--cues` is no topic.
        for line in [&["--cues", "moving"][..], &["--cues=moving"]] {
            let args = Args::try_parse_from(["reynoldsflow-ros2"].iter().chain(line)).unwrap();
            assert_eq!(args.cues.as_deref(), Some("moving"));
        }
        let args = Args::try_parse_from(["reynoldsflow-ros2", "--cues", "--reliable"]).unwrap();
        assert_eq!(
            (args.cues.as_deref(), args.reliable),
            (Some(DEFAULT_CUES), true)
        );
    }

    #[test]
    fn refusals_say_what_and_name_the_flag() {
        let err = |line: &[&str]| {
            let args = ["reynoldsflow-ros2"].iter().chain(line);
            Args::try_parse_from(args).unwrap_err().to_string()
        };
        let cases: [(&[&str], &str); 9] = [
            (
                &["--lambda=-1"],
                "invalid value '-1' for '--lambda <L>': expected a positive number (e.g. 1e-4)",
            ),
            (
                &["--threads", "0"],
                "invalid value '0' for '--threads <N>': 0 is not in 1..=1024",
            ),
            (
                &["--variant", "x"],
                "invalid value 'x' for '--variant <VARIANT>': 'x': expected one of dc, dc0, cd, hsv",
            ),
            (
                &["--depth", "1001"],
                "invalid value '1001' for '--depth <N>': 1001 is not in 1..=1000",
            ),
            (&["--bogus"], "unexpected argument '--bogus' found"),
            (&["image"], "unexpected argument 'image' found"),
            (
                &["--input"],
                "a value is required for '--input <TOPIC>' but none was supplied",
            ),
            (
                &["--reliable=yes"],
                "unexpected value 'yes' for '--reliable' found",
            ),
            (
                &["--input", "a", "--input", "b"],
                "the argument '--input <TOPIC>' cannot be used multiple times",
            ),
        ];
        for (line, message) in cases {
            let text = err(line);
            assert!(
                text.starts_with(&format!("error: {message}")),
                "{line:?}: {text}"
            );
            assert!(
                text.ends_with("For more information, try '--help'."),
                "{text}"
            );
        }
        assert_eq!(
            Args::try_parse_from(["r", "--help"]).unwrap_err(),
            Exit::Help
        );
        assert_eq!(Args::try_parse_from(["r", "-V"]).unwrap_err().code(), 0);
        assert_eq!(Args::try_parse_from(["r", "--x"]).unwrap_err().code(), 2);
    }

    #[test]
    fn help_lists_every_flag_with_its_default() {
        let help = help();
        for (name, value, heading, _) in FLAGS {
            assert!(help.contains(&format!("\n{heading}:\n")), "{heading}");
            assert!(
                help.contains(&format!("      {}", usage(name, value))),
                "{name}"
            );
        }
        assert!(help.contains("--lambda <L>                  Tikhonov term lambda of the 2x2 solve (rounded to 2^-32) [default: 1e-4]\n"));
        assert!(help.contains("--intensity-scale <S>         Intensity scale s (f = pixel * s) as an exact ratio or decimal, 6144/2^32 <= s <= 1 [default: 1/255]\n"));
        assert!(help.contains("--cue-threshold <PX>  With --cues: a pixel moves when |v_c| is above this, px [default: 1]\n"));
        assert!(help.ends_with("reliable QoS"));
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

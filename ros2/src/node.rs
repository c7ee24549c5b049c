//! The ROS 2 side: a node with one subscription and one or two
//! publishers, and the loop that turns each received image into the
//! outputs the host's [`PairStream`] says, computed by its [`PairEngine`].
//!
//! One thread takes the messages in order and computes each pair (on
//! `--threads` threads); RustDDS receives and reassembles fragments on its
//! own threads meanwhile, keeping the last `--depth` images. The loop wakes
//! on data or every 100 ms to see whether a stop was asked for.

use std::time::{Duration, Instant};

use reynoldsflow_cues::{CueError, Region};
use reynoldsflow_host::cues::Cues;
use reynoldsflow_host::engine::PairEngine;
use reynoldsflow_host::pair_stream::{Frame, Output, PairStream};
use reynoldsflow_host::{Gray, HostError};
use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
use ros2_client::dds::{Context, Node, Publisher, Subscription};
use ros2_client::qos::{Durability, History, Reliability, WhenFull};
use ros2_client::{NodeName, NodeOptions, QosProfile};

use crate::args::{self, Args, Topics};
use crate::cues;
use crate::discovery::Discovery;
use crate::log::Log;
use crate::luma;
use crate::msg::{Detection2DArray, Header, Image, Time};
use crate::shutdown::Stop;

/// Why the node could not start. Each says what to change.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// A flag's value.
    #[error("{0}")]
    Usage(String),
    /// A computation flag, named by its flag.
    #[error("{}", settings_message(.0))]
    Settings(#[from] HostError),
    /// A ROS environment variable.
    #[error("{0}")]
    Environment(String),
    /// DDS refused to start (a port in use, no interface, ...).
    #[error("could not start DDS ({what}): {why}")]
    Dds {
        /// What was being made.
        what: &'static str,
        /// The middleware's words.
        why: String,
    },
    /// The signal handler.
    #[error("could not install the SIGINT/SIGTERM handler: {0}")]
    Signal(#[from] ctrlc::Error),
}

/// A host error, a setting named by its flag.
fn settings_message(e: &HostError) -> String {
    match e {
        HostError::Setting { setting, problem } => format!("{}: {problem}", args::flag(*setting)),
        e => e.to_string(),
    }
}

fn dds<E: std::fmt::Debug>(what: &'static str) -> impl FnOnce(E) -> NodeError {
    move |e| NodeError::Dds {
        what,
        why: format!("{e:?}"),
    }
}

/// What a run did, told when it stops.
#[derive(Debug, Default)]
pub struct Summary {
    /// Images received.
    pub frames: u64,
    /// Images published.
    pub outputs: u64,
    /// Seconds spent computing pairs.
    pub compute_seconds: f64,
    /// Seconds spent on images from their decoding to their outputs'
    /// publication (computing included).
    pub busy_seconds: f64,
    /// Pairs computed.
    pub pairs: u64,
}

/// The node's DDS entities.
struct Endpoints {
    // Kept first so they drop before the node and context below.
    input: Subscription<Image>,
    output: Publisher<Image>,
    cues: Option<Publisher<Detection2DArray>>,
    node: Node,
    _context: Context,
}

/// The QoS of every topic: the sensor-data profile (best effort, volatile,
/// keep last `depth`), or reliable with `--reliable`.
fn qos(args: &Args) -> QosProfile {
    let reliability = if args.reliable {
        // Block the publisher briefly rather than drop when a reader lags.
        Reliability::Reliable {
            when_full: WhenFull::Wait(Duration::from_millis(500)),
        }
    } else {
        Reliability::BestEffort
    };
    QosProfile::subscription_default()
        .reliability(reliability)
        .durability(Durability::Volatile)
        .history(History::KeepLast {
            depth: args.depth.max(1) as usize,
        })
}

fn endpoints(args: &Args, topics: &Topics, discovery: &Discovery) -> Result<Endpoints, NodeError> {
    let participant = discovery
        .participant()
        .build()
        .map_err(dds("the domain participant"))?;
    let context = Context::from_domain_participant(participant).map_err(dds("the ROS context"))?;
    let name = NodeName::new(&args.namespace, &args.node_name).map_err(|e| {
        NodeError::Usage(format!(
            "--namespace {} --node-name {}: not a node name ({e:?})",
            args.namespace, args.node_name
        ))
    })?;
    let mut node = context
        .new_node(name, NodeOptions::new().enable_rosout(true))
        .map_err(dds("the node"))?;
    let qos = qos(args);
    let topic = |node: &Node, name, ty| node.create_topic(name, ty, &qos).map_err(dds("a topic"));
    let input = topic(&node, &topics.input, Image::type_name())?;
    let output = topic(&node, &topics.output, Image::type_name())?;
    let cue_topic = match &topics.cues {
        Some(name) => Some(topic(&node, name, Detection2DArray::type_name())?),
        None => None,
    };
    Ok(Endpoints {
        input: node
            .create_subscription(&input, None)
            .map_err(dds("the subscription"))?,
        output: node
            .create_publisher(&output, None)
            .map_err(dds("the publisher"))?,
        cues: match cue_topic {
            Some(t) => Some(
                node.create_publisher(&t, None)
                    .map_err(dds("the cue publisher"))?,
            ),
            None => None,
        },
        node,
        _context: context,
    })
}

/// Run the node until SIGINT or SIGTERM.
pub fn run(args: &Args) -> Result<Summary, NodeError> {
    let topics = args.topics().map_err(NodeError::Usage)?;
    let discovery =
        Discovery::from_env(|k| std::env::var(k).ok()).map_err(NodeError::Environment)?;
    let settings = args.settings();
    let engine = PairEngine::new(&settings)?.keep_magnitudes(args.cues.is_some());
    let cues = match args.cues {
        Some(_) => Some(Cues::new(&settings)?),
        None => None,
    };
    let stop = Stop::install()?;
    let mut endpoints = endpoints(args, &topics, &discovery)?;
    let log = Log::stderr().with_rosout(endpoints.node.logging_handle());
    let cues_topic = topics
        .cues
        .as_ref()
        .map_or(String::new(), |c| format!(", cues on {c}"));
    log.info(&format!(
        "{} -> {} (rgb8{cues_topic}), variant {}, {} thread(s), {}, {} QoS",
        topics.input,
        topics.output,
        settings.variant.name(),
        engine.threads(),
        discovery.describe(),
        if args.reliable {
            "reliable"
        } else {
            "best-effort"
        },
    ));

    let mut poll = Poll::new().map_err(dds("the poller"))?;
    poll.registry()
        .register(&mut endpoints.input, Token(0), Interest::READABLE)
        .map_err(dds("the poller"))?;
    let mut events = Events::with_capacity(8);
    let mut stream = Stream {
        pairs: PairStream::new(settings.first_frame),
        engine,
        cues,
        log,
        summary: Summary::default(),
        input: topics.input.to_string(),
    };
    while !stop.requested() {
        // Interrupted polls (the signal itself) just go round again.
        let _ = poll.poll(&mut events, Some(Duration::from_millis(100)));
        // Edge-triggered: take everything that has arrived.
        while !stop.requested() {
            match endpoints.input.take() {
                Ok(Some((image, _info))) => {
                    let started = Instant::now();
                    stream.image(image, &endpoints);
                    stream.summary.busy_seconds += started.elapsed().as_secs_f64();
                }
                Ok(None) => break,
                Err(e) => {
                    stream.log.repeated(
                        "undecodable",
                        &format!(
                            "dropped a message on {} that is no sensor_msgs/Image: {e}",
                            stream.input
                        ),
                    );
                    break;
                }
            }
        }
    }
    stream.end(&endpoints);
    stream.stopped();
    Ok(stream.summary)
}

/// The input stream's state.
struct Stream {
    pairs: PairStream<Header>,
    engine: PairEngine,
    cues: Option<Cues>,
    log: Log,
    summary: Summary,
    input: String,
}

/// A pair's image and, when asked, its cues' regions.
struct PairImage {
    width: usize,
    height: usize,
    rgb: Vec<u8>,
    regions: Option<Result<Vec<Region>, CueError>>,
}

/// The pair `(prev, next)` through the engine, and its cues when asked;
/// its time counted in `summary`.
fn pair(
    engine: &mut PairEngine,
    cues: &mut Option<Cues>,
    summary: &mut Summary,
    prev: &Gray,
    next: &Gray,
) -> Result<PairImage, HostError> {
    let started = Instant::now();
    let rgb = engine.image_vec(prev, next)?;
    let regions = match (cues.as_mut(), engine.magnitudes()) {
        (Some(cues), Some(pair)) => Some(cues.regions(&pair).map(<[Region]>::to_vec)),
        _ => None,
    };
    summary.compute_seconds += started.elapsed().as_secs_f64();
    summary.pairs += 1;
    let (width, height) = prev.size();
    Ok(PairImage {
        width,
        height,
        rgb,
        regions,
    })
}

/// A stamp in nanoseconds.
fn nanoseconds(t: &Time) -> i128 {
    i128::from(t.sec) * 1_000_000_000 + i128::from(t.nanosec)
}

impl Stream {
    /// One received image: refused, a first frame, or a pair.
    fn image(&mut self, image: Image, out: &Endpoints) {
        self.summary.frames += 1;
        let (gray, encoding) = match luma::gray(&image) {
            Ok(frame) => frame,
            Err(e) => {
                let line = format!(
                    "dropped an image on {} (stamp {}, frame_id '{}'): {e}",
                    self.input, image.header.stamp, image.header.frame_id
                );
                self.log.repeated(&e.kind(), &line);
                return;
            }
        };
        let header = image.header;
        drop(image.data);
        let frame = Frame {
            gray,
            encoding: encoding.name(),
            stamp: Some(nanoseconds(&header.stamp)),
            label: header,
        };
        let (engine, cues, summary) = (&mut self.engine, &mut self.cues, &mut self.summary);
        let step = self
            .pairs
            .push(frame, |prev, next| pair(engine, cues, summary, prev, next));
        match step {
            Ok(step) => {
                if let Some(restart) = &step.restart {
                    self.log
                        .info(&format!("{} restarts its pairs: {restart}", self.input));
                }
                self.publish(step.outputs, out);
            }
            Err(e) => self.log.repeated(
                "pair",
                &format!(
                    "could not compute a pair on {}: {}; the next frame starts anew",
                    self.input,
                    settings_message(&e)
                ),
            ),
        }
    }

    /// The input stops: the output its last frame still owes (`first-frame repeat`).
    fn end(&mut self, out: &Endpoints) {
        let (engine, cues, summary) = (&mut self.engine, &mut self.cues, &mut self.summary);
        match self
            .pairs
            .end(|prev, next| pair(engine, cues, summary, prev, next))
        {
            Ok(owed) => self.publish(owed.into_iter().collect(), out),
            Err(e) => self
                .log
                .repeated("pair", &format!("could not compute a pair: {e}")),
        }
    }

    fn publish(&mut self, outputs: Vec<Output<PairImage, Header>>, out: &Endpoints) {
        for output in outputs {
            match output {
                Output::Black {
                    width,
                    height,
                    label,
                } => {
                    self.send_cues(out, &label, &[]);
                    self.send(out, label, width, height, vec![0; 3 * width * height]);
                }
                Output::Result { result, labels } => self.publish_result(result, labels, out),
            }
        }
    }

    fn publish_result(&mut self, image: PairImage, labels: Vec<Header>, out: &Endpoints) {
        let PairImage {
            width,
            height,
            rgb,
            regions,
        } = image;
        let regions = match regions {
            Some(Ok(regions)) => Some(regions),
            Some(Err(e)) => {
                self.log.repeated(
                    "cues",
                    &format!(
                        "no cues for {width}x{height} frames: {e} (they cover up to {} px a side)",
                        cues::MAX_SIDE
                    ),
                );
                None
            }
            None => None,
        };
        let last = labels.len().saturating_sub(1);
        let mut rgb = Some(rgb);
        for (i, header) in labels.into_iter().enumerate() {
            // The copy of `first-frame repeat` clones; the last send moves.
            let data = if i == last { rgb.take() } else { rgb.clone() }.unwrap_or_default();
            if let Some(regions) = &regions {
                self.send_cues(out, &header, regions);
            }
            self.send(out, header, width, height, data);
        }
    }

    fn send(
        &mut self,
        out: &Endpoints,
        header: Header,
        width: usize,
        height: usize,
        data: Vec<u8>,
    ) {
        let image = Image {
            header,
            height: height as u32,
            width: width as u32,
            encoding: "rgb8".into(),
            is_bigendian: 0,
            step: 3 * width as u32,
            data,
        };
        match out.output.publish(image) {
            Ok(()) => self.summary.outputs += 1,
            Err(e) => self
                .log
                .repeated("publish", &format!("could not publish an image: {e}")),
        }
    }

    fn send_cues(&mut self, out: &Endpoints, header: &Header, regions: &[Region]) {
        if let Some(publisher) = &out.cues
            && let Err(e) = publisher.publish(cues::detections(header, regions))
        {
            self.log
                .repeated("publish cues", &format!("could not publish cues: {e}"));
        }
    }

    /// The closing line.
    fn stopped(&self) {
        let s = &self.summary;
        let rate = if s.compute_seconds > 0.0 {
            format!(
                ", {:.1} pairs/s computing, {:.1} handling (image in to outputs sent)",
                s.pairs as f64 / s.compute_seconds,
                s.pairs as f64 / s.busy_seconds
            )
        } else {
            String::new()
        };
        let mut refused: Vec<String> = self
            .log
            .counts()
            .map(|(k, n)| format!("{n} ({k})"))
            .collect();
        refused.sort();
        let refused = if refused.is_empty() {
            String::new()
        } else {
            format!("; problems: {}", refused.join(", "))
        };
        self.log.info(&format!(
            "stopped: {} images in, {} out{rate}{refused}",
            s.frames, s.outputs
        ));
    }
}

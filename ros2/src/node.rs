//! The ROS 2 side: a node with one subscription and one or two
//! publishers, and the loop that turns each received image into the
//! outputs [`Pairing`] says, computed by [`PairComputer`].
//!
//! One thread takes the messages in order and computes each pair (on
//! `--threads` threads); RustDDS receives and reassembles fragments on its
//! own threads meanwhile, keeping the last `--depth` images. The loop wakes
//! on data or every 100 ms to see whether a stop was asked for.

use std::time::{Duration, Instant};

use reynoldsflow_cues::{CueError, Region};
use reynoldsflow_host::HostError;
use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
use ros2_client::dds::{Context, Node, Publisher, Subscription};
use ros2_client::qos::{Durability, History, Reliability, WhenFull};
use ros2_client::{NodeName, NodeOptions, QosProfile};

use crate::args::{Args, Topics};
use crate::compute::PairComputer;
use crate::cues::{self, Cues};
use crate::discovery::Discovery;
use crate::log::Log;
use crate::luma;
use crate::msg::{Detection2DArray, Header, Image};
use crate::pairing::{Frame, Pairing, Step};
use crate::shutdown::Stop;

/// Why the node could not start. Each says what to change.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// A flag's value.
    #[error("{0}")]
    Usage(String),
    /// A computation flag, in the CLI's words.
    #[error("{0}")]
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
    let computer = PairComputer::new(&args.settings(), args.cues.is_some())?;
    let cues = match args.cues {
        Some(_) => Some(Cues::new(args.cue_settings()).map_err(NodeError::Usage)?),
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
        args.variant.name(),
        args.settings().threads(),
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
        pairing: Pairing::new(args.first_frame),
        computer,
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
    stream.stopped();
    Ok(stream.summary)
}

/// The input stream's state.
struct Stream {
    pairing: Pairing,
    computer: PairComputer,
    cues: Option<Cues>,
    log: Log,
    summary: Summary,
    input: String,
}

/// What a pair gives besides its image: the cues' regions, when asked.
type PairCues = Option<Result<Vec<Region>, CueError>>;

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
        let (width, height) = (gray.width, gray.height);
        let header = image.header;
        drop(image.data);
        let (computer, cues, summary) = (&mut self.computer, &mut self.cues, &mut self.summary);
        let step = self.pairing.push(
            Frame {
                gray,
                encoding,
                header,
            },
            |prev, next| {
                let started = Instant::now();
                let (rgb, regions) = computer.pair(prev, next, |pixels| {
                    cues.as_mut().map(|c| c.regions(width, height, pixels))
                })?;
                summary.compute_seconds += started.elapsed().as_secs_f64();
                summary.pairs += 1;
                Ok::<_, HostError>((rgb, regions.flatten()))
            },
        );
        match step {
            Ok(step) => self.publish(step, width, height, out),
            Err(e) => self.log.repeated(
                "pair",
                &format!(
                    "could not compute a pair on {}: {e}; the next frame starts anew",
                    self.input
                ),
            ),
        }
    }

    fn publish(
        &mut self,
        step: Step<(Vec<u8>, PairCues)>,
        width: usize,
        height: usize,
        out: &Endpoints,
    ) {
        if let Some(restart) = &step.restart {
            self.log
                .info(&format!("{} restarts its pairs: {restart}", self.input));
        }
        if let Some((w, h, header)) = step.black {
            self.send(out, header.clone(), w, h, vec![0; 3 * w * h]);
            self.send_cues(out, &header, &[]);
        }
        let Some(((rgb, regions), headers)) = step.result else {
            return;
        };
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
        let last = headers.len().saturating_sub(1);
        let mut rgb = Some(rgb);
        for (i, header) in headers.into_iter().enumerate() {
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

//! The node's cue topic end to end: the `reynoldsflow-ros2` binary as its
//! own process, a ros2-client peer publishing a moving square and reading
//! both outputs. Each `vision_msgs/Detection2DArray` must carry its image's
//! header and the regions the cues crate finds on the host's pixels of the
//! same pair; each image the bytes of the same computation.
//!
//! Ignored by `cargo test`: it opens DDS sockets. scripts/test-ros2 runs
//! it (`--ignored`) inside a network namespace that has only a loopback
//! interface; the node and this peer are on 127.0.0.1 only in any case.

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use reynoldsflow_host::Gray;
use reynoldsflow_host::cues::Cues;
use reynoldsflow_host::outputs::OutputSpec;
use reynoldsflow_host::settings::Settings;
use reynoldsflow_ros2::cues;
use reynoldsflow_ros2::discovery::Discovery;
use reynoldsflow_ros2::msg::{Detection2DArray, Header, Image, Time};
use ros2_client::dds::{Context, Node, Publisher, Subscription};
use ros2_client::{Name, NodeName, NodeOptions, QosProfile};

const W: usize = 96;
const H: usize = 64;
const FRAMES: usize = 8;

/// A textured square moving 2 px right per frame over a still texture.
fn frame(n: usize) -> Vec<u8> {
    (0..W * H)
        .map(|i| {
            let (x, y) = (i % W, i / W);
            let (sx, sy) = (x.wrapping_sub(20 + 2 * n), y.wrapping_sub(20));
            if sx < 16 && sy < 16 {
                (200 + (sx * 7 + sy * 3) % 50) as u8
            } else {
                ((x * 3 + y * 5) % 40) as u8
            }
        })
        .collect()
}

fn image(width: usize, height: usize, data: Vec<u8>, sec: i32) -> Image {
    Image {
        header: Header {
            stamp: Time { sec, nanosec: 0 },
            frame_id: "test_camera".into(),
        },
        height: height as u32,
        width: width as u32,
        encoding: "mono8".into(),
        is_bigendian: 0,
        step: width as u32,
        data,
    }
}

/// Stops the node (SIGINT) and checks it exits 0, also when the test fails.
struct NodeProcess(Child);

impl NodeProcess {
    fn stop(mut self) -> std::process::ExitStatus {
        signal_interrupt(&self.0);
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            if let Some(status) = self.0.try_wait().unwrap() {
                return status;
            }
            assert!(
                Instant::now() < deadline,
                "the node did not stop within 10 s of SIGINT"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for NodeProcess {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn signal_interrupt(child: &Child) {
    // `kill -INT`: std has no portable signal sending.
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
}

struct Peer {
    _context: Context,
    _node: Node,
    images: Publisher<Image>,
    outputs: Subscription<Image>,
    cues: Subscription<Detection2DArray>,
}

fn peer(domain_id: u16) -> Peer {
    let discovery = Discovery {
        domain_id,
        localhost_only: true,
    };
    let context =
        Context::from_domain_participant(discovery.participant().build().unwrap()).unwrap();
    let mut node = context
        .new_node(
            NodeName::new("/", "cues_test_peer").unwrap(),
            NodeOptions::new(),
        )
        .unwrap();
    let qos = QosProfile::subscription_default()
        .history(ros2_client::qos::History::KeepLast { depth: 16 });
    let topic = |name: &str, ty| {
        node.create_topic(&Name::parse(name).unwrap(), ty, &qos)
            .unwrap()
    };
    let (input, output, cue_topic) = (
        topic("/image", Image::type_name()),
        topic("/reynoldsflow/image", Image::type_name()),
        topic("/reynoldsflow/cues", Detection2DArray::type_name()),
    );
    Peer {
        images: node.create_publisher(&input, None).unwrap(),
        outputs: node.create_subscription(&output, None).unwrap(),
        cues: node.create_subscription(&cue_topic, None).unwrap(),
        _node: node,
        _context: context,
    }
}

/// Take from `sub` until `done` says so or `seconds` pass.
fn take_until<M: 'static + serde::de::DeserializeOwned>(
    sub: &Subscription<M>,
    got: &mut Vec<M>,
    done: impl Fn(&[M]) -> bool,
    seconds: u64,
) -> bool {
    let deadline = Instant::now() + Duration::from_secs(seconds);
    while !done(got) {
        match sub.take() {
            Ok(Some((m, _))) => got.push(m),
            Ok(None) if Instant::now() > deadline => return false,
            Ok(None) => std::thread::sleep(Duration::from_millis(5)),
            Err(e) => panic!("reading a sample: {e:?}"),
        }
    }
    true
}

#[test]
#[ignore = "DDS on loopback; scripts/test-ros2 runs it in a network namespace of its own"]
fn cues_carry_the_regions_of_the_pair_under_its_header() {
    // The cue grid is built by value (512 KiB), past a test thread's stack.
    std::thread::Builder::new()
        .stack_size(16 << 20)
        .spawn(cues_end_to_end)
        .unwrap()
        .join()
        .unwrap();
}

fn cues_end_to_end() {
    let domain_id = Discovery::from_env(|k| std::env::var(k).ok())
        .unwrap()
        .domain_id;
    let node = NodeProcess(
        Command::new(env!("CARGO_BIN_EXE_reynoldsflow-ros2"))
            .args(["--cues", "--threads", "1", "--depth", "16"])
            .env("ROS_DOMAIN_ID", domain_id.to_string())
            .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
            .stdin(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let peer = peer(domain_id);

    // Warm up: 8x8 frames until the node answers, so both ways are matched.
    let (mut images, mut detections) = (Vec::new(), Vec::new());
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut i = 0;
    while images.is_empty() {
        assert!(Instant::now() < deadline, "no answer from the node in 30 s");
        peer.images
            .publish(image(8, 8, vec![i as u8; 64], 0))
            .unwrap();
        i += 1;
        take_until(&peer.outputs, &mut images, |v| !v.is_empty(), 0);
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(Duration::from_millis(300));
    take_until(&peer.outputs, &mut images, |_| false, 0);
    take_until(&peer.cues, &mut detections, |_| false, 0);
    images.clear();
    detections.clear();

    for n in 0..FRAMES {
        peer.images
            .publish(image(W, H, frame(n), 10 + n as i32))
            .unwrap();
        let want = n; // drop: frame n > 0 completes pair n - 1
        assert!(
            take_until(&peer.outputs, &mut images, |v| v.len() >= want, 20),
            "frame {n}: {} images, {want} expected",
            images.len()
        );
    }
    assert!(take_until(
        &peer.cues,
        &mut detections,
        |v| v.len() >= FRAMES - 1,
        20
    ));
    assert_eq!(images.len(), FRAMES - 1);
    assert_eq!(detections.len(), FRAMES - 1);

    // The same pairs through the host's computation of a pair (`run`'s
    // bytes) and the cues crate on the core's magnitudes, here.
    let settings = Settings::default();
    let compute = settings.compute().unwrap();
    let mut cue_finder = Cues::new(&settings).unwrap();
    let mut moving = 0;
    for n in 0..FRAMES - 1 {
        let (a, b) = (frame(n), frame(n + 1));
        let (a, b) = (Gray::new(W, H, a).unwrap(), Gray::new(W, H, b).unwrap());
        let fields = compute.pair(&a, &b).unwrap();
        let fixed = reynoldsflow_host::internals::compute_fixed(
            &a,
            &b,
            reynoldsflow_core::Params::DEFAULT,
            None,
            reynoldsflow_core::Scaling::PerFrameMinMax,
        )
        .unwrap();
        let (m_d, m_c): (Vec<f32>, Vec<f32>) = fixed
            .m_d
            .iter()
            .zip(&fixed.m_c)
            .map(|(&d, &c)| (d as f32, c as f32))
            .unzip();
        let magnitudes = reynoldsflow_host::engine::Magnitudes {
            width: W,
            height: H,
            m_d: &m_d,
            m_c: &m_c,
            luma: &a.pixels,
        };
        let regions = cue_finder.regions(&magnitudes).unwrap().to_vec();
        let header = image(W, H, Vec::new(), 10 + n as i32).header;
        assert_eq!(
            images[n].header, header,
            "output {n} carries frame {n}'s header"
        );
        assert!(
            images[n].data == OutputSpec::default().image(&fields),
            "output {n}: bytes"
        );
        assert_eq!(
            detections[n],
            cues::detections(&header, &regions),
            "output {n}: cues"
        );
        moving += usize::from(!regions.is_empty());
    }
    assert_eq!(
        moving,
        FRAMES - 1,
        "the square is found moving in every pair"
    );
    let d = &detections[0].detections[0];
    assert!(d.bbox.size_x >= 16.0 && d.bbox.size_y >= 16.0, "{d:?}");

    drop(peer);
    assert!(node.stop().success(), "the node exits 0 on SIGINT");
}

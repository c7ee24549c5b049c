//! The `reynoldsflow` element in-process (gst_check's harness), against
//! `reynoldsflow run` run in-process on the same frames (its PNG outputs)
//! and against the core's `MotionCues` run on its own.

use std::path::{Path, PathBuf};
use std::sync::Once;

use gst::prelude::*;
use gst_check::Harness;
use gst_video::prelude::*;
use gst_video::{VideoFormat, VideoInfo, VideoRegionOfInterestMeta};
use gstreynoldsflow::cues::{self, CELL, REGION_STRUCTURE, REGIONS, ROI_TYPE};
use reynoldsflow_core::{Config, FramePair, Params, Plan};
use reynoldsflow_cues::{MotionCues, Region, grid_cells};
use reynoldsflow_host::{fixed_engine, image_io};

/// GStreamer with a registry of its own (never the user's) and the plugin.
fn init() {
    static INIT: Once = Once::new();
    INIT.call_once(|| {
        let dir = tempfile::tempdir().expect("temp dir");
        // SAFETY: set once, before GStreamer (the only reader) starts and
        // before any test thread gets past this `Once`.
        unsafe { std::env::set_var("GST_REGISTRY", dir.path().join("registry.bin")) };
        std::mem::forget(dir); // GStreamer may write the registry until exit.
        gst::init().expect("GStreamer initialises");
        gstreynoldsflow::plugin_register_static().expect("the plugin registers");
    });
}

const FPS: u64 = 25;

/// `n` frames of `w × h`: a fixed texture (seeded hash) with a bright
/// 10 × 8 block moving 2 px right and 1 px down per frame, and a global
/// brightness drift, so both fields see motion.
fn frames(n: usize, w: usize, h: usize) -> Vec<Vec<u8>> {
    (0..n)
        .map(|t| {
            (0..w * h)
                .map(|i| {
                    let (x, y) = (i % w, i / w);
                    let (bx, by) = (8 + 2 * t, 6 + t);
                    if (bx..bx + 10).contains(&x) && (by..by + 8).contains(&y) {
                        230
                    } else {
                        let texture = (((x * 7 + y * 13) * 2_654_435_761usize) >> 11) % 61;
                        (40 + texture + 3 * t) as u8
                    }
                })
                .collect()
        })
        .collect()
}

fn pts(index: usize) -> gst::ClockTime {
    gst::ClockTime::SECOND
        .mul_div_floor(index as u64, FPS)
        .unwrap()
}

fn caps(format: VideoFormat, w: usize, h: usize) -> gst::Caps {
    gst_video::VideoCapsBuilder::new()
        .format(format)
        .width(w as i32)
        .height(h as i32)
        .framerate(gst::Fraction::new(FPS as i32, 1))
        .build()
}

/// A buffer of `format` whose luma plane is `luma` (at the format's
/// stride) and whose chroma is arbitrary, stamped as frame `index`.
fn buffer(format: VideoFormat, w: usize, h: usize, luma: &[u8], index: usize) -> gst::Buffer {
    let info = VideoInfo::builder(format, w as u32, h as u32)
        .build()
        .unwrap();
    let mut buffer = gst::Buffer::with_size(info.size()).unwrap();
    {
        let b = buffer.get_mut().unwrap();
        b.set_pts(pts(index));
        b.set_duration(pts(1));
        b.set_offset(index as u64);
        let mut frame = gst_video::VideoFrameRef::from_buffer_ref_writable(b, &info).unwrap();
        for plane in 1..frame.n_planes() {
            let data = frame.plane_data_mut(plane).unwrap();
            data.iter_mut()
                .enumerate()
                .for_each(|(i, v)| *v = (i * 31 + index * 17) as u8);
        }
        let stride = frame.plane_stride()[0] as usize;
        let y = frame.plane_data_mut(0).unwrap();
        for (dst, src) in y.chunks_mut(stride).zip(luma.chunks(w)) {
            dst[..w].copy_from_slice(src);
        }
    }
    buffer
}

/// A harness around a fresh element with these properties.
fn harness(properties: &[(&str, &str)]) -> Harness {
    init();
    let mut h = Harness::new("reynoldsflow");
    let element = h.element().unwrap();
    for (name, value) in properties {
        element.set_property_from_str(name, value);
    }
    h.play();
    h
}

/// An output frame: its timestamp and its RGB bytes, packed.
#[derive(Debug, PartialEq)]
struct Out {
    pts: Option<gst::ClockTime>,
    rgb: Vec<u8>,
}

fn packed_rgb(buffer: &gst::Buffer, w: usize, h: usize) -> Vec<u8> {
    let info = VideoInfo::builder(VideoFormat::Rgb, w as u32, h as u32)
        .build()
        .unwrap();
    let frame = gst_video::VideoFrameRef::from_buffer_ref_readable(buffer.as_ref(), &info).unwrap();
    let stride = frame.plane_stride()[0] as usize;
    let plane = frame.plane_data(0).unwrap();
    plane
        .chunks(stride)
        .take(h)
        .flat_map(|row| &row[..3 * w])
        .copied()
        .collect()
}

/// Push `frames` as `format` (frame indices from `first`), collecting every output.
fn push_all(
    h: &mut Harness,
    format: VideoFormat,
    (w, h_): (usize, usize),
    frames: &[Vec<u8>],
    first: usize,
) -> Vec<Out> {
    let mut outs = Vec::new();
    for (k, luma) in frames.iter().enumerate() {
        h.push(buffer(format, w, h_, luma, first + k))
            .expect("the element takes the frame");
        while let Some(b) = h.try_pull() {
            outs.push(Out {
                pts: b.pts(),
                rgb: packed_rgb(&b, w, h_),
            });
        }
    }
    outs
}

fn run_element(
    properties: &[(&str, &str)],
    format: VideoFormat,
    (w, h): (usize, usize),
    frames: &[Vec<u8>],
) -> Vec<Out> {
    let mut rig = harness(properties);
    rig.set_src_caps(caps(format, w, h));
    push_all(&mut rig, format, (w, h), frames, 0)
}

/// `reynoldsflow run CLIP --raw WxH --out DIR FLAGS`, in-process: the RGB
/// of each PNG it writes, in frame order.
fn cli_outputs(frames: &[Vec<u8>], (w, h): (usize, usize), flags: &[&str]) -> Vec<Vec<u8>> {
    let dir = tempfile::tempdir().unwrap();
    let clip = dir.path().join("clip.gray");
    std::fs::write(&clip, frames.concat()).unwrap();
    let out = dir.path().join("out");
    let size = format!("{w}x{h}");
    let mut args: Vec<&str> = vec!["reynoldsflow", "run"];
    args.extend([
        clip.to_str().unwrap(),
        "--raw",
        &size,
        "--out",
        out.to_str().unwrap(),
    ]);
    args.extend(flags);
    let code = reynoldsflow_cli::run(&args);
    assert_eq!(
        format!("{code:?}"),
        format!("{:?}", std::process::ExitCode::SUCCESS),
        "reynoldsflow {args:?}"
    );
    let mut pngs: Vec<PathBuf> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    pngs.sort();
    pngs.iter().map(|p| read_rgb(p, w, h)).collect()
}

fn read_rgb(path: &Path, w: usize, h: usize) -> Vec<u8> {
    let image = image_io::read_rgb8(path).unwrap();
    assert_eq!((image.width, image.height), (w, h));
    image.bytes
}

/// Element properties (name, value).
type Properties = &'static [(&'static str, &'static str)];

/// Element properties and the `reynoldsflow run` flags that mean the same.
const SETTINGS: [(Properties, &[&str]); 4] = [
    (&[], &[]),
    (
        &[
            ("scale", "fixed"),
            ("k-d", "6"),
            ("k-c", "20.5"),
            ("variant", "cd"),
            ("threads", "3"),
        ],
        &["--scale", "fixed:6,20.5", "--variant", "cd"],
    ),
    (
        &[
            ("lambda", "0.0003"),
            ("intensity-scale", "2/255"),
            ("variant", "dc0"),
        ],
        &[
            "--lambda",
            "0.0003",
            "--intensity-scale",
            "2/255",
            "--variant",
            "dc0",
        ],
    ),
    (
        &[("variant", "hsv"), ("threads", "1")],
        &["--variant", "hsv"],
    ),
];

#[test]
fn gray8_frames_give_the_bytes_of_reynoldsflow_run() {
    for (w, h) in [(64, 48), (61, 37)] {
        let clip = frames(6, w, h);
        for (properties, flags) in SETTINGS {
            let outs = run_element(properties, VideoFormat::Gray8, (w, h), &clip);
            let expected = cli_outputs(&clip, (w, h), flags);
            assert_eq!(outs.len(), 5, "N frames give N - 1 outputs");
            assert_eq!(expected.len(), 5);
            for (k, (out, cli)) in outs.iter().zip(&expected).enumerate() {
                assert_eq!(
                    out.pts,
                    Some(pts(k)),
                    "result {k} carries frame {k}'s timestamp"
                );
                assert!(
                    out.rgb == *cli,
                    "{w}x{h} {properties:?}: output {k} differs from the CLI"
                );
            }
        }
    }
}

#[test]
fn i420_and_nv12_give_the_bytes_of_their_luma_as_gray8() {
    let (w, h) = (61, 37); // odd: strides differ from the width, chroma planes round up
    let clip = frames(4, w, h);
    let gray = run_element(&[], VideoFormat::Gray8, (w, h), &clip);
    assert_eq!(gray.len(), 3);
    for format in [VideoFormat::I420, VideoFormat::Nv12] {
        let outs = run_element(&[], format, (w, h), &clip);
        assert!(outs == gray, "{format:?}");
    }
}

#[test]
fn first_frame_modes() {
    let (w, h) = (64, 48);
    let clip = frames(5, w, h);
    let results = run_element(&[], VideoFormat::Gray8, (w, h), &clip);
    assert_eq!(results.len(), 4);

    // repeat: one output per frame, stamped with it; frame 0 a copy of result 0.
    let repeat = run_element(
        &[("first-frame", "repeat")],
        VideoFormat::Gray8,
        (w, h),
        &clip,
    );
    assert_eq!(repeat.len(), 5);
    assert_eq!(repeat[0].rgb, results[0].rgb);
    for (k, out) in repeat.iter().enumerate() {
        assert_eq!(out.pts, Some(pts(k)));
        if k > 0 {
            assert!(
                out.rgb == results[k - 1].rgb,
                "repeat: frame {k} carries result {}",
                k - 1
            );
        }
    }

    // black: the same, frame 0 all zero.
    let black = run_element(
        &[("first-frame", "black")],
        VideoFormat::Gray8,
        (w, h),
        &clip,
    );
    assert_eq!(black.len(), 5);
    assert!(black[0].rgb.iter().all(|&b| b == 0));
    assert_eq!(black[0].pts, Some(pts(0)));
    assert_eq!(black[1..], repeat[1..]);
}

#[test]
fn a_caps_change_and_a_flush_reset_the_pair() {
    let (w, h) = (64, 48);
    let (w2, h2) = (40, 32);
    let (a, b) = (frames(3, w, h), frames(3, w2, h2));
    let mut rig = harness(&[]);
    rig.set_src_caps(caps(VideoFormat::Gray8, w, h));
    let first = push_all(&mut rig, VideoFormat::Gray8, (w, h), &a, 0);
    rig.set_src_caps(caps(VideoFormat::Gray8, w2, h2));
    let second = push_all(&mut rig, VideoFormat::Gray8, (w2, h2), &b, 3);
    // Each size on its own: 2 outputs, the CLI's bytes; no pair across the change.
    let expected_a = cli_outputs(&a, (w, h), &[]);
    let expected_b = cli_outputs(&b, (w2, h2), &[]);
    assert_eq!(
        first.iter().map(|o| &o.rgb).collect::<Vec<_>>(),
        expected_a.iter().collect::<Vec<_>>()
    );
    assert_eq!(second.len(), 2);
    assert!(second.iter().map(|o| &o.rgb).eq(expected_b.iter()));
    assert_eq!(second[0].pts, Some(pts(3)));

    // A flush between frames 2 and 3 of one clip: the pair (2, 3) is never made.
    let clip = frames(6, w, h);
    let mut rig = harness(&[]);
    rig.set_src_caps(caps(VideoFormat::Gray8, w, h));
    let before = push_all(&mut rig, VideoFormat::Gray8, (w, h), &clip[..3], 0);
    assert!(rig.push_event(gst::event::FlushStart::new()));
    assert!(rig.push_event(gst::event::FlushStop::new(true)));
    let segment = gst::FormattedSegment::<gst::ClockTime>::new();
    assert!(rig.push_event(gst::event::Segment::new(&segment)));
    let after = push_all(&mut rig, VideoFormat::Gray8, (w, h), &clip[3..], 3);
    assert_eq!((before.len(), after.len()), (2, 2));
    let expected = cli_outputs(&clip[3..], (w, h), &[]);
    assert!(after.iter().map(|o| &o.rgb).eq(expected.iter()));
    assert_eq!(after[0].pts, Some(pts(3)));
}

#[test]
fn a_stop_resets_the_pair() {
    let (w, h) = (64, 48);
    let clip = frames(5, w, h);
    let mut rig = harness(&[]);
    rig.set_src_caps(caps(VideoFormat::Gray8, w, h));
    let before = push_all(&mut rig, VideoFormat::Gray8, (w, h), &clip[..2], 0);
    let element = rig.element().unwrap();
    element.set_state(gst::State::Null).unwrap();
    rig.play();
    rig.set_src_caps(caps(VideoFormat::Gray8, w, h));
    let after = push_all(&mut rig, VideoFormat::Gray8, (w, h), &clip[2..], 2);
    assert_eq!((before.len(), after.len()), (1, 2));
    let expected = cli_outputs(&clip[2..], (w, h), &[]);
    assert!(after.iter().map(|o| &o.rgb).eq(expected.iter()));
}

/// The core's cue sink, run by the core's engine on its own.
fn core_regions(
    prev: &[u8],
    next: &[u8],
    (w, h): (usize, usize),
    threshold: f64,
    min_area: u32,
) -> Vec<Region> {
    const W: usize = 64;
    const H: usize = 48;
    assert_eq!((w, h), (W, H));
    let config = Config::new(W, H, Params::DEFAULT).unwrap();
    let mut sink = Box::new(
        MotionCues::<CELL, { grid_cells(W, CELL) }, { grid_cells(H, CELL) }, REGIONS>::new(
            &config,
            cues::params(threshold, min_area).unwrap(),
        )
        .unwrap(),
    );
    let mut memory = fixed_engine::HostEngine::new();
    let plan = Plan::strips(config, fixed_engine::strip_width(W)).unwrap();
    let job = plan
        .bind(FramePair::packed(&config, prev, next).unwrap())
        .unwrap();
    memory.engine(&plan).unwrap().run(&job, &mut *sink);
    sink.end_frame().to_vec()
}

fn region_of(s: &gst::StructureRef) -> (u32, u32, u32, u32, u32, f64, f64) {
    (
        s.get("x").unwrap(),
        s.get("y").unwrap(),
        s.get("width").unwrap(),
        s.get("height").unwrap(),
        s.get("area").unwrap(),
        s.get("peak").unwrap(),
        s.get("mean").unwrap(),
    )
}

fn expected_region(r: &Region) -> (u32, u32, u32, u32, u32, f64, f64) {
    (
        r.x_min.into(),
        r.y_min.into(),
        r.width().into(),
        r.height().into(),
        r.area,
        r.peak.to_num(),
        r.mean.to_num(),
    )
}

#[test]
fn cue_metas_and_messages_are_the_cores_motion_cues() {
    let (w, h) = (64, 48);
    let clip = frames(5, w, h);
    let (threshold, min_area) = (0.25, 2);
    let mut rig = harness(&[
        ("cues", "true"),
        ("cue-threshold", "0.25"),
        ("cue-min-area", "2"),
    ]);
    let bus = gst::Bus::new();
    rig.element().unwrap().set_bus(Some(&bus));
    rig.set_src_caps(caps(VideoFormat::Gray8, w, h));
    let mut seen_regions = 0;
    for (k, luma) in clip.iter().enumerate() {
        rig.push(buffer(VideoFormat::Gray8, w, h, luma, k)).unwrap();
        let Some(out) = rig.try_pull() else {
            assert_eq!(k, 0);
            continue;
        };
        let expected: Vec<_> = core_regions(&clip[k - 1], luma, (w, h), threshold, min_area)
            .iter()
            .map(expected_region)
            .collect();
        assert!(!expected.is_empty(), "the moving block is found");
        seen_regions += expected.len();

        let mut metas: Vec<_> = out.iter_meta::<VideoRegionOfInterestMeta>().collect();
        metas.sort_by_key(|m| m.id());
        assert_eq!(metas.len(), expected.len());
        for (meta, region) in metas.iter().zip(&expected) {
            assert_eq!(meta.roi_type(), ROI_TYPE);
            assert_eq!(meta.rect(), (region.0, region.1, region.2, region.3));
            assert_eq!(region_of(meta.param(REGION_STRUCTURE).unwrap()), *region);
        }

        let message = bus
            .iter()
            .find(|m| matches!(m.view(), gst::MessageView::Element(_)))
            .expect("one element message per output");
        let s = message.structure().unwrap();
        assert_eq!(s.name(), cues::MESSAGE_STRUCTURE);
        assert_eq!(
            s.get::<Option<gst::ClockTime>>("timestamp").unwrap(),
            Some(pts(k - 1))
        );
        let listed: Vec<_> = s
            .get::<gst::Array>("regions")
            .unwrap()
            .iter()
            .map(|v| region_of(&v.get::<gst::Structure>().unwrap()))
            .collect();
        assert_eq!(listed, expected);
    }
    assert!(seen_regions >= 4);
}

#[test]
fn unsupported_caps_and_settings_are_refused_with_a_message() {
    let (w, h) = (64, 48);
    let clip = frames(2, w, h);

    let mut rig = harness(&[]);
    let bus = gst::Bus::new();
    rig.element().unwrap().set_bus(Some(&bus));
    rig.set_src_caps(caps(VideoFormat::Rgb, w, h));
    let rgb = gst::Buffer::from_mut_slice(vec![0u8; 3 * w * h]);
    assert_eq!(rig.push(rgb), Err(gst::FlowError::NotNegotiated));
    let text = error_text(&bus);
    assert!(
        text.contains("GRAY8, I420 or NV12") && text.contains("RGB"),
        "{text}"
    );

    let mut rig = harness_with_bus(&[("intensity-scale", "one/255")]);
    rig.0.set_src_caps(caps(VideoFormat::Gray8, w, h));
    let pushed = rig.0.push(buffer(VideoFormat::Gray8, w, h, &clip[0], 0));
    assert!(pushed.is_err());
    let text = error_text(&rig.1);
    assert!(
        text.contains("intensity-scale") && text.contains("one"),
        "{text}"
    );

    let mut rig = harness_with_bus(&[("lambda", "0")]);
    rig.0.set_src_caps(caps(VideoFormat::Gray8, w, h));
    assert!(
        rig.0
            .push(buffer(VideoFormat::Gray8, w, h, &clip[0], 0))
            .is_err()
    );
    let text = error_text(&rig.1);
    assert!(text.contains("lambda"), "{text}");
}

#[test]
fn a_nan_cue_threshold_is_refused_and_the_cues_cannot_see_one() {
    // GLib (2.74 and later) refuses NaN for a double property and keeps the
    // value it had; `cues::params` refuses it too, for the GLibs that clamp
    // instead (every comparison with NaN is false, so it passes a clamp).
    let rig = harness(&[("cue-threshold", "0.5")]);
    let element = rig.element().unwrap();
    let set = std::panic::catch_unwind(|| element.set_property("cue-threshold", f64::NAN));
    assert!(set.is_err(), "glib-rs sets a NaN it should refuse");
    assert_eq!(element.property::<f64>("cue-threshold"), 0.5);
    let refused = cues::params(f64::NAN, 1).unwrap_err();
    assert!(refused.contains("cue-threshold is NaN"), "{refused}");
    assert!(cues::params(f64::INFINITY, 1).is_ok());
}

fn harness_with_bus(properties: &[(&str, &str)]) -> (Harness, gst::Bus) {
    let rig = harness(properties);
    let bus = gst::Bus::new();
    rig.element().unwrap().set_bus(Some(&bus));
    (rig, bus)
}

/// The first error on `bus`: message and debug text.
fn error_text(bus: &gst::Bus) -> String {
    let message = bus
        .iter()
        .find(|m| matches!(m.view(), gst::MessageView::Error(_)))
        .expect("an error message");
    let gst::MessageView::Error(e) = message.view() else {
        unreachable!()
    };
    format!("{} {:?}", e.error(), e.debug())
}

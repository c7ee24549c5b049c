//! The `reynoldsflow` element in-process (gst_check's harness), against
//! the host library's computation of each pair on the same frames (what
//! `reynoldsflow run` writes: `Compute::pair` and `OutputSpec::image`) and
//! against the core's `MotionCues` run on its own.

use std::sync::Once;

use gst::prelude::*;
use gst_check::Harness;
use gst_video::prelude::*;
use gst_video::{VideoFormat, VideoInfo, VideoRegionOfInterestMeta};
use gstreynoldsflow::cues::{self, CELL, REGION_STRUCTURE, REGIONS, ROI_TYPE};
use gstreynoldsflow::{FirstFrameMode, ScaleMode, VariantMode};
use reynoldsflow_core::{Config, FramePair, Params, Plan};
use reynoldsflow_cues::{MotionCues, Region, grid_cells};
use reynoldsflow_host::Gray;
use reynoldsflow_host::HostError;
use reynoldsflow_host::outputs::{OutputSpec, Variant};
use reynoldsflow_host::settings::{
    self as values, Choice, FirstFrame, ScaleArg, Settings, parse_intensity_scale,
};

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

/// What `reynoldsflow run` writes for each consecutive pair of `frames`
/// with `settings`: the host's computation of one pair (`Compute::pair`,
/// as `reynoldsflow pair`) and the variant's image.
fn expected_outputs(
    frames: &[Vec<u8>],
    (w, h): (usize, usize),
    settings: &Settings,
) -> Vec<Vec<u8>> {
    let compute = settings.compute().unwrap();
    let spec = OutputSpec {
        variant: settings.variant,
        ..OutputSpec::default()
    };
    let gray = |luma: &Vec<u8>| Gray::new(w, h, luma.clone()).unwrap();
    frames
        .windows(2)
        .map(|pair| spec.image(&compute.pair(&gray(&pair[0]), &gray(&pair[1])).unwrap()))
        .collect()
}

/// Element properties (name, value).
type Properties = &'static [(&'static str, &'static str)];

/// Element properties and the host settings that mean the same.
fn settings_cases() -> [(Properties, Settings); 4] {
    [
        (&[], Settings::default()),
        (
            &[
                ("scale", "fixed"),
                ("k-d", "6"),
                ("k-c", "20.5"),
                ("variant", "cd"),
                ("threads", "3"),
            ],
            Settings {
                scale: ScaleArg::Fixed {
                    k_d: 6.0,
                    k_c: 20.5,
                },
                variant: Variant::Cd,
                ..Settings::default()
            },
        ),
        (
            &[
                ("lambda", "0.0003"),
                ("intensity-scale", "2/255"),
                ("variant", "dc0"),
            ],
            Settings {
                lambda: 0.0003,
                intensity_scale: parse_intensity_scale("2/255").unwrap(),
                variant: Variant::Dc0,
                ..Settings::default()
            },
        ),
        (
            &[("variant", "hsv"), ("threads", "2")],
            Settings {
                variant: Variant::Hsv,
                ..Settings::default()
            },
        ),
    ]
}

#[test]
fn gray8_frames_give_the_bytes_of_reynoldsflow_run() {
    for (w, h) in [(64, 48), (61, 37)] {
        let clip = frames(6, w, h);
        for (properties, settings) in settings_cases() {
            let outs = run_element(properties, VideoFormat::Gray8, (w, h), &clip);
            let expected = expected_outputs(&clip, (w, h), &settings);
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
                    "{w}x{h} {properties:?}: output {k} differs from run's"
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
    // Each size on its own: 2 outputs, run's bytes; no pair across the change.
    let expected_a = expected_outputs(&a, (w, h), &Settings::default());
    let expected_b = expected_outputs(&b, (w2, h2), &Settings::default());
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
    let expected = expected_outputs(&clip[3..], (w, h), &Settings::default());
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
    let expected = expected_outputs(&clip[2..], (w, h), &Settings::default());
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
    let settings = Settings {
        cue_threshold: threshold,
        cue_min_area: min_area,
        ..Settings::default()
    };
    let mut sink = Box::new(
        MotionCues::<CELL, { grid_cells(W, CELL) }, { grid_cells(H, CELL) }, REGIONS>::new(
            &config,
            reynoldsflow_host::cues::params(&settings).unwrap(),
        )
        .unwrap(),
    );
    let mut memory = reynoldsflow_host::internals::HostEngine::new();
    let plan = Plan::strips(config, reynoldsflow_host::internals::strip_width(W)).unwrap();
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
    // value it had; the host's cue settings refuse it too, for the GLibs
    // that clamp instead (every comparison with NaN is false, so it passes
    // a clamp), and the element names its property.
    let rig = harness(&[("cue-threshold", "0.5")]);
    let element = rig.element().unwrap();
    let set = std::panic::catch_unwind(|| element.set_property("cue-threshold", f64::NAN));
    assert!(set.is_err(), "glib-rs sets a NaN it should refuse");
    assert_eq!(element.property::<f64>("cue-threshold"), 0.5);
    let nan = Settings {
        cue_threshold: f64::NAN,
        ..Settings::default()
    };
    let refused = reynoldsflow_host::cues::params(&nan).unwrap_err();
    let HostError::Setting { setting, .. } = refused else {
        panic!("{refused}")
    };
    assert_eq!(gstreynoldsflow::property(setting), "cue-threshold");
}

/// A fresh element's properties are the host's defaults, and its enum
/// properties list the host's names.
#[test]
fn property_defaults_are_the_hosts_settings() {
    init();
    let element = gst::ElementFactory::make("reynoldsflow").build().unwrap();
    let d = Settings::default();
    let first_frame: FirstFrameMode = element.property("first-frame");
    assert_eq!(FirstFrame::from(first_frame), d.first_frame);
    let scale: ScaleMode = element.property("scale");
    let gains = (
        element.property::<f64>("k-d"),
        element.property::<f64>("k-c"),
    );
    assert_eq!(gains, values::DEFAULT_FIXED_GAINS);
    assert_eq!(scale.host(gains), d.scale);
    assert_eq!(element.property::<f64>("lambda"), d.lambda);
    let intensity: String = element.property("intensity-scale");
    assert_eq!(parse_intensity_scale(&intensity), Ok(d.intensity_scale));
    let variant: VariantMode = element.property("variant");
    assert_eq!(Variant::from(variant), d.variant);
    let threads = element.property::<u32>("threads");
    assert_eq!(
        Some(threads).filter(|&n| n > 0).map(|n| n as usize),
        d.threads
    );
    assert_eq!(element.property::<f64>("cue-threshold"), d.cue_threshold);
    assert_eq!(element.property::<u32>("cue-min-area"), d.cue_min_area);
    assert!(!element.property::<bool>("cues"));

    // Every enum property's nicks are the host's names, in its order.
    fn nicks<T: gst::glib::prelude::StaticType>() -> Vec<String> {
        let class = gst::glib::EnumClass::with_type(T::static_type()).unwrap();
        class.values().iter().map(|v| v.nick().to_owned()).collect()
    }
    fn names<T: Choice>() -> Vec<String> {
        T::ALL.iter().map(|v| v.name().to_owned()).collect()
    }
    let mut first_frames = names::<FirstFrame>();
    first_frames.sort();
    let mut listed = nicks::<FirstFrameMode>();
    listed.sort();
    assert_eq!(listed, first_frames);
    let mut variants = names::<Variant>();
    variants.sort();
    let mut listed = nicks::<VariantMode>();
    listed.sort();
    assert_eq!(listed, variants);
    for name in names::<FirstFrame>() {
        let f = FirstFrame::from_name(&name).unwrap();
        element.set_property_from_str("first-frame", &name);
        let set: FirstFrameMode = element.property("first-frame");
        assert_eq!(FirstFrame::from(set), f);
    }
}

/// `first-frame=repeat` gives one output per frame: one frame, then EOS,
/// gives its own pair (no motion); a caps segment of one frame too.
#[test]
fn repeat_gives_every_frame_an_output_at_eos_and_at_new_caps() {
    let (w, h) = (64, 48);
    let clip = frames(6, w, h);
    let lone = |luma: &Vec<u8>| {
        expected_outputs(&[luma.clone(), luma.clone()], (w, h), &Settings::default())
    };

    let mut rig = harness(&[("first-frame", "repeat")]);
    rig.set_src_caps(caps(VideoFormat::Gray8, w, h));
    let before = push_all(&mut rig, VideoFormat::Gray8, (w, h), &clip[..1], 0);
    assert!(before.is_empty(), "the lone frame waits for its pair");
    assert!(rig.push_event(gst::event::Eos::new()));
    let out = rig.pull().unwrap();
    assert_eq!(out.pts(), Some(pts(0)));
    assert!(packed_rgb(&out, w, h) == lone(&clip[0])[0]);
    assert!(rig.try_pull().is_none());

    // Frames 0-2 in one caps, frame 3 alone in another, frames 4-5 in a third:
    // 6 frames, 6 outputs, each stamped with its frame.
    let mut rig = harness(&[("first-frame", "repeat")]);
    let mut outs = Vec::new();
    let segments: [(&[Vec<u8>], usize, u32); 3] = [
        (&clip[..3], 0, 25),
        (&clip[3..4], 3, 30),
        (&clip[4..], 4, 25),
    ];
    for (frames, first, fps) in segments {
        let caps = gst_video::VideoCapsBuilder::new()
            .format(VideoFormat::Gray8)
            .width(w as i32)
            .height(h as i32)
            .framerate(gst::Fraction::new(fps as i32, 1))
            .build();
        rig.set_src_caps(caps);
        outs.extend(push_all(
            &mut rig,
            VideoFormat::Gray8,
            (w, h),
            frames,
            first,
        ));
    }
    assert!(rig.push_event(gst::event::Eos::new()));
    while let Some(b) = rig.try_pull() {
        outs.push(Out {
            pts: b.pts(),
            rgb: packed_rgb(&b, w, h),
        });
    }
    let stamps: Vec<_> = outs.iter().map(|o| o.pts).collect();
    assert_eq!(stamps, (0..6).map(|k| Some(pts(k))).collect::<Vec<_>>());
    assert!(outs[3].rgb == lone(&clip[3])[0], "frame 3's own pair");
    let tail = expected_outputs(&clip[4..], (w, h), &Settings::default());
    assert!(outs[4].rgb == tail[0] && outs[5].rgb == tail[0]);
}

/// A gap (a GAP event, or a buffer flagged GAP, empty or not) breaks the
/// pair chain: no pair spans it, the gap goes on downstream, and the
/// stream goes on.
#[test]
fn a_gap_breaks_the_pair_chain() {
    let (w, h) = (64, 48);
    let clip = frames(6, w, h);
    let expected = |frames: &[Vec<u8>]| expected_outputs(frames, (w, h), &Settings::default());
    for how in ["event", "empty buffer", "full buffer"] {
        let mut rig = harness(&[]);
        rig.set_src_caps(caps(VideoFormat::Gray8, w, h));
        let before = push_all(&mut rig, VideoFormat::Gray8, (w, h), &clip[..3], 0);
        match how {
            "event" => {
                assert!(rig.push_event(gst::event::Gap::builder(pts(3)).duration(pts(1)).build()))
            }
            _ => {
                let mut gap = match how {
                    "empty buffer" => gst::Buffer::new(),
                    _ => buffer(VideoFormat::Gray8, w, h, &clip[2], 3),
                };
                let b = gap.get_mut().unwrap();
                b.set_pts(pts(3));
                b.set_duration(pts(1));
                b.set_flags(gst::BufferFlags::GAP);
                assert_eq!(rig.push(gap), Ok(gst::FlowSuccess::Ok), "{how}");
            }
        }
        let after = push_all(&mut rig, VideoFormat::Gray8, (w, h), &clip[3..], 3);
        assert_eq!((before.len(), after.len()), (2, 2), "{how}");
        assert!(
            after.iter().map(|o| &o.rgb).eq(expected(&clip[3..]).iter()),
            "{how}"
        );
        assert_eq!(after[0].pts, Some(pts(3)), "{how}");
        let gap =
            std::iter::from_fn(|| rig.try_pull_event()).find(|e| e.type_() == gst::EventType::Gap);
        assert!(gap.is_some(), "{how}: the gap goes on downstream");
    }
}

/// At odd widths each RGB row has padding: every byte of it is written (zero).
#[test]
fn row_padding_is_written() {
    let (w, h) = (61, 37);
    let clip = frames(3, w, h);
    for first_frame in ["drop", "black"] {
        let mut rig = harness(&[("first-frame", first_frame)]);
        rig.set_src_caps(caps(VideoFormat::Gray8, w, h));
        let mut outs = 0;
        for (k, luma) in clip.iter().enumerate() {
            rig.push(buffer(VideoFormat::Gray8, w, h, luma, k)).unwrap();
            while let Some(b) = rig.try_pull() {
                let map = b.map_readable().unwrap();
                let stride = 3 * w + 1; // 183 bytes of pixels, 4-byte rows
                assert_eq!(map.len(), stride * h);
                for row in map.chunks(stride) {
                    assert_eq!(row[3 * w..], [0], "{first_frame}");
                }
                outs += 1;
            }
        }
        assert_eq!(outs, if first_frame == "drop" { 2 } else { 3 });
    }
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

/// A harness whose source says it is live (`live`) or not: from a source
/// that is not live, on more than one thread, the element computes whole
/// pairs on its workers and pushes from their threads.
fn harness_from(properties: &[(&str, &str)], live: bool) -> Harness {
    let rig = harness(properties);
    let sink = rig.element().unwrap().static_pad("sink").unwrap();
    sink.add_probe(gst::PadProbeType::QUERY_UPSTREAM, move |_, info| {
        if let Some(query) = info.query_mut()
            && let gst::QueryViewMut::Latency(latency) = query.view_mut()
        {
            latency.set(live, gst::ClockTime::ZERO, gst::ClockTime::NONE);
            return gst::PadProbeReturn::Handled;
        }
        gst::PadProbeReturn::Ok
    });
    rig
}

/// One step of a stream as a source gives it.
#[derive(Clone, Copy)]
enum Step {
    /// New caps of this size.
    Caps(usize, usize),
    /// Frame `k` of the clip (at the last caps' size), stamped `k`.
    Frame(usize),
    /// Frame `k`, flagged `DISCONT` (frames lost upstream before it).
    Discont(usize),
    /// A QoS event from downstream saying that frames up to `k` are late
    /// (with `qos=true` the base class drops them before the element).
    Late(usize),
    /// A GAP event at frame `k`.
    GapEvent(usize),
    /// An empty buffer flagged GAP at frame `k`.
    GapBuffer(usize),
    /// A drain query (every output out), then a flush.
    Flush,
    /// A property set between frames.
    Set(&'static str, &'static str),
    /// The element to NULL and back to PLAYING (a stop, new caps after).
    Restart(usize, usize),
}

/// An output buffer: its stamp, `DISCONT`, its bytes with any row
/// padding, its cue boxes.
type Output = (
    Option<gst::ClockTime>,
    bool,
    Vec<u8>,
    Vec<(u32, u32, u32, u32)>,
);

/// Everything that leaves the element: buffers in order, and the gaps'
/// stamps.
#[derive(Debug, Default, PartialEq)]
struct Seen {
    buffers: Vec<Output>,
    gaps: Vec<gst::ClockTime>,
}

impl Seen {
    fn collect(&mut self, rig: &mut Harness) {
        while let Some(event) = rig.try_pull_event() {
            if let gst::EventView::Gap(gap) = event.view() {
                self.gaps.push(gap.get().0);
            }
        }
        while let Some(b) = rig.try_pull() {
            let boxes = b
                .iter_meta::<VideoRegionOfInterestMeta>()
                .map(|m| m.rect())
                .collect();
            let discont = b.flags().contains(gst::BufferFlags::DISCONT);
            let bytes = b.map_readable().unwrap().to_vec();
            self.buffers.push((b.pts(), discont, bytes, boxes));
        }
    }
}

/// Every output pushed before a drain query returns.
fn drain(rig: &mut Harness) {
    let mut drain = gst::query::Drain::new();
    rig.srcpad().unwrap().peer_query(&mut drain);
}

/// Run `steps` through a fresh element with `properties` from a live
/// source or not, then EOS: what leaves it, and how many buffers left
/// from a worker thread.
fn stream_through(
    properties: &[(&str, &str)],
    live: bool,
    clip: &[Vec<u8>],
    steps: &[Step],
) -> (Seen, usize) {
    let mut rig = harness_from(properties, live);
    let element = rig.element().unwrap();
    let from_workers = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let counter = std::sync::Arc::clone(&from_workers);
    element
        .static_pad("src")
        .unwrap()
        .add_probe(gst::PadProbeType::BUFFER, move |_, _| {
            let name = std::thread::current().name().unwrap_or("").to_owned();
            if name.starts_with("reynoldsflow-worker") {
                counter.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            }
            gst::PadProbeReturn::Ok
        });
    let mut seen = Seen::default();
    let mut size = (0, 0);
    for &step in steps {
        match step {
            Step::Caps(w, h) => {
                size = (w, h);
                rig.set_src_caps(caps(VideoFormat::Gray8, w, h));
            }
            Step::Frame(k) | Step::Discont(k) => {
                let (w, h) = size;
                let luma = &clip[k][..w * h];
                let mut frame = buffer(VideoFormat::Gray8, w, h, luma, k);
                if let Step::Discont(_) = step {
                    frame.make_mut().set_flags(gst::BufferFlags::DISCONT);
                }
                assert_eq!(rig.push(frame), Ok(gst::FlowSuccess::Ok));
            }
            Step::Late(k) => {
                let qos = gst::event::Qos::new(gst::QOSType::Underflow, 1.0, 0, pts(k));
                assert!(rig.push_upstream_event(qos));
            }
            Step::GapEvent(k) => {
                assert!(rig.push_event(gst::event::Gap::builder(pts(k)).duration(pts(1)).build()))
            }
            Step::GapBuffer(k) => {
                let mut gap = gst::Buffer::new();
                let b = gap.get_mut().unwrap();
                b.set_pts(pts(k));
                b.set_duration(pts(1));
                b.set_flags(gst::BufferFlags::GAP);
                assert_eq!(rig.push(gap), Ok(gst::FlowSuccess::Ok));
            }
            Step::Flush => {
                drain(&mut rig);
                seen.collect(&mut rig);
                assert!(rig.push_event(gst::event::FlushStart::new()));
                assert!(rig.push_event(gst::event::FlushStop::new(true)));
                let segment = gst::FormattedSegment::<gst::ClockTime>::new();
                assert!(rig.push_event(gst::event::Segment::new(&segment)));
            }
            Step::Set(name, value) => element.set_property_from_str(name, value),
            Step::Restart(w, h) => {
                drain(&mut rig);
                seen.collect(&mut rig);
                element.set_state(gst::State::Null).unwrap();
                rig.play();
                size = (w, h);
                rig.set_src_caps(caps(VideoFormat::Gray8, w, h));
            }
        }
    }
    assert!(rig.push_event(gst::event::Eos::new()));
    seen.collect(&mut rig);
    let from_workers = from_workers.load(std::sync::atomic::Ordering::SeqCst);
    (seen, from_workers)
}

/// From a source that is not live, whole pairs on the workers: the same
/// outputs (stamps, flags, bytes, cues, gaps) as pair by pair from a live
/// source, through caps changes, gaps, flushes, stops and property
/// changes (the threads too), in every first-frame mode, and `run`'s
/// bytes.
#[test]
fn whole_pairs_on_the_workers_give_what_each_pair_as_it_comes_gives() {
    let (w, h) = (64, 48);
    let clip = frames(12, w, h);
    let frames_of = |range: std::ops::Range<usize>| range.map(Step::Frame);
    let mut steps = vec![Step::Caps(w, h)];
    steps.extend(frames_of(0..4));
    steps.push(Step::GapEvent(4));
    steps.extend(frames_of(5..7));
    steps.push(Step::GapBuffer(7));
    steps.extend(frames_of(8..9));
    steps.push(Step::Caps(40, 32));
    steps.extend(frames_of(9..11));
    steps.push(Step::Flush);
    steps.extend(frames_of(11..12));
    steps.push(Step::Set("variant", "cd"));
    steps.push(Step::Restart(w, h));
    steps.extend(frames_of(0..3));
    steps.push(Step::Set("scale", "fixed"));
    steps.extend(frames_of(3..6));
    // From the workers to each pair as it comes and back, mid-chain.
    steps.push(Step::Set("threads", "1"));
    steps.extend(frames_of(6..8));
    steps.push(Step::Set("threads", "3"));
    steps.extend(frames_of(8..10));

    for first_frame in ["drop", "repeat", "black"] {
        for threads in ["2", "3"] {
            let properties = [
                ("first-frame", first_frame),
                ("threads", threads),
                ("cues", "true"),
                ("cue-threshold", "0.5"),
            ];
            let (live, none) = stream_through(&properties, true, &clip, &steps);
            let (workers, pushed) = stream_through(&properties, false, &clip, &steps);
            let case = format!("first-frame={first_frame} threads={threads}");
            assert_eq!(none, 0, "{case}: pair by pair from a live source");
            assert!(pushed > 0, "{case}: no output left from a worker");
            assert!(live.buffers.len() >= 10, "{case}: {:?}", live.buffers.len());
            assert_eq!(live.gaps, [pts(4), pts(7)], "{case}");
            assert!(
                live.buffers.iter().any(|b| !b.3.is_empty()),
                "{case}: no cue seen"
            );
            assert!(live == workers, "{case}: the workers' outputs differ");
        }
    }

    // And `run`'s bytes, a longer clip.
    let clip = frames(20, w, h);
    let mut steps = vec![Step::Caps(w, h)];
    steps.extend(frames_of(0..20));
    let (seen, _) = stream_through(&[("threads", "2")], false, &clip, &steps);
    let expected = expected_outputs(&clip, (w, h), &Settings::default());
    assert!(seen.buffers.iter().map(|b| &b.2).eq(expected.iter()));
}

/// A flush while the workers compute: the outputs of frames before it are
/// pushed or dropped, never after it; the stream goes on from a first
/// frame. A stop while they compute comes back, and the element runs
/// again.
#[test]
fn a_flush_or_a_stop_while_the_workers_compute() {
    let (w, h) = (160, 120);
    let clip = frames(16, w, h);
    let expected = |frames: &[Vec<u8>]| expected_outputs(frames, (w, h), &Settings::default());
    let mut rig = harness_from(&[("threads", "2")], false);
    rig.set_src_caps(caps(VideoFormat::Gray8, w, h));
    for (k, luma) in clip[..8].iter().enumerate() {
        rig.push(buffer(VideoFormat::Gray8, w, h, luma, k)).unwrap();
    }
    assert!(rig.push_event(gst::event::FlushStart::new()));
    assert!(rig.push_event(gst::event::FlushStop::new(true)));
    let before: Vec<_> = std::iter::from_fn(|| rig.try_pull()).collect();
    assert!(before.len() <= 7);
    let segment = gst::FormattedSegment::<gst::ClockTime>::new();
    assert!(rig.push_event(gst::event::Segment::new(&segment)));
    for (k, luma) in clip[8..].iter().enumerate() {
        rig.push(buffer(VideoFormat::Gray8, w, h, luma, 8 + k))
            .unwrap();
    }
    assert!(rig.push_event(gst::event::Eos::new()));
    let after: Vec<_> = std::iter::from_fn(|| rig.try_pull()).collect();
    let stamps: Vec<_> = after.iter().map(|b| b.pts()).collect();
    assert_eq!(stamps, (8..15).map(|k| Some(pts(k))).collect::<Vec<_>>());
    assert!(after[0].flags().contains(gst::BufferFlags::DISCONT));
    assert!(
        after
            .iter()
            .map(|b| packed_rgb(b, w, h))
            .eq(expected(&clip[8..]))
    );

    // A stop with pairs in flight, then the same element again.
    let mut rig = harness_from(&[("threads", "2")], false);
    rig.set_src_caps(caps(VideoFormat::Gray8, w, h));
    let element = rig.element().unwrap();
    for (k, luma) in clip[..8].iter().enumerate() {
        rig.push(buffer(VideoFormat::Gray8, w, h, luma, k)).unwrap();
    }
    element.set_state(gst::State::Null).unwrap();
    rig.play();
    rig.set_src_caps(caps(VideoFormat::Gray8, w, h));
    let _ = std::iter::from_fn(|| rig.try_pull()).count();
    for (k, luma) in clip[..5].iter().enumerate() {
        rig.push(buffer(VideoFormat::Gray8, w, h, luma, k)).unwrap();
    }
    assert!(rig.push_event(gst::event::Eos::new()));
    let again: Vec<_> = std::iter::from_fn(|| rig.try_pull()).collect();
    assert!(
        again
            .iter()
            .map(|b| packed_rgb(b, w, h))
            .eq(expected(&clip[..5]))
    );
}

/// A pair that fails on a worker (cues past their frame size) stops the
/// stream with the element's message, as it does pair by pair.
#[test]
fn a_pair_that_fails_on_a_worker_stops_the_stream_with_its_message() {
    let (w, h) = (cues::MAX_SIDE + 8, 16);
    let clip = frames(3, w, h);
    for live in [true, false] {
        let mut rig = harness_from(&[("threads", "2"), ("cues", "true")], live);
        let bus = gst::Bus::new();
        rig.element().unwrap().set_bus(Some(&bus));
        rig.set_src_caps(caps(VideoFormat::Gray8, w, h));
        let pushed: Vec<_> = clip
            .iter()
            .enumerate()
            .map(|(k, luma)| rig.push(buffer(VideoFormat::Gray8, w, h, luma, k)))
            .collect();
        drain(&mut rig);
        let text = error_text(&bus);
        assert!(text.contains("cues"), "live={live}: {text}");
        assert!(rig.try_pull().is_none(), "live={live}");
        assert!(
            pushed.contains(&Err(gst::FlowError::Error))
                || rig.push(buffer(VideoFormat::Gray8, w, h, &clip[0], 3))
                    == Err(gst::FlowError::Error),
            "live={live}: {pushed:?}"
        );
    }
}

/// Downstream at its end (`identity eos-after`) or failing (`error-after`)
/// while the workers compute, or pair by pair: the source learns it, and
/// the pipeline still ends (EOS or an error on the bus, never a hang).
#[test]
fn the_pipeline_ends_when_downstream_ends_or_fails_early() {
    init();
    let (w, h) = (160, 120);
    let clip = frames(12, w, h);
    for live in [false, true] {
        for downstream in ["eos-after=3", "error-after=3"] {
            let pipeline = gst::parse::launch(&format!(
                "appsrc name=src is-live={live} format=time ! reynoldsflow threads=2 \
                 ! identity {downstream} ! fakesink sync=false"
            ))
            .unwrap()
            .downcast::<gst::Pipeline>()
            .unwrap();
            let src = pipeline.by_name("src").unwrap();
            src.set_property("caps", caps(VideoFormat::Gray8, w, h));
            pipeline.set_state(gst::State::Playing).unwrap();
            for (k, luma) in clip.iter().enumerate() {
                let frame = buffer(VideoFormat::Gray8, w, h, luma, k);
                let pushed = src.emit_by_name::<gst::FlowReturn>("push-buffer", &[&frame]);
                if pushed != gst::FlowReturn::Ok {
                    break;
                }
            }
            let _ = src.emit_by_name::<gst::FlowReturn>("end-of-stream", &[]);
            let bus = pipeline.bus().unwrap();
            let end = bus.timed_pop_filtered(
                gst::ClockTime::from_seconds(20),
                &[gst::MessageType::Eos, gst::MessageType::Error],
            );
            pipeline.set_state(gst::State::Null).unwrap();
            assert!(
                end.is_some(),
                "live={live} {downstream}: the pipeline hangs"
            );
        }
    }
}

/// An input flagged `DISCONT` (frames lost upstream, a seek) and a frame
/// the base class drops as late (`qos=true`) break the pair chain as a gap
/// does: no output spans them, each output is the pair its stamp names,
/// and the first output after each carries `DISCONT`: the same pair by
/// pair (one thread, or a live source) and on the workers.
#[test]
fn a_discontinuity_or_a_frame_dropped_as_late_breaks_the_pair_chain() {
    let (w, h) = (64, 48);
    let clip = frames(16, w, h);
    let mut steps = vec![Step::Caps(w, h)];
    steps.extend((0..5).map(Step::Frame));
    steps.push(Step::Discont(5));
    steps.extend((6..10).map(Step::Frame));
    // Frame 10 comes late: dropped before the element sees it.
    steps.push(Step::Late(10));
    steps.extend((10..16).map(Step::Frame));
    let pieces = [0..5, 5..10, 11..16];
    for first_frame in ["drop", "repeat", "black"] {
        let mut seen = Vec::new();
        for (threads, live) in [("1", false), ("2", false), ("3", false), ("3", true)] {
            let properties = [
                ("first-frame", first_frame),
                ("threads", threads),
                ("qos", "true"),
            ];
            let case = format!("first-frame={first_frame} threads={threads} live={live}");
            let (out, _) = stream_through(&properties, live, &clip, &steps);
            let stamps = |discont: bool| -> Vec<_> {
                out.buffers
                    .iter()
                    .filter(|b| b.1 || !discont)
                    .map(|b| b.0)
                    .collect()
            };
            let firsts: Vec<_> = pieces.iter().map(|p| Some(pts(p.start))).collect();
            assert_eq!(stamps(true), firsts, "{case}: DISCONT on these outputs");
            let labelled: Vec<_> = match first_frame {
                "drop" => pieces.iter().flat_map(|p| p.start..p.end - 1).collect(),
                _ => pieces.iter().flat_map(|p| p.clone()).collect(),
            };
            let labelled: Vec<_> = labelled.into_iter().map(|k| Some(pts(k))).collect();
            assert_eq!(stamps(false), labelled, "{case}: stamps");
            if first_frame == "drop" {
                let expected = pieces
                    .iter()
                    .flat_map(|p| expected_outputs(&clip[p.clone()], (w, h), &Settings::default()));
                // 64 px rows of RGB have no padding: the bytes are packed.
                let bytes = out.buffers.iter().map(|b| b.2.clone());
                assert!(
                    bytes.eq(expected),
                    "{case}: an output is not its stamp's pair"
                );
            }
            seen.push((case, out));
        }
        let (first_case, first) = &seen[0];
        for (case, out) in &seen[1..] {
            assert!(out == first, "{case} differs from {first_case}");
        }
    }
}

/// A POSITION query on the source pad answers the end of the last output
/// pushed, pair by pair and on the workers.
#[test]
fn the_source_pad_answers_the_position_of_the_last_output() {
    let (w, h) = (64, 48);
    let clip = frames(9, w, h);
    for (threads, live) in [("1", false), ("2", false), ("3", false), ("3", true)] {
        let case = format!("threads={threads} live={live}");
        let mut rig = harness_from(&[("threads", threads)], live);
        rig.set_src_caps(caps(VideoFormat::Gray8, w, h));
        let src = rig.element().unwrap().static_pad("src").unwrap();
        let position = || {
            let mut q = gst::query::Position::new(gst::Format::Time);
            assert!(src.query(&mut q), "{case}: the query is answered");
            q.result()
        };
        for (upto, last) in [(4, 2), (9, 7)] {
            let from = if upto == 4 { 0 } else { 4 };
            for (k, luma) in clip.iter().enumerate().take(upto).skip(from) {
                rig.push(buffer(VideoFormat::Gray8, w, h, luma, k)).unwrap();
            }
            drain(&mut rig);
            // The last output is stamped `last` (drop: the pair (last, last + 1)).
            let end = gst::GenericFormattedValue::from(pts(last) + pts(1));
            assert_eq!(position(), end, "{case}: after {upto} frames");
        }
        assert_eq!(std::iter::from_fn(|| rig.try_pull()).count(), 8, "{case}");
    }
}

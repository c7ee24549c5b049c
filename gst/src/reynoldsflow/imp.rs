//! The element: a `BaseTransform` that keeps the previous frame's luma and,
//! for every frame after the first, computes the pair through the host's
//! [`PairPool`] (the core, the CLI's parameters and checks,
//! the frame spread over `threads` cores so no latency is added).
//!
//! Outputs are made in `generate_output`, so one input can give two
//! outputs (`first-frame=repeat`) or none (`drop`). The pair is reset (the
//! next frame is a first frame again) on a flush, a caps change and a stop.

use std::collections::VecDeque;
use std::sync::{LazyLock, Mutex, MutexGuard};

use gst::glib;
use gst::prelude::*;
use gst::subclass::prelude::*;
use gst_base::subclass::base_transform::GenerateOutputSuccess;
use gst_base::subclass::prelude::*;
use gst_video::VideoFormat;
use gst_video::prelude::*;
use reynoldsflow_core::fixed::types::U32F32;
use reynoldsflow_core::{Config, Frame, MAX_SIDE, Params, Pixels, Sink};
use reynoldsflow_cues::Region;
use reynoldsflow_host::pair_pool::PairPool;
use reynoldsflow_host::settings::{self as values, ScaleArg};

use super::{FirstFrame, ScaleMode, VariantMode};
use crate::cues::{self, Cues};

static CAT: LazyLock<gst::DebugCategory> = LazyLock::new(|| {
    gst::DebugCategory::new(
        "reynoldsflow",
        gst::DebugColorFlags::empty(),
        Some("ReynoldsFlow element"),
    )
});

/// Input formats: the Y plane is the frame (as the CLI reads Y4M).
const FORMATS: [VideoFormat; 3] = [VideoFormat::Gray8, VideoFormat::I420, VideoFormat::Nv12];

/// What to tell a user whose caps are refused.
const ACCEPTED: &str = "reynoldsflow takes video/x-raw in GRAY8, I420 or NV12 \
    (the luma plane is used), 1 to 65535 px a side; put videoconvert before it";

/// The properties (read for every frame).
#[derive(Clone, Debug)]
struct Settings {
    first_frame: FirstFrame,
    scale: ScaleMode,
    k_d: f64,
    k_c: f64,
    lambda: f64,
    intensity_scale: String,
    variant: VariantMode,
    threads: u32,
    cues: bool,
    cue_threshold: f64,
    cue_min_area: u32,
    /// Bumped by every property change: the engine and cues are rebuilt.
    generation: u64,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            first_frame: FirstFrame::Drop,
            scale: ScaleMode::MinMax,
            k_d: 8.0,
            k_c: 32.0,
            lambda: 1e-4,
            intensity_scale: "1/255".to_owned(),
            variant: VariantMode::Dc,
            threads: 0,
            cues: false,
            cue_threshold: 1.0,
            cue_min_area: 4,
            generation: 0,
        }
    }
}

impl Settings {
    /// The engine, checked as `reynoldsflow run` checks its flags.
    fn pair_pool(&self) -> Result<PairPool, String> {
        let intensity_scale = values::parse_intensity_scale(&self.intensity_scale)
            .map_err(|e| format!("intensity-scale: {e}"))?;
        let scale = match self.scale {
            ScaleMode::MinMax => ScaleArg::MinMax,
            ScaleMode::Fixed => ScaleArg::Fixed {
                k_d: self.k_d,
                k_c: self.k_c,
            },
        };
        let threads = match self.threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            n => n as usize,
        };
        PairPool::new(scale, intensity_scale, self.lambda, threads).map_err(|e| e.to_string())
    }
}

/// A buffer's timing, given to the output that carries its label.
#[derive(Clone, Copy, Debug)]
struct Stamps {
    pts: Option<gst::ClockTime>,
    dts: Option<gst::ClockTime>,
    duration: Option<gst::ClockTime>,
    offset: u64,
    offset_end: u64,
}

impl Stamps {
    fn of(buffer: &gst::BufferRef) -> Self {
        Self {
            pts: buffer.pts(),
            dts: buffer.dts(),
            duration: buffer.duration(),
            offset: buffer.offset(),
            offset_end: buffer.offset_end(),
        }
    }

    fn apply(&self, buffer: &mut gst::BufferRef) {
        buffer.set_pts(self.pts);
        buffer.set_dts(self.dts);
        buffer.set_duration(self.duration);
        buffer.set_offset(self.offset);
        buffer.set_offset_end(self.offset_end);
    }
}

/// The frame a pair starts with.
struct Prev {
    /// Luma, packed (`width · height`).
    luma: Vec<u8>,
    stamps: Stamps,
    /// `first-frame=repeat`: this frame still waits for its output (a
    /// copy of the result of the pair it starts).
    awaits_copy: bool,
}

/// The streaming state, reset on flush, caps change and stop.
#[derive(Default)]
struct State {
    in_info: Option<gst_video::VideoInfo>,
    out_info: Option<gst_video::VideoInfo>,
    prev: Option<Prev>,
    /// Outputs made from the last input, not yet handed to the base class.
    pending: VecDeque<gst::Buffer>,
    /// The engine and the settings generation it was built for.
    pool: Option<(u64, PairPool)>,
    /// The cue sink and the generation it was built for.
    cues: Option<(u64, Box<Cues>)>,
    /// The next output follows a reset.
    discont: bool,
}

impl State {
    /// Forget the pair in progress (the next frame is a first frame).
    fn reset(&mut self) {
        self.prev = None;
        self.pending.clear();
        self.cues = None;
        self.discont = true;
    }
}

/// The `reynoldsflow` element.
#[derive(Default)]
pub struct ReynoldsFlow {
    settings: Mutex<Settings>,
    state: Mutex<State>,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A panic elsewhere cannot leave these half-written (plain assignments).
    m.lock().unwrap_or_else(|e| e.into_inner())
}

#[glib::object_subclass]
impl ObjectSubclass for ReynoldsFlow {
    const NAME: &'static str = "GstReynoldsFlow";
    type Type = super::ReynoldsFlow;
    type ParentType = gst_base::BaseTransform;
}

impl ObjectImpl for ReynoldsFlow {
    fn properties() -> &'static [glib::ParamSpec] {
        static PROPERTIES: LazyLock<Vec<glib::ParamSpec>> = LazyLock::new(|| {
            let d = Settings::default();
            vec![
                glib::ParamSpecEnum::builder_with_default("first-frame", d.first_frame)
                    .nick("First frame")
                    .blurb("What the first frame of a stream gives: drop (N frames, N-1 outputs, each stamped with its first frame), repeat or black (one output per frame, stamped with it)")
                    .mutable_playing()
                    .build(),
                glib::ParamSpecEnum::builder_with_default("scale", d.scale)
                    .nick("Scale")
                    .blurb("Magnitudes to bytes: per-frame min-max, or the fixed gains k-d and k-c (reynoldsflow run --scale)")
                    .mutable_playing()
                    .build(),
                glib::ParamSpecDouble::builder("k-d")
                    .nick("Gain of |v_d|")
                    .blurb("Gain of |v_d| (R) with scale=fixed, rounded to 1/65536")
                    .minimum(0.0)
                    .maximum(65535.0)
                    .default_value(d.k_d)
                    .mutable_playing()
                    .build(),
                glib::ParamSpecDouble::builder("k-c")
                    .nick("Gain of |v_c|")
                    .blurb("Gain of |v_c| (G) with scale=fixed, rounded to 1/65536")
                    .minimum(0.0)
                    .maximum(65535.0)
                    .default_value(d.k_c)
                    .mutable_playing()
                    .build(),
                glib::ParamSpecDouble::builder("lambda")
                    .nick("Lambda")
                    .blurb("Tikhonov term of the 2x2 solve, rounded to 2^-32 (reynoldsflow run --lambda)")
                    .minimum(0.0)
                    .default_value(d.lambda)
                    .mutable_playing()
                    .build(),
                glib::ParamSpecString::builder("intensity-scale")
                    .nick("Intensity scale")
                    .blurb("s in f = pixel * s, an exact ratio or decimal (reynoldsflow run --intensity-scale)")
                    .default_value(Some(d.intensity_scale.as_str()))
                    .mutable_playing()
                    .build(),
                glib::ParamSpecEnum::builder_with_default("variant", d.variant)
                    .nick("Variant")
                    .blurb("The image: dc = [|v_d|, |v_c|, f], dc0, cd, hsv (reynoldsflow run --variant)")
                    .mutable_playing()
                    .build(),
                glib::ParamSpecUInt::builder("threads")
                    .nick("Threads")
                    .blurb("Threads that compute each frame pair (0: every core); the output does not depend on it")
                    .maximum(1024)
                    .default_value(d.threads)
                    .mutable_playing()
                    .build(),
                glib::ParamSpecBoolean::builder("cues")
                    .nick("Motion cues")
                    .blurb("Add a region-of-interest meta (type \"motion\") per moving region to each output and post a \"reynoldsflow-cues\" element message per output")
                    .default_value(d.cues)
                    .mutable_playing()
                    .build(),
                glib::ParamSpecDouble::builder("cue-threshold")
                    .nick("Cue threshold")
                    .blurb("A pixel moves when |v_c| is above this, px")
                    .minimum(0.0)
                    .maximum(2_147_483_647.0)
                    .default_value(d.cue_threshold)
                    .mutable_playing()
                    .build(),
                glib::ParamSpecUInt::builder("cue-min-area")
                    .nick("Cue minimum area")
                    .blurb("Regions of fewer moving pixels are dropped")
                    .default_value(d.cue_min_area)
                    .mutable_playing()
                    .build(),
            ]
        });
        PROPERTIES.as_ref()
    }

    fn set_property(&self, _id: usize, value: &glib::Value, pspec: &glib::ParamSpec) {
        let mut s = lock(&self.settings);
        let wrong = "type checked by the property's spec";
        match pspec.name() {
            "first-frame" => s.first_frame = value.get().expect(wrong),
            "scale" => s.scale = value.get().expect(wrong),
            "k-d" => s.k_d = value.get().expect(wrong),
            "k-c" => s.k_c = value.get().expect(wrong),
            "lambda" => s.lambda = value.get().expect(wrong),
            "intensity-scale" => {
                s.intensity_scale = value
                    .get::<Option<String>>()
                    .expect(wrong)
                    .unwrap_or_else(|| Settings::default().intensity_scale)
            }
            "variant" => s.variant = value.get().expect(wrong),
            "threads" => s.threads = value.get().expect(wrong),
            "cues" => s.cues = value.get().expect(wrong),
            "cue-threshold" => s.cue_threshold = value.get().expect(wrong),
            "cue-min-area" => s.cue_min_area = value.get().expect(wrong),
            _ => unimplemented!("no property {}", pspec.name()),
        }
        s.generation += 1;
    }

    fn property(&self, _id: usize, pspec: &glib::ParamSpec) -> glib::Value {
        let s = lock(&self.settings);
        match pspec.name() {
            "first-frame" => s.first_frame.to_value(),
            "scale" => s.scale.to_value(),
            "k-d" => s.k_d.to_value(),
            "k-c" => s.k_c.to_value(),
            "lambda" => s.lambda.to_value(),
            "intensity-scale" => s.intensity_scale.to_value(),
            "variant" => s.variant.to_value(),
            "threads" => s.threads.to_value(),
            "cues" => s.cues.to_value(),
            "cue-threshold" => s.cue_threshold.to_value(),
            "cue-min-area" => s.cue_min_area.to_value(),
            _ => unimplemented!("no property {}", pspec.name()),
        }
    }

    fn constructed(&self) {
        self.parent_constructed();
        // Refused caps never reach set_caps (the pad checks them first):
        // say why here, on the caps event itself, rather than leave the
        // source with a bare "not-negotiated".
        let sink = self.obj().static_pad("sink").expect("template pad");
        sink.add_probe(gst::PadProbeType::EVENT_DOWNSTREAM, |pad, info| {
            if let Some(gst::EventView::Caps(caps)) = info.event().map(|e| e.view())
                && !caps.caps().can_intersect(&pad.pad_template_caps())
                && let Some(element) = pad.parent_element()
            {
                gst::element_error!(
                    element,
                    gst::CoreError::Negotiation,
                    ("Unsupported caps {}: {ACCEPTED}", caps.caps())
                );
            }
            gst::PadProbeReturn::Ok
        });
    }
}

impl GstObjectImpl for ReynoldsFlow {}

impl ElementImpl for ReynoldsFlow {
    fn metadata() -> Option<&'static gst::subclass::ElementMetadata> {
        static META: LazyLock<gst::subclass::ElementMetadata> = LazyLock::new(|| {
            gst::subclass::ElementMetadata::new(
                "ReynoldsFlow",
                "Filter/Analyzer/Video",
                "Optical-flow representation [|v_d|, |v_c|, f] of consecutive frames, \
                 exactly as `reynoldsflow run` computes it, with optional motion cues",
                "ReynoldsFlow project",
            )
        });
        Some(&META)
    }

    fn pad_templates() -> &'static [gst::PadTemplate] {
        static TEMPLATES: LazyLock<Vec<gst::PadTemplate>> = LazyLock::new(|| {
            let side = 1..=MAX_SIDE as i32;
            let sink = gst_video::VideoCapsBuilder::new()
                .format_list(FORMATS)
                .width_range(side.clone())
                .height_range(side.clone())
                .build();
            let src = gst_video::VideoCapsBuilder::new()
                .format(VideoFormat::Rgb)
                .width_range(side.clone())
                .height_range(side)
                .build();
            vec![
                gst::PadTemplate::new(
                    "sink",
                    gst::PadDirection::Sink,
                    gst::PadPresence::Always,
                    &sink,
                )
                .expect("valid template"),
                gst::PadTemplate::new(
                    "src",
                    gst::PadDirection::Src,
                    gst::PadPresence::Always,
                    &src,
                )
                .expect("valid template"),
            ]
        });
        TEMPLATES.as_ref()
    }
}

impl BaseTransformImpl for ReynoldsFlow {
    const MODE: gst_base::subclass::BaseTransformMode =
        gst_base::subclass::BaseTransformMode::NeverInPlace;
    const PASSTHROUGH_ON_SAME_CAPS: bool = false;
    const TRANSFORM_IP_ON_PASSTHROUGH: bool = false;

    fn stop(&self) -> Result<(), gst::ErrorMessage> {
        *lock(&self.state) = State::default();
        Ok(())
    }

    fn transform_caps(
        &self,
        direction: gst::PadDirection,
        caps: &gst::Caps,
        filter: Option<&gst::Caps>,
    ) -> Option<gst::Caps> {
        // Same size, framerate and aspect; only the format changes.
        let mut other = gst::Caps::new_empty();
        {
            let other = other.get_mut().expect("new caps are writable");
            for s in caps.iter() {
                let mut s = s.to_owned();
                s.remove_fields(["format", "colorimetry", "chroma-site"]);
                match direction {
                    gst::PadDirection::Sink => s.set("format", VideoFormat::Rgb.to_str()),
                    _ => s.set("format", gst::List::new(FORMATS.iter().map(|f| f.to_str()))),
                }
                other.append_structure(s);
            }
        }
        gst::trace!(CAT, imp = self, "{direction:?} {caps} -> {other}");
        Some(match filter {
            Some(filter) => filter.intersect_with_mode(&other, gst::CapsIntersectMode::First),
            None => other,
        })
    }

    fn set_caps(&self, incaps: &gst::Caps, outcaps: &gst::Caps) -> Result<(), gst::LoggableError> {
        let refuse = |why: String| {
            gst::element_imp_error!(
                self,
                gst::CoreError::Negotiation,
                ("Unsupported caps {incaps} ({why}): {ACCEPTED}")
            );
            gst::loggable_error!(CAT, "{why}")
        };
        let in_info = gst_video::VideoInfo::from_caps(incaps)
            .map_err(|e| refuse(format!("not raw video ({e})")))?;
        let out_info = gst_video::VideoInfo::from_caps(outcaps)
            .map_err(|e| refuse(format!("output caps {outcaps} ({e})")))?;
        if !FORMATS.contains(&in_info.format()) {
            return Err(refuse(format!("format {}", in_info.format().to_str())));
        }
        let size = |i: &gst_video::VideoInfo| (i.width(), i.height());
        if out_info.format() != VideoFormat::Rgb || size(&out_info) != size(&in_info) {
            return Err(refuse(format!("output caps {outcaps}")));
        }
        // The core's size limits do not depend on the parameters.
        Config::new(
            in_info.width() as usize,
            in_info.height() as usize,
            Params::DEFAULT,
        )
        .map_err(|e| refuse(format!("frame size: {e}")))?;
        gst::debug!(CAT, imp = self, "{incaps} -> {outcaps}");
        let mut state = lock(&self.state);
        state.reset();
        state.in_info = Some(in_info);
        state.out_info = Some(out_info);
        Ok(())
    }

    fn sink_event(&self, event: gst::Event) -> bool {
        if let gst::EventView::FlushStop(_) = event.view() {
            lock(&self.state).reset();
        }
        self.parent_sink_event(event)
    }

    fn query(&self, direction: gst::PadDirection, query: &mut gst::QueryRef) -> bool {
        if !BaseTransformImplExt::parent_query(self, direction, query) {
            return false;
        }
        // With drop and repeat a result leaves when the frame after its
        // label arrives: one frame later than its timestamp.
        if direction == gst::PadDirection::Src
            && let gst::QueryViewMut::Latency(q) = query.view_mut()
            && lock(&self.settings).first_frame != FirstFrame::Black
            && let Some(frame) = lock(&self.state).in_info.as_ref().and_then(frame_duration)
        {
            let (live, min, max) = q.result();
            q.set(live, min + frame, max.map(|m| m + frame));
        }
        true
    }

    fn generate_output(&self) -> Result<GenerateOutputSuccess, gst::FlowError> {
        if let Some(input) = self.take_queued_buffer() {
            self.process(&input)?;
        }
        Ok(match lock(&self.state).pending.pop_front() {
            Some(buffer) => GenerateOutputSuccess::Buffer(buffer),
            None => GenerateOutputSuccess::NoOutput,
        })
    }
}

/// One frame's duration at the caps' framerate (none when variable).
fn frame_duration(info: &gst_video::VideoInfo) -> Option<gst::ClockTime> {
    let fps = info.fps();
    let (num, den) = (
        u64::try_from(fps.numer()).ok()?,
        u64::try_from(fps.denom()).ok()?,
    );
    (num > 0).then(|| gst::ClockTime::SECOND.mul_div_floor(den, num))?
}

/// One pair's image and cues, ready to be stamped.
struct PairOutput {
    rgb: Vec<u8>,
    /// The cues' regions and level, when `cues=true`.
    cues: Option<(Vec<Region>, U32F32)>,
}

impl ReynoldsFlow {
    /// Take one input frame: queue the outputs it gives.
    fn process(&self, input: &gst::Buffer) -> Result<(), gst::FlowError> {
        let settings = lock(&self.settings).clone();
        let mut state = lock(&self.state);
        let state = &mut *state;
        let (Some(in_info), Some(out_info)) = (state.in_info.clone(), state.out_info.clone())
        else {
            gst::element_imp_error!(
                self,
                gst::CoreError::Negotiation,
                ("No caps before the first frame")
            );
            return Err(gst::FlowError::NotNegotiated);
        };
        let (width, height) = (in_info.width() as usize, in_info.height() as usize);
        let frame = gst_video::VideoFrameRef::from_buffer_ref_readable(input.as_ref(), &in_info)
            .map_err(|_| {
                gst::element_imp_error!(
                    self,
                    gst::StreamError::Format,
                    ("A buffer smaller than its caps say")
                );
                gst::FlowError::Error
            })?;
        let stride = frame.plane_stride()[0] as usize;
        let luma = frame.plane_data(0).map_err(|_| gst::FlowError::Error)?;
        let stamps = Stamps::of(input);
        // Checked on every frame, the first included: a bad setting stops
        // the stream at once, with the CLI's message for its flag.
        if state
            .pool
            .as_ref()
            .is_none_or(|(g, _)| *g != settings.generation)
        {
            let pool = settings.pair_pool().map_err(|why| {
                gst::element_imp_error!(self, gst::LibraryError::Settings, ("{why}"));
                gst::FlowError::Error
            })?;
            state.pool = Some((settings.generation, pool));
        }

        let Some(mut prev) = state.prev.take() else {
            if settings.first_frame == FirstFrame::Black {
                let black = vec![0u8; 3 * width * height];
                let out = self.output(state, &out_info, &black, &stamps, None)?;
                state.pending.push_back(out);
            }
            state.prev = Some(Prev {
                luma: packed(luma, width, height, stride),
                stamps,
                awaits_copy: settings.first_frame == FirstFrame::Repeat,
            });
            return Ok(());
        };

        let result = self.compute(state, &settings, &prev.luma, luma, width, height, stride)?;
        if prev.awaits_copy {
            let copy = self.output(
                state,
                &out_info,
                &result.rgb,
                &prev.stamps,
                result.cues.as_ref(),
            )?;
            state.pending.push_back(copy);
        }
        let label = match settings.first_frame {
            FirstFrame::Drop => prev.stamps,
            FirstFrame::Repeat | FirstFrame::Black => stamps,
        };
        let out = self.output(state, &out_info, &result.rgb, &label, result.cues.as_ref())?;
        state.pending.push_back(out);
        // The next pair starts with this frame (the allocation is reused).
        prev.luma.clear();
        pack_into(&mut prev.luma, luma, width, height, stride);
        prev.stamps = stamps;
        prev.awaits_copy = false;
        state.prev = Some(prev);
        Ok(())
    }

    /// The pair `(prev, next)` through the engine (rebuilt when a property
    /// changed), and its cues.
    #[allow(clippy::too_many_arguments)]
    fn compute(
        &self,
        state: &mut State,
        settings: &Settings,
        prev: &[u8],
        next: &[u8],
        width: usize,
        height: usize,
        stride: usize,
    ) -> Result<PairOutput, gst::FlowError> {
        let settings_error = |why: String| {
            gst::element_imp_error!(self, gst::LibraryError::Settings, ("{why}"));
            gst::FlowError::Error
        };
        let Some((_, pool)) = state.pool.as_mut() else {
            unreachable!("process builds it first")
        };
        let frames = (
            Frame::packed(prev, width, height),
            Frame::new(next, width, height, stride),
        );
        let (Ok(prev), Ok(next)) = frames else {
            gst::element_imp_error!(
                self,
                gst::StreamError::Format,
                ("Frames of {width}x{height} do not fit their buffers")
            );
            return Err(gst::FlowError::Error);
        };
        let pixels = pool.compute(prev, next).map_err(|e| {
            gst::element_imp_error!(self, gst::StreamError::Failed, ("{e}"));
            gst::FlowError::Error
        })?;
        let rgb = pixels.image(settings.variant.host());
        let cues = match settings.cues {
            false => None,
            true => {
                if state
                    .cues
                    .as_ref()
                    .is_none_or(|(g, _)| *g != settings.generation)
                {
                    // The grid depends on the frame size only.
                    let config = Config::new(width, height, Params::DEFAULT)
                        .map_err(|e| settings_error(e.to_string()))?;
                    let params = cues::params(settings.cue_threshold, settings.cue_min_area)
                        .map_err(settings_error)?;
                    let sink = cues::new_cues(&config, params).map_err(|e| {
                        settings_error(format!(
                            "cues: {e} (they cover frames up to {} px a side)",
                            cues::MAX_SIDE
                        ))
                    })?;
                    state.cues = Some((settings.generation, sink));
                }
                let Some((_, sink)) = state.cues.as_mut() else {
                    unreachable!("built above")
                };
                // Whole rows in raster order: the cues are the same for any
                // order the engine's tiles would have given (the cues crate's
                // doc).
                // The cues read the magnitudes only (`reads_fields` is false).
                let (mut m_d, mut m_c, mut luma) = (Vec::new(), Vec::new(), Vec::new());
                for (y, row) in pixels.pixels().chunks(width).enumerate() {
                    m_d.clear();
                    m_d.extend(row.iter().map(|p| p.m_d));
                    m_c.clear();
                    m_c.extend(row.iter().map(|p| p.m_c));
                    luma.clear();
                    luma.extend(row.iter().map(|p| p.luma));
                    let fields = None;
                    sink.row(
                        y,
                        0,
                        Pixels {
                            m_d: &m_d,
                            m_c: &m_c,
                            luma: &luma,
                            fields,
                        },
                    );
                }
                let regions = sink.end_frame().to_vec();
                Some((regions, sink.last_frame().level))
            }
        };
        Ok(PairOutput { rgb, cues })
    }

    /// An output buffer: `rgb` in the negotiated layout, stamped, with its
    /// cues as metas (and their message posted).
    fn output(
        &self,
        state: &mut State,
        out_info: &gst_video::VideoInfo,
        rgb: &[u8],
        stamps: &Stamps,
        cues: Option<&(Vec<Region>, U32F32)>,
    ) -> Result<gst::Buffer, gst::FlowError> {
        let mut buffer =
            gst::Buffer::with_size(out_info.size()).map_err(|_| gst::FlowError::Error)?;
        {
            let buffer = buffer.get_mut().expect("a new buffer is writable");
            stamps.apply(buffer);
            if std::mem::take(&mut state.discont) {
                buffer.set_flags(gst::BufferFlags::DISCONT);
            }
            let mut frame = gst_video::VideoFrameRef::from_buffer_ref_writable(buffer, out_info)
                .map_err(|_| gst::FlowError::Error)?;
            let stride = frame.plane_stride()[0] as usize;
            let row_bytes = 3 * out_info.width() as usize;
            let plane = frame.plane_data_mut(0).map_err(|_| gst::FlowError::Error)?;
            for (dst, src) in plane.chunks_mut(stride).zip(rgb.chunks(row_bytes)) {
                dst[..row_bytes].copy_from_slice(src);
            }
        }
        if let Some((regions, level)) = cues {
            cues::add_metas(buffer.get_mut().expect("not shared yet"), regions);
            let structure = cues::message_structure(stamps.pts, *level, regions);
            let message = gst::message::Element::builder(structure)
                .src(&*self.obj())
                .build();
            let _ = self.obj().post_message(message);
        }
        Ok(buffer)
    }
}

/// `height` rows of `width` bytes from a plane with `stride`, packed.
fn packed(plane: &[u8], width: usize, height: usize, stride: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(width * height);
    pack_into(&mut out, plane, width, height, stride);
    out
}

fn pack_into(out: &mut Vec<u8>, plane: &[u8], width: usize, height: usize, stride: usize) {
    for row in plane.chunks(stride.max(1)).take(height) {
        out.extend_from_slice(&row[..width.min(row.len())]);
    }
}

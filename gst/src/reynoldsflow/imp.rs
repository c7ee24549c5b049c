//! The element: a `BaseTransform` that keeps the previous frame's luma and,
//! for every frame after the first, computes the pair through the host's
//! pair engine (`run`'s path), in the order the host's [`PairStream`] says
//! (first-frame policy, restarts).
//!
//! On one thread, and from a live source, each pair is computed as its
//! frame arrives, its tiles spread over `threads` cores (one pair's
//! latency), and its outputs are made in `generate_output`, so one input
//! can give two outputs (`first-frame=repeat`) or none (`drop`). From a
//! source that is not live (a file) on more threads, whose frames come
//! faster than one pair takes, each thread computes whole pairs while the
//! streaming thread goes on ([`super::workers`]), and the outputs leave in
//! order from the [`Outbox`]; serialized events and queries wait for the
//! outputs before them. The bytes are the same either way, and so is what
//! travels with them: the element pushes every output itself (through the
//! outbox), marking `DISCONT` and keeping the position for POSITION
//! queries, on both paths. The pair chain breaks (the next frame is a
//! first frame again) on a flush, a stop, new caps, a gap (a GAP event or
//! a buffer flagged GAP), a discontinuity (a buffer flagged DISCONT, or one
//! the base class drops as late with `qos=true`) and a timestamp going
//! back; at new caps, a gap, a discontinuity and EOS the last frame gets
//! the output it still owes (`repeat`), so every frame gets one; the first
//! output after a flush, a stop or a discontinuity carries `DISCONT`.

use std::collections::VecDeque;
use std::sync::{Arc, LazyLock, Mutex, MutexGuard, OnceLock};

use gst::glib;
use gst::prelude::*;
use gst::subclass::prelude::*;
use gst_base::subclass::base_transform::GenerateOutputSuccess;
use gst_base::subclass::prelude::*;
use gst_video::VideoFormat;
use gst_video::prelude::*;
use reynoldsflow_core::{Config, MAX_SIDE, Params};
use reynoldsflow_host::pair_stream::{Frame, Output, PairStream};
use reynoldsflow_host::settings::{self as values, FirstFrame, Setting, Settings};
use reynoldsflow_host::{Gray, HostError};

use super::outbox::{Item, Outbox, Ready, Slot};
use super::pairs::{Failure, PairOutput, Pairs, Stamps, outputs_of};
use super::workers::{Recipe, Workers};
use super::{FirstFrameMode, ScaleMode, VariantMode};

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

/// `threads` when unset: every core (the host's `threads: None`).
const DEFAULT_THREADS: u32 = 0;
/// `cues` when unset: no cues.
const DEFAULT_CUES: bool = false;

/// The host's default intensity scale as the property writes it.
fn default_intensity_scale() -> String {
    let s = values::DEFAULT_INTENSITY_SCALE;
    format!("{}/{}", s.num(), s.den())
}

/// The properties (read for every frame): the host's settings, and what
/// the element keeps as set until the next frame checks it.
#[derive(Clone, Debug)]
struct Properties {
    /// Every setting the element has (scale and intensity scale as below).
    settings: Settings,
    /// `scale`, `k-d`, `k-c` (the gains are kept with min–max too).
    scale: ScaleMode,
    gains: (f64, f64),
    /// `intensity-scale` as set.
    intensity_scale: String,
    /// `cues`.
    cues: bool,
    /// Bumped by every property change: the engine and cues are rebuilt.
    generation: u64,
}

impl Default for Properties {
    fn default() -> Self {
        Self {
            settings: Settings::default(),
            scale: ScaleMode::of(values::DEFAULT_SCALE),
            gains: values::DEFAULT_FIXED_GAINS,
            intensity_scale: default_intensity_scale(),
            cues: DEFAULT_CUES,
            generation: 0,
        }
    }
}

impl Properties {
    /// The host's settings, the intensity scale parsed (the rest is checked
    /// when the engine is built).
    fn settings(&self) -> Result<Settings, HostError> {
        let intensity_scale = values::parse_intensity_scale(&self.intensity_scale)
            .map_err(|e| HostError::setting(Setting::IntensityScale, e))?;
        Ok(Settings {
            scale: self.scale.host(self.gains),
            intensity_scale,
            ..self.settings.clone()
        })
    }
}

/// How the pairs are computed.
enum Compute {
    /// As each frame arrives, on the streaming thread and the engine's
    /// helpers.
    Here(Box<Pairs>),
    /// Whole pairs on the workers, each with the recipe of its engine.
    Workers(Workers, Arc<Recipe>),
}

/// A pair's result as the stream hands it on.
enum Computed {
    /// Computed here.
    Done(PairOutput),
    /// On a worker.
    Queued(Slot),
}

/// The streaming state, reset on flush, caps change and stop.
struct State {
    in_info: Option<gst_video::VideoInfo>,
    out_info: Option<gst_video::VideoInfo>,
    stream: PairStream<Stamps, Arc<Gray>>,
    /// Outputs made from the last input, not yet handed downstream (when
    /// computed here).
    pending: VecDeque<Ready>,
    compute: Option<Compute>,
    /// Whether the source is live (asked once per stream).
    live: Option<bool>,
    /// The next output follows a reset or a discontinuity: it carries
    /// `DISCONT`.
    discont: bool,
}

impl Default for State {
    fn default() -> Self {
        Self {
            in_info: None,
            out_info: None,
            stream: PairStream::new(values::DEFAULT_FIRST_FRAME),
            pending: VecDeque::new(),
            compute: None,
            live: None,
            discont: true,
        }
    }
}

impl State {
    /// Forget the pair in progress (the next frame is a first frame).
    fn reset(&mut self) {
        self.stream.reset();
        self.pending.clear();
        self.live = None;
        self.discont = true;
    }
}

/// The `reynoldsflow` element.
#[derive(Default)]
pub struct ReynoldsFlow {
    settings: Mutex<Properties>,
    state: Mutex<State>,
    /// The outputs of pairs computed on the workers (made when the element
    /// is constructed).
    outbox: OnceLock<Arc<Outbox>>,
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
            vec![
                glib::ParamSpecEnum::builder_with_default(
                    "first-frame",
                    FirstFrameMode::from(values::DEFAULT_FIRST_FRAME),
                )
                    .nick("First frame")
                    .blurb("What the first frame of a stream gives: drop (N frames, N-1 outputs, each stamped with its first frame), repeat or black (one output per frame, stamped with it)")
                    .mutable_playing()
                    .build(),
                glib::ParamSpecEnum::builder_with_default("scale", ScaleMode::of(values::DEFAULT_SCALE))
                    .nick("Scale")
                    .blurb("Magnitudes to bytes: per-frame min-max, or the fixed gains k-d and k-c (reynoldsflow run --scale)")
                    .mutable_playing()
                    .build(),
                glib::ParamSpecDouble::builder("k-d")
                    .nick("Gain of |v_d|")
                    .blurb("Gain of |v_d| (R) with scale=fixed, rounded to 1/65536")
                    .minimum(0.0)
                    .maximum(65535.0)
                    .default_value(values::DEFAULT_FIXED_GAINS.0)
                    .mutable_playing()
                    .build(),
                glib::ParamSpecDouble::builder("k-c")
                    .nick("Gain of |v_c|")
                    .blurb("Gain of |v_c| (G) with scale=fixed, rounded to 1/65536")
                    .minimum(0.0)
                    .maximum(65535.0)
                    .default_value(values::DEFAULT_FIXED_GAINS.1)
                    .mutable_playing()
                    .build(),
                glib::ParamSpecDouble::builder("lambda")
                    .nick("Lambda")
                    .blurb("Tikhonov term of the 2x2 solve, rounded to 2^-32 (reynoldsflow run --lambda)")
                    .minimum(0.0)
                    .default_value(values::DEFAULT_LAMBDA)
                    .mutable_playing()
                    .build(),
                glib::ParamSpecString::builder("intensity-scale")
                    .nick("Intensity scale")
                    .blurb("s in f = pixel * s, an exact ratio or decimal (reynoldsflow run --intensity-scale)")
                    .default_value(Some(default_intensity_scale().as_str()))
                    .mutable_playing()
                    .build(),
                glib::ParamSpecEnum::builder_with_default(
                    "variant",
                    VariantMode::from(values::DEFAULT_VARIANT),
                )
                    .nick("Variant")
                    .blurb("The image: dc = [|v_d|, |v_c|, f], dc0, cd, hsv (reynoldsflow run --variant)")
                    .mutable_playing()
                    .build(),
                glib::ParamSpecUInt::builder("threads")
                    .nick("Threads")
                    .blurb("Threads (0: every core): from a live source they share each pair as it arrives, otherwise each computes whole pairs; the output does not depend on it")
                    .maximum(1024)
                    .default_value(DEFAULT_THREADS)
                    .mutable_playing()
                    .build(),
                glib::ParamSpecBoolean::builder("cues")
                    .nick("Motion cues")
                    .blurb("Add a region-of-interest meta (type \"motion\") per moving region to each output and post a \"reynoldsflow-cues\" element message per output")
                    .default_value(DEFAULT_CUES)
                    .mutable_playing()
                    .build(),
                glib::ParamSpecDouble::builder("cue-threshold")
                    .nick("Cue threshold")
                    .blurb("A pixel moves when |v_c| is above this, px")
                    .minimum(0.0)
                    .maximum(2_147_483_647.0)
                    .default_value(values::DEFAULT_CUE_THRESHOLD)
                    .mutable_playing()
                    .build(),
                glib::ParamSpecUInt::builder("cue-min-area")
                    .nick("Cue minimum area")
                    .blurb("Regions of fewer moving pixels are dropped")
                    .default_value(values::DEFAULT_CUE_MIN_AREA)
                    .mutable_playing()
                    .build(),
            ]
        });
        PROPERTIES.as_ref()
    }

    fn set_property(&self, _id: usize, value: &glib::Value, pspec: &glib::ParamSpec) {
        let mut guard = lock(&self.settings);
        let wrong = "type checked by the property's spec";
        let p = &mut *guard;
        let s = &mut p.settings;
        match pspec.name() {
            "first-frame" => s.first_frame = value.get::<FirstFrameMode>().expect(wrong).into(),
            "scale" => p.scale = value.get().expect(wrong),
            "k-d" => p.gains.0 = value.get().expect(wrong),
            "k-c" => p.gains.1 = value.get().expect(wrong),
            "lambda" => s.lambda = value.get().expect(wrong),
            "intensity-scale" => {
                p.intensity_scale = value
                    .get::<Option<String>>()
                    .expect(wrong)
                    .unwrap_or_else(default_intensity_scale)
            }
            "variant" => s.variant = value.get::<VariantMode>().expect(wrong).into(),
            "threads" => {
                s.threads = match value.get::<u32>().expect(wrong) {
                    0 => None,
                    n => Some(n as usize),
                }
            }
            "cues" => p.cues = value.get().expect(wrong),
            "cue-threshold" => s.cue_threshold = value.get().expect(wrong),
            "cue-min-area" => s.cue_min_area = value.get().expect(wrong),
            _ => unimplemented!("no property {}", pspec.name()),
        }
        p.generation += 1;
    }

    fn property(&self, _id: usize, pspec: &glib::ParamSpec) -> glib::Value {
        let p = lock(&self.settings);
        let s = &p.settings;
        match pspec.name() {
            "first-frame" => FirstFrameMode::from(s.first_frame).to_value(),
            "scale" => p.scale.to_value(),
            "k-d" => p.gains.0.to_value(),
            "k-c" => p.gains.1.to_value(),
            "lambda" => s.lambda.to_value(),
            "intensity-scale" => p.intensity_scale.to_value(),
            "variant" => VariantMode::from(s.variant).to_value(),
            "threads" => (s.threads.unwrap_or(0) as u32).to_value(),
            "cues" => p.cues.to_value(),
            "cue-threshold" => s.cue_threshold.to_value(),
            "cue-min-area" => s.cue_min_area.to_value(),
            _ => unimplemented!("no property {}", pspec.name()),
        }
    }

    fn constructed(&self) {
        self.parent_constructed();
        let _ = self.outbox.set(Arc::new(Outbox::new(&self.obj())));
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
        // The pads are flushing already: a push in hand returns at once.
        self.outbox().flush_stop();
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
        match event.view() {
            gst::EventView::FlushStart(_) => self.outbox().flush_start(),
            gst::EventView::FlushStop(_) => {
                self.outbox().flush_stop();
                lock(&self.state).reset();
            }
            // The stream ends before new caps (the frame that owes an
            // output is made in the old ones), at EOS and at a gap (no pair
            // spans it; the gap goes on downstream).
            gst::EventView::Caps(_) | gst::EventView::Eos(_) | gst::EventView::Gap(_) => {
                if self.end_stream().is_err() {
                    return false;
                }
                // A push that failed (downstream at its end, or in error)
                // went upstream already; the event goes on all the same,
                // so an EOS still ends the pipeline.
                let _ = self.flush_outputs();
            }
            // The outputs before it were in the old segment.
            gst::EventView::Segment(segment) => {
                let _ = self.outbox().drain();
                self.outbox().set_segment(segment.segment());
            }
            // Every other serialized event goes on after the outputs before it.
            _ if event.is_serialized() => {
                let _ = self.outbox().drain();
            }
            _ => {}
        }
        self.parent_sink_event(event)
    }

    fn query(&self, direction: gst::PadDirection, query: &mut gst::QueryRef) -> bool {
        // A serialized query (allocation, drain) comes after the outputs
        // before it.
        if direction == gst::PadDirection::Sink && query.is_serialized() {
            let _ = self.outbox().drain();
        }
        // The position of the outputs, which the element pushes itself
        // (the base class knows only of buffers it pushes).
        if let gst::QueryViewMut::Position(q) = query.view_mut()
            && q.format() == gst::Format::Time
            && let Some(position) = self.outbox().position()
        {
            q.set(position);
            return true;
        }
        if !BaseTransformImplExt::parent_query(self, direction, query) {
            return false;
        }
        // With drop and repeat a result leaves when the frame after its
        // label arrives: one frame later than its timestamp.
        if direction == gst::PadDirection::Src
            && let gst::QueryViewMut::Latency(q) = query.view_mut()
            && lock(&self.settings).settings.first_frame != FirstFrame::Black
            && let Some(frame) = lock(&self.state).in_info.as_ref().and_then(frame_duration)
        {
            let (live, min, max) = q.result();
            q.set(live, min + frame, max.map(|m| m + frame));
        }
        true
    }

    fn submit_input_buffer(
        &self,
        is_discont: bool,
        inbuf: gst::Buffer,
    ) -> Result<gst::FlowSuccess, gst::FlowError> {
        // (`is_discont` stays set in the base class until a buffer it
        // pushes itself, and it pushes none: the element reads each
        // buffer's own flag instead, in `process`.)
        let submitted = self.parent_submit_input_buffer(is_discont, inbuf)?;
        if submitted == gst_base::BASE_TRANSFORM_FLOW_DROPPED {
            // Late (`qos=true`): the base class dropped the frame before
            // the element sees it, so no pair may span it.
            gst::debug!(
                CAT,
                imp = self,
                "a frame dropped as late breaks the pair chain"
            );
            self.discontinuity(&mut lock(&self.state))?;
            self.push_owed()?;
        }
        Ok(submitted)
    }

    fn generate_output(&self) -> Result<GenerateOutputSuccess, gst::FlowError> {
        if let Some(input) = self.take_queued_buffer()
            && let Some(threads) = self.process(&input)?
        {
            // On the workers: room for the next frame once a thread is
            // free (the state is not held: a push may query the element).
            let outbox = self.outbox();
            outbox.push_ready();
            outbox.wait_room(threads)?;
            return Ok(GenerateOutputSuccess::NoOutput);
        }
        // Computed here: pushed now, after the workers' outputs if any
        // (none is returned to the base class, see the outbox).
        self.flush_outputs()?;
        Ok(GenerateOutputSuccess::NoOutput)
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

impl ReynoldsFlow {
    fn outbox(&self) -> &Arc<Outbox> {
        self.outbox
            .get()
            .expect("made when the element is constructed")
    }

    fn next_pending(&self) -> Option<Ready> {
        lock(&self.state).pending.pop_front()
    }

    /// Post `failure` as an element error: the flow error to return.
    fn fail(&self, failure: &Failure) -> gst::FlowError {
        failure.post(&self.obj());
        gst::FlowError::Error
    }

    /// Whether the source is live (its latency query says so): each pair
    /// is then computed as its frame arrives. One that does not answer is
    /// taken to be live.
    fn upstream_live(&self) -> bool {
        let mut query = gst::query::Latency::new();
        !self.obj().sink_pad().peer_query(&mut query) || query.result().0
    }

    /// Take one input frame: queue the outputs it gives. Returns the
    /// workers' threads when they compute its pairs.
    fn process(&self, input: &gst::Buffer) -> Result<Option<usize>, gst::FlowError> {
        let properties = lock(&self.settings).clone();
        let live = lock(&self.state).live;
        let live = live.unwrap_or_else(|| {
            let live = self.upstream_live();
            lock(&self.state).live = Some(live);
            live
        });
        let mut state = lock(&self.state);
        let state = &mut *state;
        let Some(in_info) = state.in_info.clone() else {
            gst::element_imp_error!(
                self,
                gst::CoreError::Negotiation,
                ("No caps before the first frame")
            );
            return Err(gst::FlowError::NotNegotiated);
        };
        let out_info = state
            .out_info
            .clone()
            .ok_or(gst::FlowError::NotNegotiated)?;
        // Checked on every frame, the first included: a bad setting stops
        // the stream at once, naming its property.
        self.prepare(state, &properties, live, &out_info)?;
        if input.flags().contains(gst::BufferFlags::DISCONT) {
            // Frames lost upstream (a driver, packet loss, a seek): the
            // frame before and this one are no consecutive frames.
            self.discontinuity(state)?;
        }
        let stamps = Stamps::of(input);
        if input.flags().contains(gst::BufferFlags::GAP) {
            // No frame here (its bytes, if any, show nothing): the stream
            // ends, and the gap goes on downstream in its place.
            self.end_locked(state)?;
            let gap = gst::event::Gap::builder(stamps.pts.unwrap_or(gst::ClockTime::ZERO))
                .duration(stamps.duration)
                .build();
            self.queue_ready(state, Ready::Gap(gap));
            return Ok(state.workers());
        }
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
        // The frame the last pair no longer needs, unless a worker still
        // reads it.
        let mut gray = state
            .stream
            .take_spare()
            .and_then(|spare| Arc::try_unwrap(spare).ok())
            .unwrap_or(Gray {
                width: 0,
                height: 0,
                pixels: Vec::new(),
            });
        gray.pixels.clear();
        for row in luma.chunks(stride.max(1)).take(height) {
            gray.pixels.extend_from_slice(&row[..width.min(row.len())]);
        }
        (gray.width, gray.height) = (width, height);
        let frame = Frame {
            gray: Arc::new(gray),
            encoding: in_info.format().to_str().as_str(),
            stamp: stamps.pts.map(|t| i128::from(t.nseconds())),
            label: stamps,
        };
        let (stream, compute) = (&mut state.stream, &mut state.compute);
        let step = stream.push(frame, |prev, next| {
            self.pair(compute, &out_info, prev, next)
        })?;
        if let Some(restart) = &step.restart {
            gst::info!(CAT, imp = self, "the pair chain restarts: {restart}");
        }
        self.queue(state, step.outputs)?;
        Ok(state.workers())
    }

    /// Build what computes the pairs anew when a property changed, on the
    /// workers when the source is not live and more than one thread asked.
    fn prepare(
        &self,
        state: &mut State,
        properties: &Properties,
        live: bool,
        out_info: &gst_video::VideoInfo,
    ) -> Result<(), gst::FlowError> {
        let generation = properties.generation;
        let settings = properties
            .settings()
            .map_err(|e| self.fail(&Failure::Settings(super::message(&e))))?;
        let threads = settings.threads();
        let here = live || threads < 2;
        let current = match &state.compute {
            Some(Compute::Here(pairs)) => here && pairs.generation == generation,
            Some(Compute::Workers(workers, recipe)) => {
                !here
                    && recipe.generation == generation
                    && workers.threads() == threads
                    && recipe.out_info == *out_info
            }
            None => false,
        };
        if !current {
            let compute = match here {
                true => Compute::Here(Box::new(
                    Pairs::new(&settings, properties.cues, generation)
                        .map_err(|f| self.fail(&f))?,
                )),
                false => {
                    let recipe = Arc::new(Recipe {
                        settings: Settings {
                            threads: Some(1),
                            ..settings.clone()
                        },
                        cues: properties.cues,
                        generation,
                        out_info: out_info.clone(),
                    });
                    let workers = match state.compute.take() {
                        Some(Compute::Workers(w, _)) if w.threads() == threads => w,
                        _ => Workers::new(threads).map_err(|f| self.fail(&f))?,
                    };
                    workers.prepare(&recipe).map_err(|f| self.fail(&f))?;
                    Compute::Workers(workers, recipe)
                }
            };
            match &compute {
                Compute::Here(_) => gst::info!(
                    CAT,
                    imp = self,
                    "each pair computed as its frame arrives, on {threads} thread(s)"
                ),
                Compute::Workers(..) => gst::info!(
                    CAT,
                    imp = self,
                    "whole pairs on {threads} threads (the source is not live)"
                ),
            }
            state.compute = Some(compute);
        }
        state.stream.set_first_frame(settings.first_frame);
        Ok(())
    }

    /// The stream ends here: queue the output its last frame still owes.
    fn end_stream(&self) -> Result<(), gst::FlowError> {
        let mut state = lock(&self.state);
        self.end_locked(&mut state)
    }

    fn end_locked(&self, state: &mut State) -> Result<(), gst::FlowError> {
        let (stream, compute) = (&mut state.stream, &mut state.compute);
        let Some(out_info) = state.out_info.as_ref() else {
            stream.reset();
            return Ok(());
        };
        let owed = stream.end(|prev, next| self.pair(compute, out_info, prev, next))?;
        self.queue(state, owed.into_iter().collect())
    }

    /// A discontinuity before the next frame: the stream ends here (the
    /// last frame gets the output it owes) and the next output carries
    /// `DISCONT`.
    fn discontinuity(&self, state: &mut State) -> Result<(), gst::FlowError> {
        self.end_locked(state)?;
        state.discont = true;
        Ok(())
    }

    /// The outputs the streaming thread holds, after the workers' ones:
    /// pushed now (before an event).
    fn flush_outputs(&self) -> Result<gst::FlowSuccess, gst::FlowError> {
        let outbox = self.outbox();
        outbox.push_ready();
        outbox.drain()?;
        while let Some(next) = self.next_pending() {
            outbox.send(next)?;
        }
        Ok(gst::FlowSuccess::Ok)
    }

    /// The output a stream that ended between frames owes, on its way:
    /// pushed now when made here (waiting for the workers' outputs before
    /// it only then), in the outbox's turn when on the workers.
    fn push_owed(&self) -> Result<gst::FlowSuccess, gst::FlowError> {
        let outbox = self.outbox();
        outbox.push_ready();
        match lock(&self.state).pending.is_empty() {
            true => Ok(gst::FlowSuccess::Ok),
            false => self.flush_outputs(),
        }
    }

    /// The pair `(prev, next)`: computed here, or handed to a worker.
    fn pair(
        &self,
        compute: &mut Option<Compute>,
        out_info: &gst_video::VideoInfo,
        prev: &Arc<Gray>,
        next: &Arc<Gray>,
    ) -> Result<Computed, gst::FlowError> {
        match compute {
            Some(Compute::Here(pairs)) => pairs
                .pair(out_info, prev, next)
                .map(Computed::Done)
                .map_err(|f| self.fail(&f)),
            Some(Compute::Workers(workers, recipe)) => Ok(Computed::Queued(workers.submit(
                recipe,
                Arc::clone(prev),
                Arc::clone(next),
                self.outbox(),
            ))),
            None => Err(gst::FlowError::NotNegotiated),
        }
    }

    /// Stamp `outputs` and queue them: for the streaming thread to push
    /// when computed here, in the outbox when on the workers.
    fn queue(
        &self,
        state: &mut State,
        outputs: Vec<Output<Computed, Stamps>>,
    ) -> Result<(), gst::FlowError> {
        for output in outputs {
            match output {
                Output::Black { label, .. } => {
                    let size = state
                        .out_info
                        .as_ref()
                        .ok_or(gst::FlowError::NotNegotiated)?
                        .size();
                    let mut image =
                        gst::Buffer::with_size(size).map_err(|_| gst::FlowError::Error)?;
                    image
                        .get_mut()
                        .expect("a new buffer is writable")
                        .map_writable()
                        .map_err(|_| gst::FlowError::Error)?
                        .fill(0);
                    let output = PairOutput { image, cues: None };
                    self.queue_done(state, output, &[label]);
                }
                Output::Result {
                    result: Computed::Done(output),
                    labels,
                } => self.queue_done(state, output, &labels),
                Output::Result {
                    result: Computed::Queued(slot),
                    labels,
                } => {
                    let discont = std::mem::take(&mut state.discont);
                    self.outbox().add(Item::Pair {
                        slot,
                        labels,
                        discont,
                    });
                }
            }
        }
        Ok(())
    }

    /// An output made here, stamped, once per label.
    fn queue_done(&self, state: &mut State, output: PairOutput, labels: &[Stamps]) {
        let mut discont = std::mem::take(&mut state.discont);
        for buffer in outputs_of(&self.obj(), output, labels, &mut discont) {
            self.queue_ready(state, Ready::Buffer(buffer));
        }
    }

    /// An output made here, in its place: after the workers' ones when
    /// they compute the pairs.
    fn queue_ready(&self, state: &mut State, ready: Ready) {
        match state.workers() {
            Some(_) => self.outbox().add(Item::Ready(ready)),
            None => state.pending.push_back(ready),
        }
    }
}

impl State {
    /// The workers' threads, when they compute the pairs.
    fn workers(&self) -> Option<usize> {
        match &self.compute {
            Some(Compute::Workers(workers, _)) => Some(workers.threads()),
            _ => None,
        }
    }
}

//! `import reynoldsflow`: the host crate's computation behind a NumPy API.
//!
//! Thin by design: every result comes from the host's `PairEngine` (what
//! `reynoldsflow pair`, `run` and `dataset` compute), paired by its
//! `PairStream` for `Stream`, or from `dataset::convert` (what `dataset`
//! does per item), so the bytes are the command line's. This crate only turns arrays into frames and back,
//! checks arguments (`TypeError` for a wrong type, dtype or number of
//! dimensions, `ValueError` for a wrong shape or value), releases the GIL
//! while computing, and turns any panic into a `RuntimeError`.

use std::ops::ControlFlow;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use numpy::ndarray::Axis;
use numpy::{Element, PyArray1, PyArrayDyn, PyArrayMethods, PyUntypedArray};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use reynoldsflow_host::dataset::{self, Record, Shard};
use reynoldsflow_host::driver::{self, Work};
use reynoldsflow_host::engine::PairEngine;
use reynoldsflow_host::limits::{DEFAULT_MAX_PIXELS, Limits};
use reynoldsflow_host::outputs::flo;
use reynoldsflow_host::pair_stream::{self, PairStream};
use reynoldsflow_host::sequence::sampled::{self, FramePlan};
use reynoldsflow_host::sequence::{Frame, FrameSource};
use reynoldsflow_host::settings::{FirstFrame, Setting};
use reynoldsflow_host::{Gray, HostError, io::atomic};

mod errors;
mod frames;
mod settings;

use errors::{Failure, guarded, host_error, value_error};
use frames::{Frames, Output, gray};
use settings::{CallSettings, Kwargs, Layout};

/// A pair engine (the host's, on one thread or, for a `Stream`, on its
/// `threads`: its memory kept from pair to pair), and the interleaved image
/// a channels-first result is split from.
struct PairWorker {
    engine: PairEngine,
    rgb: Vec<u8>,
}

impl PairWorker {
    /// A worker of `settings`, on `threads` threads.
    fn new(settings: &CallSettings, threads: usize) -> Result<Self, HostError> {
        Ok(Self {
            engine: settings.pair_engine(threads)?,
            rgb: Vec::new(),
        })
    }

    /// The worker in `slot`, made there on first use.
    fn of<'a>(
        slot: &'a mut Option<Self>,
        settings: &CallSettings,
    ) -> Result<&'a mut Self, HostError> {
        if slot.is_none() {
            *slot = Some(Self::new(settings, 1)?);
        }
        Ok(slot.as_mut().expect("made above"))
    }

    /// The image of one pair written into `out` (its `3·H·W` bytes) in
    /// `layout`; the pair's motion score when `score` is asked (which
    /// needs the fields), else 0. Without the fields, an (H, W, 3) image
    /// is written straight into `out`, a channels-first one split into it
    /// from the worker's reused buffer.
    fn pair_into(
        &mut self,
        (prev, next): (&Gray, &Gray),
        layout: Layout,
        score: bool,
        out: &mut [u8],
    ) -> Result<f64, HostError> {
        if score {
            let fields = self.engine.fields(prev, next)?;
            layout.place(&self.engine.image_of(&fields), out);
            return Ok(fields.planes.mean_speed());
        }
        match layout {
            Layout::Hwc => self.engine.image(prev, next, out)?,
            Layout::Chw => {
                self.rgb.resize(out.len(), 0);
                self.engine.image(prev, next, &mut self.rgb)?;
                layout.place(&self.rgb, out);
            }
        }
        Ok(0.0)
    }

    /// The image of one pair in `layout`, in a new buffer.
    fn image_vec(&mut self, pair: (&Gray, &Gray), layout: Layout) -> Result<Vec<u8>, HostError> {
        let mut image = vec![0; 3 * pair.0.pixels.len()];
        self.pair_into(pair, layout, false, &mut image)?;
        Ok(image)
    }
}

/// An array of `shape` owning `data` (no copy).
fn array<'py, T: Element>(
    py: Python<'py>,
    data: Vec<T>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyArrayDyn<T>>> {
    PyArray1::from_vec(py, data).reshape(shape)
}

/// Two frames checked as a pair: same size.
fn pair_frames<'py>(
    prev: &Bound<'py, PyAny>,
    next: &Bound<'py, PyAny>,
) -> PyResult<(Frames<'py>, Frames<'py>)> {
    let (p, n) = (Frames::single(prev, "prev")?, Frames::single(next, "next")?);
    if p.frame_shape() != n.frame_shape() {
        return Err(value_error(format!(
            "prev and next differ in shape: {:?} and {:?} (a pair is two frames of one size)",
            p.frame_shape(),
            n.frame_shape()
        )));
    }
    Ok((p, n))
}

/// `work` on the pair `(prev, next)` with a one-thread worker of
/// `settings`, without the GIL.
fn on_pair<T: Send>(
    py: Python<'_>,
    settings: &CallSettings,
    (prev, next): (&Frames<'_>, &Frames<'_>),
    work: impl FnOnce(&mut PairWorker, &Gray, &Gray) -> Result<T, HostError> + Send,
) -> PyResult<T> {
    let mut worker = PairWorker::new(settings, 1).map_err(host_error)?;
    let (pv, nv) = (prev.view(), next.view());
    py.detach(|| guarded(|| work(&mut worker, &gray(pv)?, &gray(nv)?)))
        .map_err(Failure::into_pyerr)
}

/// represent(prev, next, *, engine="fixed", scale="minmax",
/// intensity_scale=1/255, lam=1e-4, tile=None, variant="dc", hsv_max=None)
///
/// The ReynoldsFlow representation of a frame pair: an (H, W, 3) uint8
/// image [|v_d|, |v_c|, prev] (variant "dc"), byte for byte what
/// `reynoldsflow pair` writes to rep.png. Frames are (H, W) or (H, W, 1)
/// uint8 arrays of any strides.
#[pyfunction]
#[pyo3(signature = (prev, next, **options))]
fn represent<'py>(
    py: Python<'py>,
    prev: &Bound<'py, PyAny>,
    next: &Bound<'py, PyAny>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyArrayDyn<u8>>> {
    let settings =
        CallSettings::parse(Kwargs::new(py, "represent", options, settings::IMAGE_KEYS)?)?;
    let (p, n) = pair_frames(prev, next)?;
    let (h, w) = p.frame_shape();
    let layout = settings.layout();
    let image = on_pair(py, &settings, (&p, &n), |worker, prev, next| {
        worker.image_vec((prev, next), layout)
    })?;
    array(py, image, &layout.shape(None, h, w))
}

/// fields(prev, next, *, engine="fixed", intensity_scale=1/255, lam=1e-4,
/// tile=None) -> {"v_c", "v_d", "v_R"}
///
/// The curl-free field v_c, the divergence-free field v_d and their sum
/// v_R as float32 (H, W, 2) arrays, last axis (x, y) in pixels (x right,
/// y down), like OpenCV's flow. With engine="fixed", v_c and v_d are the
/// core's float32 values exactly; v_R is their float64 sum, rounded once.
#[pyfunction]
#[pyo3(signature = (prev, next, **options))]
fn fields<'py>(
    py: Python<'py>,
    prev: &Bound<'py, PyAny>,
    next: &Bound<'py, PyAny>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let settings = CallSettings::parse(Kwargs::new(py, "fields", options, &[])?)?;
    let (p, n) = pair_frames(prev, next)?;
    let (h, w) = p.frame_shape();
    let planes = on_pair(py, &settings, (&p, &n), |worker, prev, next| {
        Ok(worker.engine.fields(prev, next)?.planes)
    })?;
    let out = PyDict::new(py);
    let v_r = planes.v_r();
    for (name, field) in [("v_c", &planes.v_c), ("v_d", &planes.v_d), ("v_R", &v_r)] {
        // Exact for the core's v_c and v_d (f32 values in f64 planes).
        let xy: Vec<f32> = field
            .u
            .iter()
            .zip(&field.v)
            .flat_map(|(x, y)| [*x as f32, *y as f32])
            .collect();
        out.set_item(name, array(py, xy, &[h, w, 2])?)?;
    }
    Ok(out)
}

/// motion_score(prev, next, *, engine="fixed", intensity_scale=1/255,
/// lam=1e-4, tile=None) -> float
///
/// How much a pair moves: the mean over all pixels of |v_R| = |v_c + v_d|,
/// in pixels per frame (0.0 for identical frames). Rank or threshold clips
/// by it to drop static ones; represent_clip(..., return_scores=True) gives
/// it for every pair of a clip.
#[pyfunction]
#[pyo3(signature = (prev, next, **options))]
fn motion_score<'py>(
    py: Python<'py>,
    prev: &Bound<'py, PyAny>,
    next: &Bound<'py, PyAny>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<f64> {
    let settings = CallSettings::parse(Kwargs::new(py, "motion_score", options, &[])?)?;
    let (p, n) = pair_frames(prev, next)?;
    on_pair(py, &settings, (&p, &n), |worker, prev, next| {
        Ok(worker.engine.fields(prev, next)?.planes.mean_speed())
    })
}

/// represent_clip(frames, *, keep_count=False, threads=None,
/// return_scores=False, step=None, fps=None, source_fps=None, resize=None,
/// short_side=None, layout="hwc", out=None, engine="fixed", scale="minmax", ...)
///
/// Every consecutive pair of a (T, H, W) or (T, H, W, 1) uint8 clip: a
/// (T - 1, H, W, 3) array whose image i is represent(frames[i],
/// frames[i + 1]); with keep_count=True, (T, H, W, 3), the last image
/// repeated so every frame has one. Pairs are computed on `threads` workers
/// (default: every core); the bytes do not depend on it. With
/// return_scores=True, returns (images, scores): scores[i] is
/// motion_score(frames[i], frames[i + 1]), float64 of shape (T - 1,).
///
/// step=K takes frames 0, K, 2K, ... (pairs (0, K), (K, 2K), ...); fps=F
/// takes F frames per second of the clip's rate source_fps (frame
/// floor(k * source_fps / F)); resize=(W, H) or short_side=N resizes the
/// frames taken first, as `reynoldsflow run --step/--fps/--resize/
/// --short-side` do. layout="chw" returns (T - 1, 3, H, W).
///
/// out= a writable, C-contiguous uint8 array (or CPU tensor) of the
/// result's shape: the images are written into it, each pair's straight
/// into its place, and it is returned instead of a new array (a DataLoader
/// worker writes a clip into memory the main process maps this way, so
/// nothing is copied on the way there).
#[pyfunction]
#[pyo3(signature = (frames, **options))]
fn represent_clip<'py>(
    py: Python<'py>,
    frames: &Bound<'py, PyAny>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Py<PyAny>> {
    let mut kw = Kwargs::new(
        py,
        "represent_clip",
        options,
        &[
            settings::IMAGE_KEYS,
            settings::FRAME_KEYS,
            &[
                "keep_count",
                "threads",
                "return_scores",
                "source_fps",
                "out",
            ],
        ]
        .concat(),
    )?;
    let keep_count = kw.flag("keep_count")?;
    let return_scores = kw.flag("return_scores")?;
    let threads = kw.threads()?;
    let plan = kw.frame_plan()?;
    let source_fps = kw.rate("source_fps")?;
    let out = kw.object("out")?;
    let settings = CallSettings::parse(kw)?;
    let layout = settings.layout();
    let clip = Frames::clip(frames, "frames")?;
    let (t, (h, w)) = (clip.count(), clip.frame_shape());
    if t < 2 {
        return Err(value_error(format!(
            "frames holds {t} frame(s); a result needs a pair, so at least 2 (shape (T, H, W), T >= 2)"
        )));
    }
    if matches!(plan.sampling, sampled::Sampling::Fps(_)) && source_fps.is_none() {
        return Err(value_error(
            "represent_clip(): fps needs source_fps, the clip's own frame rate (an array states none)",
        ));
    }
    let picked = plan
        .picker(source_fps.map(|r| (r.num, r.den)), "frames")
        .map_err(host_error)?
        .indices(t);
    if picked.len() < 2 {
        return Err(value_error(format!(
            "frames: step or fps takes {} of its {t} frames; a result needs a pair, so at least 2",
            picked.len()
        )));
    }
    let (w, h) = plan.size.map_or((w, h), |size| size.of(w, h));
    // The frames taken, resized, are held too: the same limit.
    frame_limits()
        .check_frame_size(w, h)
        .map_err(|too_large| host_error(too_large.about("resize")))?;
    let results = picked.len() - 1;
    let count = results + usize::from(keep_count);
    let mut output = Output::new(py, out, &layout.shape(Some(count), h, w))?;
    let view = clip.view();
    let rgb = output.bytes();
    let scores = py
        .detach(|| {
            let grays = guarded(|| {
                picked
                    .iter()
                    .map(|&i| sized(gray(view.index_axis(Axis(0), i))?, &plan))
                    .collect::<Result<Vec<Gray>, HostError>>()
            })?;
            let frame_bytes = 3 * h * w;
            let (images, kept) = rgb.split_at_mut(results * frame_bytes);
            let pairs = ClipPairs {
                settings: &settings,
                grays: &grays,
                layout,
                score: return_scores,
                slots: images
                    .chunks_exact_mut(frame_bytes)
                    .map(Mutex::new)
                    .collect(),
            };
            let mut scores = Vec::with_capacity(results);
            driver::in_order(
                &pairs,
                threads.min(results),
                |feed| {
                    (0..results).all(|i| feed.send(i));
                    Ok(())
                },
                |score| {
                    scores.push(score);
                    Ok(ControlFlow::Continue(()))
                },
            )?;
            drop(pairs);
            if keep_count {
                kept.copy_from_slice(&images[(results - 1) * frame_bytes..]);
            }
            Ok(scores)
        })
        .map_err(Failure::into_pyerr)?;
    let images = output.object;
    if return_scores {
        let scores = PyArray1::from_vec(py, scores);
        Ok((images, scores).into_pyobject(py)?.into_any().unbind())
    } else {
        Ok(images.unbind())
    }
}

/// `frame` at the plan's size (itself when it has none).
fn sized(frame: Gray, plan: &FramePlan) -> Result<Gray, HostError> {
    match plan.size {
        Some(size) if size.of(frame.width, frame.height) != frame.size() => {
            let mut out = Gray {
                width: 0,
                height: 0,
                pixels: Vec::new(),
            };
            sampled::resize_gray(&frame, size, frame_limits(), &mut out)?;
            Ok(out)
        }
        _ => Ok(frame),
    }
}

/// `represent_clip`'s pairs: pair `i` is frames `i` and `i + 1`, its
/// image written into `slots[i]` (taken by the one worker that computes
/// it), its motion score the output.
struct ClipPairs<'a> {
    settings: &'a CallSettings,
    grays: &'a [Gray],
    layout: Layout,
    score: bool,
    slots: Vec<Mutex<&'a mut [u8]>>,
}

impl Work for ClipPairs<'_> {
    type Job = usize;
    type Output = f64;
    type Error = Failure;
    /// Made on the worker's first pair.
    type State = Option<PairWorker>;

    fn state(&self) -> Option<PairWorker> {
        None
    }

    fn compute(&self, worker: &mut Option<PairWorker>, &i: &usize) -> Result<f64, Failure> {
        let worker = PairWorker::of(worker, self.settings).map_err(Failure::Host)?;
        let pair = (&self.grays[i], &self.grays[i + 1]);
        let mut slot = self.slots[i].lock().expect("one thread takes each pair");
        worker
            .pair_into(pair, self.layout, self.score, &mut slot)
            .map_err(Failure::Host)
    }

    fn panicked(&self, _: &usize, payload: Box<dyn std::any::Any + Send>) -> Failure {
        Failure::Panic(reynoldsflow_host::panic_message(payload.as_ref()))
    }
}

/// Stream(width, height, *, first_frame="drop", threads=None,
/// engine="fixed", scale="minmax", ...)
///
/// Frames pushed one at a time (a camera, a decoder), paired as the
/// GStreamer element and the ROS 2 node pair them: each frame with the one
/// before, every result the same bytes as represent(previous, this).
/// Frames are (height, width) or (height, width, 1) uint8 arrays.
///
/// first_frame says what the first frame (which has no pair of its own)
/// gives: "drop" (the default) nothing, so N frames give N - 1 images;
/// "black" an all-zero image; "repeat" a copy of the first pair's image,
/// given with it at the second frame (a stream of one frame gives, at
/// end(), that frame paired with itself). push() returns at most one image
/// per frame, so "repeat" takes feed() and end(), which return lists.
/// Each pair is computed on `threads` threads (default every core; the
/// bytes do not depend on it).
///
/// A Stream holds its previous frame: use each one from one thread at a
/// time (one per camera); a call from a second thread while another runs
/// raises RuntimeError ("Already borrowed"). A frame that another thread
/// changes during a call (which releases the GIL) gives undefined bytes.
#[pyclass(module = "reynoldsflow")]
struct Stream {
    width: usize,
    height: usize,
    layout: Layout,
    /// The pairing, then the engine.
    pairs: PairStream<()>,
    worker: PairWorker,
}

impl Stream {
    /// `work` on the pair stream, the worker and `frame`'s luma, without
    /// the GIL; `frame` checked first (the stream's shape).
    fn take<'py, T: Send>(
        &mut self,
        py: Python<'py>,
        frame: &Bound<'py, PyAny>,
        work: impl FnOnce(&mut PairStream<()>, &mut PairWorker, Gray) -> Result<T, HostError> + Send,
    ) -> PyResult<T> {
        let f = Frames::single(frame, "frame")?;
        if f.frame_shape() != (self.height, self.width) {
            return Err(value_error(format!(
                "frame has shape {:?}; this Stream takes (height, width) = ({}, {})",
                f.frame_shape(),
                self.height,
                self.width
            )));
        }
        let view = f.view();
        let (pairs, worker) = (&mut self.pairs, &mut self.worker);
        py.detach(|| guarded(|| work(pairs, worker, gray(view)?)))
            .map_err(Failure::into_pyerr)
    }

    /// The images of `outputs`, in order, as arrays.
    fn arrays<'py>(
        &self,
        py: Python<'py>,
        outputs: impl IntoIterator<Item = pair_stream::Output<Vec<u8>, ()>>,
    ) -> PyResult<Vec<Bound<'py, PyArrayDyn<u8>>>> {
        let shape = self.layout.shape(None, self.height, self.width);
        let mut arrays = Vec::new();
        for output in outputs {
            match output {
                pair_stream::Output::Black { width, height, .. } => {
                    arrays.push(array(py, vec![0; 3 * width * height], &shape)?);
                }
                pair_stream::Output::Result { result, labels } => {
                    for _ in 1..labels.len() {
                        arrays.push(array(py, result.clone(), &shape)?);
                    }
                    arrays.push(array(py, result, &shape)?);
                }
            }
        }
        Ok(arrays)
    }

    /// The computation the pair stream calls: the image of `(prev, next)`
    /// in a new buffer.
    fn image(
        worker: &mut PairWorker,
        layout: Layout,
    ) -> impl FnMut(&Gray, &Gray) -> Result<Vec<u8>, HostError> {
        move |prev, next| worker.image_vec((prev, next), layout)
    }
}

/// `Stream`'s `width` or `height` (`name`): an integer (anything with
/// `__index__`) of at least 1, or the `TypeError` / `ValueError` naming it.
fn stream_side(value: &Bound<'_, PyAny>, name: &str) -> PyResult<usize> {
    let type_name = || {
        value
            .get_type()
            .name()
            .map_or_else(|_| "?".to_owned(), |n| n.to_string())
    };
    let Ok(index) = value.call_method0("__index__") else {
        return Err(PyTypeError::new_err(format!(
            "Stream: {name}: {} {}; expected an integer number of pixels",
            type_name(),
            value
                .repr()
                .map_or_else(|_| "?".to_owned(), |r| r.to_string())
        )));
    };
    if index.lt(1)? {
        return Err(value_error(format!(
            "Stream: {name} = {index}; expected at least 1 pixel"
        )));
    }
    index.extract::<usize>().map_err(|_| {
        value_error(format!(
            "Stream: {name} = {index}; a side is at most {} pixels",
            reynoldsflow_core::MAX_SIDE
        ))
    })
}

/// A frame as the pair stream takes it: no stamp, no label.
fn stream_frame(gray: Gray) -> pair_stream::Frame<()> {
    pair_stream::Frame {
        gray,
        encoding: "GRAY8",
        stamp: None,
        label: (),
    }
}

#[pymethods]
impl Stream {
    #[new]
    #[pyo3(signature = (width, height, **options))]
    fn new(
        py: Python<'_>,
        width: &Bound<'_, PyAny>,
        height: &Bound<'_, PyAny>,
        options: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let (width, height) = (stream_side(width, "width")?, stream_side(height, "height")?);
        let keys = [settings::IMAGE_KEYS, &["first_frame", "threads"]].concat();
        let mut kw = Kwargs::new(py, "Stream", options, &keys)?;
        let first_frame = kw.first_frame()?;
        let threads = kw.threads()?;
        let settings = CallSettings::parse(kw)?;
        // Refused when made, not at the first push: a side the core cannot
        // hold, or more pixels than a frame may have.
        if width > reynoldsflow_core::MAX_SIDE || height > reynoldsflow_core::MAX_SIDE {
            return Err(value_error(format!(
                "Stream: {width}x{height}: a side exceeds {} pixels, the engine's largest",
                reynoldsflow_core::MAX_SIDE
            )));
        }
        frame_limits()
            .check_frame_size(width, height)
            .map_err(|too_large| host_error(too_large.about("Stream")))?;
        Ok(Self {
            width,
            height,
            layout: settings.layout(),
            pairs: PairStream::new(first_frame),
            worker: PairWorker::new(&settings, threads).map_err(host_error)?,
        })
    }

    /// push(frame, *, out=None) -> None | uint8 image (the layout's shape)
    ///
    /// This frame's image: the representation of (previous frame, frame),
    /// or for a first frame (since the start, end() or reset()) None, or
    /// with first_frame="black" an all-zero image. With out (a writable,
    /// C-contiguous uint8 array of the result's shape), the image is
    /// written into it and out returned (untouched when None is
    /// returned). first_frame="repeat" gives two images at the second
    /// frame: use feed().
    #[pyo3(signature = (frame, *, out=None))]
    fn push<'py>(
        &mut self,
        py: Python<'py>,
        frame: &Bound<'py, PyAny>,
        out: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Option<Bound<'py, PyAny>>> {
        if self.pairs.first_frame() == FirstFrame::Repeat {
            return Err(value_error(
                "Stream.push: first_frame=\"repeat\" gives two images at the second frame (the first frame's copy and its own); use feed(frame) and end(), which return lists",
            ));
        }
        // Checked even for a first frame, which writes nothing: a wrong
        // out fails at once, not one frame later.
        let mut output = Output::new(py, out, &self.layout.shape(None, self.height, self.width))?;
        let rgb = output.bytes();
        let layout = self.layout;
        let written = self.take(py, frame, |pairs, worker, gray| {
            let step = pairs.push(stream_frame(gray), |prev, next| {
                worker.pair_into((prev, next), layout, false, rgb)
            })?;
            // One output at most: none or the pair's image (drop), zeros
            // for a first frame (black).
            Ok(match step.outputs.into_iter().next() {
                None => false,
                Some(pair_stream::Output::Black { .. }) => {
                    rgb.fill(0);
                    true
                }
                Some(pair_stream::Output::Result { .. }) => true,
            })
        })?;
        Ok(written.then_some(output.object))
    }

    /// feed(frame) -> list of uint8 images (the layout's shape)
    ///
    /// Every image this frame gives, in order: none or one, and with
    /// first_frame="repeat" two at the second frame (the first frame's
    /// copy of the first pair's image, then its own).
    fn feed<'py>(
        &mut self,
        py: Python<'py>,
        frame: &Bound<'py, PyAny>,
    ) -> PyResult<Vec<Bound<'py, PyArrayDyn<u8>>>> {
        let layout = self.layout;
        let outputs = self.take(py, frame, |pairs, worker, gray| {
            Ok(pairs
                .push(stream_frame(gray), Self::image(worker, layout))?
                .outputs)
        })?;
        self.arrays(py, outputs)
    }

    /// end() -> list of uint8 images (the layout's shape)
    ///
    /// The stream ends here (the end of the input, a gap): the images its
    /// frames still owe (with first_frame="repeat", a lone first frame
    /// paired with itself), and the next frame is a first frame.
    fn end<'py>(&mut self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyArrayDyn<u8>>>> {
        let (pairs, worker, layout) = (&mut self.pairs, &mut self.worker, self.layout);
        let owed = py
            .detach(|| guarded(|| pairs.end(Self::image(worker, layout))))
            .map_err(Failure::into_pyerr)?;
        self.arrays(py, owed)
    }

    /// Forget the previous frame without an image: the next frame is a
    /// first frame.
    fn reset(&mut self) {
        self.pairs.reset();
    }

    /// Frame width in pixels.
    #[getter]
    fn width(&self) -> usize {
        self.width
    }

    /// Frame height in pixels.
    #[getter]
    fn height(&self) -> usize {
        self.height
    }

    /// What the first frame gives: "drop", "black" or "repeat".
    #[getter]
    fn first_frame(&self) -> &'static str {
        self.pairs.first_frame().name()
    }
}

/// The status record as a dict.
fn record_dict<'py>(py: Python<'py>, r: &Record) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("path", &r.path)?;
    d.set_item("output", &r.output)?;
    d.set_item("status", r.status.name())?;
    d.set_item("frames", r.frames)?;
    d.set_item("outputs", r.outputs)?;
    d.set_item("seconds", r.seconds)?;
    d.set_item("error", &r.error)?;
    if let Some(used) = &r.source_frames {
        d.set_item("source_frames", used.clone())?;
    }
    Ok(d)
}

/// convert(src, dst, *, rep=True, viz=False, hsv_max=None, npy=None,
/// npy_dtype=None, flo=None, image_format=None, jpeg_quality=None,
/// keep_count=False, max_frames=None, step=None, fps=None, resize=None,
/// short_side=None, threads=None, force=False, engine="fixed",
/// scale="minmax", intensity_scale=1/255, lam=1e-4, tile=None,
/// variant="dc") -> dict
///
/// One video or frame folder `src` into the folder `dst`, exactly as
/// `reynoldsflow dataset` makes each item: the same files, and the marker
/// .reynoldsflow-done written last, so a finished item is skipped when run
/// again with the same options on the same source with all its files
/// there (force=True redoes it). Returns the status
/// record {"path", "output", "status", "frames", "outputs", "seconds",
/// "error"}, status one of "done", "skipped", "failed"; an input that
/// cannot be read is a "failed" record (with the reason in "error"), a bad
/// option raises. npy_dtype, image_format, jpeg_quality, jpeg_subsampling,
/// png_compression, step, fps, resize and short_side are the command
/// line's flags of the same names
/// (npy_dtype="f16", image_format="jpg", step=2, fps=10, resize=(W, H),
/// short_side=N); with step or fps the record also has "source_frames",
/// the input index of every frame used.
#[pyfunction]
#[pyo3(signature = (src, dst, **options))]
fn convert<'py>(
    py: Python<'py>,
    src: std::path::PathBuf,
    dst: std::path::PathBuf,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let kw = Kwargs::new(py, "convert", options, settings::CONVERT_KEYS)?;
    let (item, force) = settings::convert_settings(kw)?;
    let record = py
        .detach(|| guarded(|| dataset::convert(&src, &dst, &item, force)))
        .map_err(Failure::into_pyerr)?;
    record_dict(py, &record)
}

/// dataset_items(src, *, files_from=None, dst=None, shard=None) -> list[tuple[str, str]]
///
/// The items `reynoldsflow dataset SRC DST` would make, in its order: (the
/// video or frame folder, its output folder relative to DST). With
/// files_from, those of that manifest (one path relative to src per line),
/// or of that list of paths (each relative to src, or absolute inside it);
/// with dst inside src, dst is not searched. With shard=(i, n), only those
/// `reynoldsflow dataset --shard i/n` takes (the same hash of each item's
/// path relative to src, computed by the same code). An item that
/// `reynoldsflow dataset` would refuse (its output folder another's, or in
/// another's side-output folder `hsv/`, `v_c/`, `v_d/`, `v_R/`) raises
/// ValueError naming it.
#[pyfunction]
#[pyo3(signature = (src, *, files_from=None, dst=None, shard=None))]
fn dataset_items(
    py: Python<'_>,
    src: std::path::PathBuf,
    files_from: Option<&Bound<'_, PyAny>>,
    dst: Option<std::path::PathBuf>,
    shard: Option<(u64, u64)>,
) -> PyResult<Vec<(String, String)>> {
    let shard = match shard {
        None => Shard::ALL,
        Some((index, count)) => Shard::new(index, count).map_err(|e| {
            value_error(format!("dataset_items(): shard = ({index}, {count}): {e}"))
        })?,
    };
    let files_from = files_from.map(FilesFrom::extract).transpose()?;
    let items = py
        .detach(|| {
            guarded(|| match &files_from {
                Some(FilesFrom::Manifest(list)) => dataset::manifest(&src, list),
                Some(FilesFrom::Paths(paths)) => dataset::listed(
                    &src,
                    std::path::Path::new("files_from"),
                    paths
                        .iter()
                        .enumerate()
                        .map(|(n, p)| (format!("item {n}"), p.as_path())),
                ),
                None => {
                    let skip = dst.as_deref().and_then(|d| std::fs::canonicalize(d).ok());
                    dataset::discover(&src, skip.as_deref())
                }
            })
        })
        .map_err(Failure::into_pyerr)?;
    let dst_shown = dst.unwrap_or_else(|| "DST".into());
    let mut taken = Vec::new();
    for (item, clash) in items.iter().zip(dataset::clashes(&items, &dst_shown, true)) {
        if !shard.contains(&dataset::shard_key(&src, item)) {
            continue;
        }
        if let Some(reason) = clash {
            return Err(value_error(format!(
                "dataset_items(): {}: {reason}",
                item.src.display()
            )));
        }
        taken.push((
            item.src.display().to_string(),
            item.rel.display().to_string(),
        ));
    }
    Ok(taken)
}

/// `files_from=`: a manifest's path, or the paths themselves.
enum FilesFrom {
    Manifest(std::path::PathBuf),
    Paths(Vec<std::path::PathBuf>),
}

impl FilesFrom {
    fn extract(value: &Bound<'_, PyAny>) -> PyResult<Self> {
        if let Ok(path) = value.extract() {
            return Ok(Self::Manifest(path));
        }
        value.extract().map(Self::Paths).map_err(|_| {
            PyTypeError::new_err(format!(
                "dataset_items(): files_from must be a manifest's path or a list of paths, not {}",
                value
                    .get_type()
                    .name()
                    .map_or_else(|_| "?".into(), |n| n.to_string())
            ))
        })
    }
}

/// read_frames(path, *, step=None, fps=None, resize=None, short_side=None,
/// max_frames=None) -> FrameReader
///
/// The frames of a video (Y4M, or anything ffmpeg decodes) or frame
/// folder, read one at a time as `reynoldsflow dataset` reads an item, with
/// `--step`/`--fps`/`--resize`/`--short-side` applied: an iterator of
/// (index, frame), index the frame's position in the input and frame an
/// (H, W) uint8 array. max_frames counts the frames taken.
#[pyfunction]
#[pyo3(signature = (path, **options))]
fn read_frames(
    py: Python<'_>,
    path: std::path::PathBuf,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<FrameReader> {
    let mut kw = Kwargs::new(
        py,
        "read_frames",
        options,
        &[settings::FRAME_KEYS, &["max_frames"]].concat(),
    )?;
    let plan = kw.frame_plan()?;
    let max_frames = kw.max_frames()?;
    kw.done()?;
    let source = py
        .detach(|| guarded(|| dataset::open_item(&path, path.is_dir(), &plan, frame_limits())))
        .map_err(Failure::into_pyerr)?;
    Ok(FrameReader {
        source: Mutex::new(Some(source)),
        left: max_frames,
    })
}

/// The frames of one video or frame folder (read_frames).
#[pyclass(module = "reynoldsflow")]
struct FrameReader {
    /// `None` once the input has ended (or failed).
    source: Mutex<Option<Box<dyn FrameSource>>>,
    /// Frames still to give, with max_frames.
    left: Option<u64>,
}

#[pymethods]
impl FrameReader {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__<'py>(
        &mut self,
        py: Python<'py>,
    ) -> PyResult<Option<(usize, Bound<'py, PyArrayDyn<u8>>)>> {
        if self.left == Some(0) {
            *self.source.lock().expect("no panic holding it") = None;
            return Ok(None);
        }
        let source = &self.source;
        let frame = py
            .detach(|| {
                guarded(|| {
                    let mut source = source.lock().expect("no panic holding it");
                    let Some(frames) = source.as_mut() else {
                        return Ok(None);
                    };
                    let next: Result<Option<Frame>, HostError> = frames.next_frame();
                    if !matches!(next, Ok(Some(_))) {
                        *source = None;
                    }
                    next
                })
            })
            .map_err(Failure::into_pyerr)?;
        let Some(frame) = frame else {
            return Ok(None);
        };
        if let Some(left) = &mut self.left {
            *left -= 1;
        }
        let (w, h) = frame.gray.size();
        Ok(Some((frame.index, array(py, frame.gray.pixels, &[h, w])?)))
    }

    /// The frame rate of the frames given `(num, den)` per second, when
    /// the input states one (None once it has ended).
    #[getter]
    fn frame_rate(&self) -> Option<(u32, u32)> {
        self.source
            .lock()
            .expect("no panic holding it")
            .as_ref()
            .and_then(|s| s.frame_rate())
    }
}

/// _as_ndarray(obj) -> numpy.ndarray
///
/// The array view every function reads `obj` through: itself for an
/// ndarray, a view of the same memory for an object with __dlpack__ or the
/// array interface (for tests of the no-copy path).
#[pyfunction]
fn _as_ndarray<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyUntypedArray>> {
    frames::ndarray(obj, "obj")
}

/// read_flo(path) -> (H, W, 2) float32
///
/// A Middlebury .flo file as an array, last axis (u, v) = (x, y).
#[pyfunction]
fn read_flo<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
    let flo = py
        .detach(|| {
            guarded(|| {
                let bytes = std::fs::read(&path).map_err(|e| HostError::io(&path, e))?;
                flo::decode(&bytes)
                    .map_err(|why| HostError::invalid(path.display().to_string(), why))
            })
        })
        .map_err(Failure::into_pyerr)?;
    let uv: Vec<f32> = flo
        .u
        .iter()
        .zip(&flo.v)
        .flat_map(|(u, v)| [*u as f32, *v as f32])
        .collect();
    array(py, uv, &[flo.height, flo.width, 2])
}

/// write_flo(path, flow)
///
/// Write an (H, W, 2) float32 or float64 array (last axis (x, y)) as a
/// Middlebury .flo file (float32), atomically: the file appears complete or
/// not at all.
#[pyfunction]
fn write_flo(py: Python<'_>, path: std::path::PathBuf, flow: &Bound<'_, PyAny>) -> PyResult<()> {
    let (h, w, u, v) = frames::flow_planes(flow)?;
    py.detach(|| {
        guarded(|| {
            let bytes = flo::encode(w, h, &u, &v)?;
            atomic::write_file(&path, &bytes)
        })
    })
    .map_err(Failure::into_pyerr)
}

/// The frame-size limit of this process's Python users, as
/// `set_max_pixels` sets it; each entry point passes it to the host.
static MAX_PIXELS: AtomicU64 = AtomicU64::new(DEFAULT_MAX_PIXELS);

/// The limits every entry point reads and checks frames within.
pub(crate) fn frame_limits() -> Limits {
    Limits::new(MAX_PIXELS.load(Ordering::Relaxed))
}

/// set_max_pixels(n)
///
/// The most pixels (width x height) a frame of this process may have, at
/// least 1 (``ValueError`` otherwise); default 8192 x 8192. Every entry
/// point (the readers of image files, Y4M, raw and video, ``represent``,
/// ``fields``, ``motion_score``, ``represent_clip``, ``Stream``,
/// ``represent_batch``) refuses a larger frame with the same ``ValueError``
/// before allocating it, as the command line's ``--max-pixels``.
#[pyfunction]
fn set_max_pixels(n: i64) -> PyResult<()> {
    let n = u64::try_from(n).ok().filter(|&n| n >= 1).ok_or_else(|| {
        host_error(HostError::setting(
            Setting::MaxPixels,
            format!("{n} pixels; the limit is at least 1"),
        ))
    })?;
    MAX_PIXELS.store(n, Ordering::Relaxed);
    Ok(())
}

/// _check_frame_size(width, height, subject)
///
/// The ``ValueError`` every entry point gives for a frame of
/// ``width x height`` over the ``set_max_pixels`` limit, about ``subject``
/// (for the package's functions written in Python).
#[pyfunction]
fn _check_frame_size(width: usize, height: usize, subject: &str) -> PyResult<()> {
    frame_limits()
        .check_frame_size(width, height)
        .map_err(|too_large| host_error(too_large.about(subject)))
}

/// max_pixels() -> int
///
/// The limit ``set_max_pixels`` sets.
#[pyfunction]
fn max_pixels() -> u64 {
    frame_limits().max_pixels()
}

/// ReynoldsFlow: curl-free and divergence-free motion fields of frame
/// pairs, and their RGB representation [|v_d|, |v_c|, frame n], computed by
/// the same code as the `reynoldsflow` command line (same bytes).
///
/// Compiled as `reynoldsflow._native`; the package's `__init__.py`
/// re-exports all of it as `reynoldsflow`.
/// The settings a call with these keywords computes with (engine, scale,
/// intensity_scale, lam, tile, variant, hsv_max, layout), checked as every
/// function checks them: ``settings()`` gives the defaults, which are
/// ``DEFAULTS``, the library's own.
#[pyfunction]
#[pyo3(name = "settings", signature = (**options))]
fn call_settings<'py>(
    py: Python<'py>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    CallSettings::parse(Kwargs::new(py, "settings", options, settings::IMAGE_KEYS)?)?.to_dict(py)
}

/// _settings(function, options) -> dict
///
/// ``settings(**options)``, its errors naming ``function`` as the caller
/// (``"represent_batch() got an unexpected keyword argument ..."``): the
/// one parsing of the computing keywords, for the package's functions
/// written in Python.
#[pyfunction]
#[pyo3(signature = (function, options=None))]
fn _settings<'py>(
    py: Python<'py>,
    function: &str,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    CallSettings::parse(Kwargs::new(py, function, options, settings::IMAGE_KEYS)?)?.to_dict(py)
}

#[pymodule]
#[pyo3(name = "_native")]
fn reynoldsflow(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add(
        "DEFAULTS",
        settings::keywords(
            m.py(),
            &reynoldsflow_host::settings::Settings::default(),
            Layout::default(),
        )?,
    )?;
    m.add_function(wrap_pyfunction!(call_settings, m)?)?;
    m.add_function(wrap_pyfunction!(_settings, m)?)?;
    m.add_function(wrap_pyfunction!(represent, m)?)?;
    m.add_function(wrap_pyfunction!(fields, m)?)?;
    m.add_function(wrap_pyfunction!(motion_score, m)?)?;
    m.add_function(wrap_pyfunction!(represent_clip, m)?)?;
    m.add_function(wrap_pyfunction!(convert, m)?)?;
    m.add_function(wrap_pyfunction!(dataset_items, m)?)?;
    m.add_function(wrap_pyfunction!(read_frames, m)?)?;
    m.add_function(wrap_pyfunction!(_as_ndarray, m)?)?;
    m.add_class::<FrameReader>()?;
    m.add_function(wrap_pyfunction!(read_flo, m)?)?;
    m.add_function(wrap_pyfunction!(set_max_pixels, m)?)?;
    m.add_function(wrap_pyfunction!(max_pixels, m)?)?;
    m.add_function(wrap_pyfunction!(_check_frame_size, m)?)?;
    m.add_function(wrap_pyfunction!(write_flo, m)?)?;
    m.add_class::<Stream>()?;
    Ok(())
}

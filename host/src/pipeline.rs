//! A frame sequence through the engine: every consecutive pair `(n, n+1)`
//! gives result `n`, labelled with frame `n` (SPEC §5), computed on a pool
//! of worker threads and delivered in frame order.
//!
//! The pairs go through the one ordered driver ([`crate::driver`]): its
//! feeding thread reads frames from the [`FrameSource`] and hands out
//! pairs; `threads` workers compute each pair and write its files (or
//! encode its stream frame); this thread puts stream frames out in order
//! and counts. Memory stays bounded whatever the sequence's length, and
//! the output is the same for every thread count. Each worker holds the
//! one engine ([`PairEngine`]); the run's last pairs are spread over the
//! run's kept pool (`crate::engine::bands`), so that the threads of
//! workers with no pair left help finish them.
//!
//! Only what the outputs need is computed: when no output needs the fields
//! ([`OutputSpec::needs_fields`]), a worker computes the representation's
//! bytes alone. Frames, engines and output buffers are
//! reused from pair to pair (a `Pool`), so a warm run allocates no frame-
//! sized memory.

use std::io::Write;
use std::ops::ControlFlow;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

use crate::HostError;
use crate::driver::{self, Feed, Work};
use crate::engine::page_buffer::{ByteBuffer, PageBytes};
use crate::engine::{Compute, Image, PairEngine};
use crate::outputs::{DirWriter, OutputSpec, StreamFormat, y4m_frame_into, y4m_header};
use crate::sequence::{Frame, FrameSource};
use crate::stop::Stop;

/// Where results go.
pub enum Destination<'a> {
    /// Files in a folder.
    Dir(&'a DirWriter),
    /// Samples, in order: each result's files (as `spec` makes them for a
    /// folder) with its frames and motion score (`dataset --webdataset`).
    Samples {
        /// What each sample holds.
        spec: &'a OutputSpec,
        /// Where the samples go.
        sink: &'a mut dyn SampleSink,
    },
    /// The `--variant` images as a stream, in frame order.
    Stream {
        /// Which image.
        spec: &'a OutputSpec,
        /// Raw RGB24 or Y4M.
        format: StreamFormat,
        /// Where (standard output).
        writer: &'a mut (dyn Write + Send),
    },
}

/// How a sequence is run.
#[derive(Clone, Debug)]
pub struct Options {
    /// Worker threads (at least 1).
    pub threads: usize,
    /// Repeat the last result for the last frame (N outputs for N frames).
    pub keep_count: bool,
    /// Read at most this many frames.
    pub max_frames: Option<usize>,
    /// Name each result `PREV_NEXT` after both its frames' stems (frames
    /// are picked by `--step` or `--fps`), not after the first alone.
    pub pair_names: bool,
    /// Keep the input index of every frame used ([`Summary::source_frames`]).
    pub record_frames: bool,
    /// Set to stop the run: no new pair is started, pairs in flight
    /// finish, and the run fails as interrupted.
    pub stop: Stop,
}

impl Options {
    /// A plain run on `threads` workers: one result a pair, every frame
    /// read, results named after their first frame, nothing recorded, and
    /// a fresh [`Stop`] no one else holds.
    pub fn new(threads: usize) -> Self {
        Self {
            threads,
            keep_count: false,
            max_frames: None,
            pair_names: false,
            record_frames: false,
            stop: Stop::new(),
        }
    }
}

/// One result as a sample: its files and what it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// `(path relative to an output folder, bytes)`, as
    /// [`OutputSpec::files`] makes them.
    pub files: Vec<(std::path::PathBuf, Vec<u8>)>,
    /// The mean `|v_R|` of the pair ([`crate::FlowPlanes::mean_speed`]).
    pub motion: f64,
}

/// Where [`Destination::Samples`] puts the samples, one call per result
/// in result order (and the `--keep-count` repeat last).
pub trait SampleSink {
    /// The result named `stem`, of the input frames `frames` (indices).
    fn sample(
        &mut self,
        stem: &str,
        frames: (usize, usize),
        sample: &Sample,
    ) -> Result<(), HostError>;
}

/// What a run did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Summary {
    /// Frames read.
    pub frames: usize,
    /// Results computed (`frames − 1`, or 0).
    pub results: usize,
    /// Results delivered, with the `--keep-count` repeat.
    pub outputs: usize,
    /// Frame size.
    pub size: Option<(usize, usize)>,
    /// The stream's reader closed it (broken pipe) before the end: the run
    /// stopped there, without error.
    pub stream_closed: bool,
    /// The input index of every frame used, in order, with
    /// [`Options::record_frames`]: result `i` came from frames
    /// `source_frames[i]` and `source_frames[i + 1]`.
    pub source_frames: Option<Vec<usize>>,
}

/// Buffers handed back after use, for the next pair to reuse: once it
/// holds as many as are in flight, a run allocates no more of them.
struct Pool<T>(Mutex<Vec<T>>);

impl<T> Pool<T> {
    fn new() -> Self {
        Self(Mutex::new(Vec::new()))
    }

    /// A used buffer, if one is free.
    fn take(&self) -> Option<T> {
        self.0.lock().expect("no panic while holding it").pop()
    }

    fn put(&self, item: T) {
        self.0.lock().expect("no panic while holding it").push(item);
    }
}

/// A pair to compute.
struct Job {
    index: usize,
    prev: Arc<Frame>,
    next: Arc<Frame>,
    /// Named after both frames ([`Options::pair_names`]).
    pair_names: bool,
}

impl Job {
    /// The name of its result.
    fn stem(&self) -> std::borrow::Cow<'_, str> {
        result_stem(&self.prev.stem, &self.next.stem, self.pair_names)
    }
}

/// The name of the result of frames `prev` and `next`: `prev`, or
/// `PREV_NEXT` with `pair_names`.
fn result_stem<'a>(prev: &'a str, next: &str, pair_names: bool) -> std::borrow::Cow<'a, str> {
    if pair_names {
        format!("{prev}_{next}").into()
    } else {
        prev.into()
    }
}

/// What the reader found once it reached the end of the input.
#[derive(Default)]
struct End {
    frames: usize,
    last_stem: Option<String>,
    size: Option<(usize, usize)>,
    source_frames: Option<Vec<usize>>,
}

fn interrupted() -> HostError {
    HostError::io(
        "interrupted",
        std::io::Error::new(
            std::io::ErrorKind::Interrupted,
            "stopped on request; every file written so far is complete",
        ),
    )
}

/// Run `source` through `compute` into `dest`; `on_output` is called once
/// per delivered result, in order. Stops at the first error (files already
/// written stay: each is complete).
pub fn process(
    source: &mut dyn FrameSource,
    compute: &Compute,
    dest: Destination<'_>,
    options: Options,
    on_output: &mut dyn FnMut(),
) -> Result<Summary, HostError> {
    process_with(
        source,
        compute,
        dest,
        options,
        on_output,
        #[cfg(test)]
        None,
    )
}

/// [`process`]; in tests, each worker enters `overlap` while computing.
fn process_with(
    source: &mut dyn FrameSource,
    compute: &Compute,
    dest: Destination<'_>,
    options: Options,
    on_output: &mut dyn FnMut(),
    #[cfg(test)] overlap: Option<&tests::Overlap>,
) -> Result<Summary, HostError> {
    let threads = options.threads.max(1);
    let fps = source.frame_rate().unwrap_or((25, 1));
    let (dir, mut stream, mut samples) = match dest {
        Destination::Dir(d) => (Some(d), None, None),
        Destination::Stream {
            spec,
            format,
            writer,
        } => (None, Some((spec, format, writer)), None),
        Destination::Samples { spec, sink } => (None, None, Some((spec, sink))),
    };
    let stream_spec = stream.as_ref().map(|(spec, format, _)| (*spec, *format));
    let sample_spec = samples.as_ref().map(|(spec, _)| *spec);
    // A sample's motion score needs the fields.
    let needs_fields = match (dir, stream_spec, sample_spec) {
        (Some(dir), _, _) => dir.spec().needs_fields(),
        (None, Some((spec, _)), _) => spec.image_needs_fields(),
        (None, None, Some(_)) => true,
        (None, None, None) => unreachable!("a destination is a folder, a stream or samples"),
    };
    let pairs = Pairs {
        compute,
        threads,
        // The threads that help finish the run's last pairs (none on one).
        pool: match threads {
            1 => None,
            n => Some(Arc::new(crate::workers::kept_pool(
                n - 1,
                "reynoldsflow-help",
            )?)),
        },
        needs_fields,
        dir,
        stream: stream_spec,
        samples: sample_spec,
        desk: LastPairs::new(threads),
        frames: Pool::new(),
        payloads: Pool::new(),
        #[cfg(test)]
        overlap,
    };
    let mut out = Out {
        payloads: &pairs.payloads,
        dir,
        stream: stream.as_mut().map(|(_, format, w)| (*format, &mut **w)),
        samples: samples.as_mut().map(|(_, sink)| &mut **sink),
        pair_names: options.pair_names,
        fps,
        keep_count: options.keep_count,
        header_written: false,
        delivered: 0,
        last: None,
    };
    let ran = driver::in_order(
        &pairs,
        threads,
        |feed| read_pairs(source, &options, feed, &pairs),
        |delivery| {
            let next = out.deliver(delivery)?;
            if next.is_continue() {
                on_output();
            }
            Ok(next)
        },
    );
    let result = (|| {
        let ran = ran?;
        if options.stop.is_stopped() {
            return Err(interrupted());
        }
        let Some(end) = ran else {
            return Ok(Summary {
                outputs: out.delivered,
                results: out.delivered,
                stream_closed: true,
                ..Summary::default()
            });
        };
        let mut summary = Summary {
            frames: end.frames,
            results: out.delivered,
            outputs: out.delivered,
            size: end.size,
            stream_closed: false,
            source_frames: end.source_frames,
        };
        if let Some(to) = end.last_stem
            && out.repeat_last(&to)?
        {
            on_output();
            summary.outputs += 1;
        }
        Ok(summary)
    })();
    // Files still being written in the background are complete before
    // this returns, whatever happened (the run's own error comes first).
    let flushed = dir.map_or(Ok(()), DirWriter::flush);
    let summary = result?;
    flushed?;
    Ok(summary)
}

/// Which of a run's pairs are its last `workers − 1` (when one starts,
/// the other workers have one pair left at most, and they finish it
/// first): those are spread over the run's pool, whose threads the idle
/// workers leave free. With one worker, none is.
struct LastPairs {
    workers: usize,
    /// Frames in the input, once the reader has found its end (0 before).
    frames: std::sync::atomic::AtomicUsize,
}

impl LastPairs {
    fn new(workers: usize) -> Self {
        Self {
            workers,
            frames: std::sync::atomic::AtomicUsize::new(0),
        }
    }

    /// The reader reached the end of the input after `frames` frames.
    fn end_input(&self, frames: usize) {
        self.frames.store(frames, Ordering::SeqCst);
    }

    /// Whether pair `index` is one of the last, once the reader has told
    /// where the input ends.
    fn shares(&self, index: usize) -> bool {
        let frames = self.frames.load(Ordering::SeqCst);
        self.workers > 1 && frames > 0 && index + self.workers >= frames
    }
}

/// The reader: frames in, pairs out to `feed` (which waits for room);
/// tells `pairs.desk` where the input ends. Stopped early, what it returns
/// is not used.
fn read_pairs(
    source: &mut dyn FrameSource,
    options: &Options,
    feed: &Feed<'_, Job>,
    pairs: &Pairs<'_>,
) -> Result<End, HostError> {
    let mut prev: Option<Arc<Frame>> = None;
    let mut frames = 0;
    let mut source_frames = options.record_frames.then(Vec::new);
    loop {
        if feed.stopped() {
            return Ok(End::default());
        }
        if options.stop.is_stopped() {
            return Err(interrupted());
        }
        if options.max_frames.is_some_and(|m| frames >= m) {
            break;
        }
        let mut frame = pairs.frames.take().unwrap_or_else(Frame::empty);
        let frame = match source.next_frame_into(&mut frame)? {
            true => Arc::new(frame),
            false => break,
        };
        frames += 1;
        if let Some(used) = &mut source_frames {
            used.push(frame.index);
        }
        if let Some(prev) = prev.replace(Arc::clone(&frame)) {
            let job = Job {
                index: frames - 2,
                prev,
                next: frame,
                pair_names: options.pair_names,
            };
            if !feed.send(job) {
                return Ok(End::default());
            }
        }
    }
    pairs.desk.end_input(frames);
    Ok(End {
        frames,
        last_stem: prev.as_ref().map(|f| f.stem.clone()),
        size: prev.as_ref().map(|f| f.gray.size()),
        source_frames,
    })
}

/// What the workers compute and where results go, shared by them all.
struct Pairs<'a> {
    compute: &'a Compute,
    threads: usize,
    /// The threads that help finish the run's last pairs.
    pool: Option<Arc<rayon::ThreadPool>>,
    /// Some output needs the fields; otherwise only the representation's
    /// bytes are computed.
    needs_fields: bool,
    dir: Option<&'a DirWriter>,
    stream: Option<(&'a OutputSpec, StreamFormat)>,
    /// Results are samples of this spec.
    samples: Option<&'a OutputSpec>,
    /// Which pairs are the run's last.
    desk: LastPairs,
    /// Frames: the reader fills them, the last worker to use one hands it
    /// back.
    frames: Pool<Frame>,
    /// Stream payloads: workers fill them, the collector hands them back.
    payloads: Pool<PageBytes>,
    /// Where the pipeline's tests see whether two workers compute at once.
    #[cfg(test)]
    overlap: Option<&'a tests::Overlap>,
}

/// A worker's own: its engine and the `--variant` image of the pair (when
/// it is not the payload itself), reused for every pair it takes.
struct Lane {
    engine: PairEngine,
    rgb: Vec<u8>,
}

impl Work for Pairs<'_> {
    type Job = Job;
    type Output = Delivery;
    type Error = HostError;
    type State = Lane;

    fn state(&self) -> Lane {
        Lane {
            engine: PairEngine::with_pool(
                self.compute.clone(),
                Image::default(),
                self.pool.clone(),
                self.threads - 1,
            ),
            rgb: Vec::new(),
        }
    }

    /// One pair's result. Its payload is drawn from the pool only when its
    /// bytes are written ([`PooledBytes`]).
    fn compute(&self, lane: &mut Lane, job: &Job) -> Result<Delivery, HostError> {
        #[cfg(test)]
        let _inside = self.overlap.map(|o| o.enter());
        let mut payload = PooledBytes::new(&self.payloads);
        let sample = self.work(lane, job, &mut payload)?;
        Ok(Delivery {
            stem: job.stem().into_owned(),
            size: job.prev.gray.size(),
            payload: payload.into_inner(),
            frames: (job.prev.index, job.next.index),
            sample,
        })
    }

    fn panicked(&self, job: &Job, _: Box<dyn std::any::Any + Send>) -> HostError {
        HostError::internal_panic(format!("frame {}", job.prev.stem), "computing this pair")
    }

    /// The last of the two jobs (and the reader) to use a frame hands it
    /// back.
    fn release(&self, job: Job) {
        for frame in [job.prev, job.next] {
            if let Some(frame) = Arc::into_inner(frame) {
                self.frames.put(frame);
            }
        }
    }
}

impl Pairs<'_> {
    /// Compute one pair, then write its files, encode its stream frame
    /// into `payload`, or make its sample.
    fn work(
        &self,
        lane: &mut Lane,
        job: &Job,
        payload: &mut PooledBytes<'_>,
    ) -> Result<Option<Sample>, HostError> {
        let (prev, next) = (&job.prev.gray, &job.next.gray);
        let stem = job.stem();
        if self.needs_fields {
            let fields = lane.engine.fields(prev, next)?;
            if let Some(dir) = self.dir {
                // A folder is the run's one destination: the fields go to it.
                dir.write(&stem, fields)?;
                return Ok(None);
            }
            if let Some(spec) = self.samples {
                return Ok(Some(Sample {
                    files: spec.files(&stem, &fields)?,
                    motion: fields.planes.mean_speed(),
                }));
            }
            return match self.stream {
                Some((spec, StreamFormat::Rgb24)) => {
                    let image = spec.image(&fields);
                    payload.overwrite(image.len())?.copy_from_slice(&image);
                    Ok(None)
                }
                Some((spec, StreamFormat::Y4m)) => {
                    y4m_frame_into(&spec.image(&fields), payload).map(|()| None)
                }
                None => Ok(None),
            };
        }
        // Raw RGB goes out as computed; Y4M and files are made from the image.
        let spec = self.dir.map_or_else(
            || self.stream.expect("a folder or a stream").0,
            DirWriter::spec,
        );
        let last = self.desk.shares(job.index);
        let image: &mut [u8] = match self.stream {
            Some((_, StreamFormat::Rgb24)) => {
                lane.engine.representation(prev, next, payload, last)?;
                payload.bytes()
            }
            _ => {
                lane.engine
                    .representation(prev, next, &mut lane.rgb, last)?;
                &mut lane.rgb
            }
        };
        spec.arrange(image);
        if let Some(dir) = self.dir {
            dir.write_image(&stem, prev.width, prev.height, image)?;
        }
        if let Some((_, StreamFormat::Y4m)) = self.stream {
            y4m_frame_into(&lane.rgb, payload)?;
        }
        Ok(None)
    }
}

/// A result's stream bytes, drawn from the run's pool of used buffers only
/// when they are first written: per-frame min–max writes its bytes after
/// the engine pass, when the collector has handed back the buffer of an
/// earlier result, so a run keeps fewer buffers (each one's first touch is
/// a page fault per 2 MiB): at 1280×720 with two workers, 2 payloads are
/// mapped, not 4 (`strace -e trace=mmap`).
struct PooledBytes<'a> {
    pool: &'a Pool<PageBytes>,
    bytes: Option<PageBytes>,
}

impl<'a> PooledBytes<'a> {
    fn new(pool: &'a Pool<PageBytes>) -> Self {
        Self { pool, bytes: None }
    }

    /// What was written (nothing: an empty buffer, which allocates nothing).
    fn bytes(&mut self) -> &mut [u8] {
        self.bytes.as_deref_mut().unwrap_or_default()
    }

    fn into_inner(self) -> PageBytes {
        self.bytes.unwrap_or_default()
    }
}

impl ByteBuffer for PooledBytes<'_> {
    fn overwrite(&mut self, len: usize) -> Result<&mut [u8], HostError> {
        let pool = self.pool;
        self.bytes
            .get_or_insert_with(|| pool.take().unwrap_or_default())
            .overwrite(len)
    }
}

/// A computed result waiting for its turn.
struct Delivery {
    stem: String,
    size: (usize, usize),
    /// Stream bytes.
    payload: PageBytes,
    /// Input indices of its frames.
    frames: (usize, usize),
    sample: Option<Sample>,
}

/// This thread's part: results in frame order to the stream or the
/// sample sink, and the count.
struct Out<'a, 'w, 'o> {
    payloads: &'a Pool<PageBytes>,
    dir: Option<&'a DirWriter>,
    stream: Option<(StreamFormat, &'w mut (dyn Write + Send + 'o))>,
    samples: Option<&'w mut (dyn SampleSink + 'o)>,
    /// Results are named after both frames ([`Options::pair_names`]).
    pair_names: bool,
    fps: (u32, u32),
    keep_count: bool,
    header_written: bool,
    /// Results delivered so far.
    delivered: usize,
    /// The last result, kept only to be repeated (`--keep-count`).
    last: Option<Delivery>,
}

fn stdout_error(e: std::io::Error) -> HostError {
    HostError::io("stdout", e)
}

impl Out<'_, '_, '_> {
    /// Put the next result out (on the stream or as a sample, if any);
    /// `Break` when the stream's reader closed it (broken pipe), which
    /// stops the run without error.
    fn deliver(&mut self, delivery: Delivery) -> Result<ControlFlow<()>, HostError> {
        if let (Some(sink), Some(sample)) = (self.samples.as_mut(), &delivery.sample) {
            sink.sample(&delivery.stem, delivery.frames, sample)?;
        }
        if let Some((format, w)) = self.stream.as_mut() {
            let written = (|| {
                if *format == StreamFormat::Y4m && !self.header_written {
                    let (width, height) = delivery.size;
                    w.write_all(y4m_header(width, height, self.fps).as_bytes())?;
                    self.header_written = true;
                }
                w.write_all(&delivery.payload)?;
                w.flush()
            })();
            match written {
                Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
                    return Ok(ControlFlow::Break(()));
                }
                Err(e) => return Err(stdout_error(e)),
                Ok(()) => {}
            }
        }
        self.delivered += 1;
        // Unless it is kept to be repeated, its buffer goes straight back
        // to the workers.
        if !self.keep_count {
            self.payloads.put(delivery.payload);
        } else if let Some(used) = self.last.replace(delivery) {
            self.payloads.put(used.payload);
        }
        Ok(ControlFlow::Continue(()))
    }

    /// `--keep-count`: the last result once more, labelled with the last
    /// frame (`to`); whether there was one to repeat.
    fn repeat_last(&mut self, to: &str) -> Result<bool, HostError> {
        let Some(from) = self.last.take().filter(|_| self.keep_count) else {
            return Ok(false);
        };
        let to = &*result_stem(to, to, self.pair_names);
        if let Some(dir) = self.dir {
            dir.repeat(&from.stem, to)?;
        }
        if let (Some(sink), Some(sample)) = (self.samples.as_mut(), &from.sample) {
            let renamed = Sample {
                files: sample
                    .files
                    .iter()
                    .map(|(path, bytes)| (renamed_file(path, &from.stem, to), bytes.clone()))
                    .collect(),
                motion: sample.motion,
            };
            sink.sample(to, from.frames, &renamed)?;
        }
        if let Some((_, w)) = self.stream.as_mut() {
            w.write_all(&from.payload)
                .and_then(|()| w.flush())
                .map_err(stdout_error)?;
        }
        Ok(true)
    }
}

/// `path` (`[DIR/]FROM.EXT`) as `[DIR/]TO.EXT`.
fn renamed_file(path: &std::path::Path, from: &str, to: &str) -> std::path::PathBuf {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    let ext = name.strip_prefix(from).unwrap_or(name);
    path.with_file_name(format!("{to}{ext}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Gray;
    use crate::sequence::index_stem;
    use crate::settings::{EngineKind, ScaleArg};
    use reynoldsflow_core::IntensityScale;

    /// `n` small moving frames, then an error if `fail`.
    struct Frames {
        next: usize,
        n: usize,
        fail: bool,
    }

    impl FrameSource for Frames {
        fn next_frame(&mut self) -> Result<Option<Frame>, HostError> {
            if self.next == self.n {
                return match self.fail {
                    true => Err(HostError::invalid("source", "broken on purpose")),
                    false => Ok(None),
                };
            }
            let t = self.next;
            self.next += 1;
            let pixels = (0..24 * 16)
                .map(|i| (((i % 24 + 2 * t) * 37 + (i / 24) * 11) % 251) as u8)
                .collect();
            Ok(Some(Frame {
                gray: Gray::new(24, 16, pixels).unwrap(),
                stem: index_stem(t),
                index: t,
            }))
        }
    }

    /// The fixed engine at `run`'s defaults.
    fn fixed_compute() -> Compute {
        Compute::new(
            EngineKind::Fixed,
            ScaleArg::MinMax,
            IntensityScale::PER_255,
            1e-4,
            None,
        )
        .unwrap()
    }

    fn stream(
        n: usize,
        fail: bool,
        threads: usize,
        keep_count: bool,
    ) -> (Result<Summary, HostError>, Vec<u8>, usize) {
        stream_with(&fixed_compute(), n, fail, threads, keep_count)
    }

    /// `n` frames through `compute` into an RGB stream: the summary, the
    /// bytes and the number of outputs reported.
    fn stream_with(
        compute: &Compute,
        n: usize,
        fail: bool,
        threads: usize,
        keep_count: bool,
    ) -> (Result<Summary, HostError>, Vec<u8>, usize) {
        stream_on(compute, n, fail, threads, keep_count, None)
    }

    /// `n` frames on `threads` workers, each entering `overlap` while it
    /// computes.
    fn stream_overlapping(
        n: usize,
        threads: usize,
        overlap: Option<&Overlap>,
    ) -> (Result<Summary, HostError>, Vec<u8>, usize) {
        stream_on(&fixed_compute(), n, false, threads, false, overlap)
    }

    fn stream_on(
        compute: &Compute,
        n: usize,
        fail: bool,
        threads: usize,
        keep_count: bool,
        overlap: Option<&Overlap>,
    ) -> (Result<Summary, HostError>, Vec<u8>, usize) {
        let spec = OutputSpec::default();
        let mut bytes = Vec::new();
        let mut calls = 0;
        let result = process_with(
            &mut Frames { next: 0, n, fail },
            compute,
            Destination::Stream {
                spec: &spec,
                format: StreamFormat::Rgb24,
                writer: &mut bytes,
            },
            Options {
                keep_count,
                ..Options::new(threads)
            },
            &mut || calls += 1,
            overlap,
        );
        (result, bytes, calls)
    }

    /// Workers inside a job at once: `enter` waits (up to two seconds, once)
    /// for a second worker to be inside too.
    #[derive(Debug, Default)]
    pub(super) struct Overlap {
        inside: Mutex<(usize, bool)>,
        changed: std::sync::Condvar,
    }

    impl Overlap {
        pub(super) fn enter(&self) -> Inside<'_> {
            let mut state = self.inside.lock().unwrap();
            state.0 += 1;
            state.1 |= state.0 >= 2;
            self.changed.notify_all();
            let timeout = std::time::Duration::from_secs(2);
            let (state, _) = self
                .changed
                .wait_timeout_while(state, timeout, |(_, met)| !*met)
                .unwrap();
            drop(state);
            Inside(self)
        }

        fn met(&self) -> bool {
            self.inside.lock().unwrap().1
        }
    }

    pub(super) struct Inside<'a>(&'a Overlap);

    impl Drop for Inside<'_> {
        fn drop(&mut self) {
            self.0.inside.lock().unwrap().0 -= 1;
        }
    }

    #[test]
    fn a_pair_is_one_of_the_last_once_the_end_is_known() {
        let last = LastPairs::new(2);
        assert!(!last.shares(29), "before the end is known");
        last.end_input(31);
        assert!(last.shares(29) && !last.shares(28));
        let last = LastPairs::new(3);
        last.end_input(31);
        assert!(last.shares(28) && !last.shares(27));
        let last = LastPairs::new(4);
        last.end_input(2);
        assert!(last.shares(0));
        let last = LastPairs::new(1);
        last.end_input(31);
        assert!(
            (0..30).all(|pair| !last.shares(pair)),
            "one worker spreads nothing"
        );
    }

    /// Two workers compute two pairs at the same time (a worker that kept
    /// the job queue's lock while computing would serialise them).
    #[test]
    fn workers_compute_pairs_at_the_same_time() {
        let overlap = Overlap::default();
        let (summary, _, _) = stream_overlapping(6, 2, Some(&overlap));
        assert_eq!(summary.unwrap().results, 5);
        assert!(
            overlap.met(),
            "no two workers were ever inside a job at once"
        );
    }

    /// A payload is drawn from the pool only when its bytes are written,
    /// so a buffer handed back meanwhile is the one reused.
    #[test]
    fn a_payload_is_taken_from_the_pool_when_first_written() {
        let pool = Pool::new();
        let mut used = PageBytes::default();
        used.overwrite(5).unwrap().copy_from_slice(b"first");
        let mut payload = PooledBytes::new(&pool);
        pool.put(used);
        assert!(payload.bytes().is_empty());
        assert!(pool.0.lock().unwrap().len() == 1, "taken before any byte");
        payload.overwrite(3).unwrap().copy_from_slice(b"abc");
        assert!(pool.take().is_none(), "a new buffer made beside a free one");
        assert_eq!(&*payload.into_inner(), b"abc");
        // Never written: an empty buffer, nothing taken.
        pool.put(PageBytes::default());
        assert!(PooledBytes::new(&pool).into_inner().is_empty());
        assert!(pool.take().is_some());
    }

    #[test]
    fn results_come_in_frame_order_whatever_the_thread_count() {
        let frame = 3 * 24 * 16;
        let (one, bytes_one, calls) = stream(9, false, 1, false);
        let one = one.unwrap();
        assert_eq!((one.frames, one.results, one.outputs, calls), (9, 8, 8, 8));
        assert_eq!(bytes_one.len(), 8 * frame);
        for threads in [2, 3, 8] {
            let (_, bytes, _) = stream(9, false, threads, false);
            assert!(bytes == bytes_one, "{threads} threads");
        }
        let (kept, bytes, _) = stream(9, false, 3, true);
        assert_eq!(kept.unwrap().outputs, 9);
        assert_eq!(bytes[..8 * frame], bytes_one[..]);
        assert_eq!(bytes[8 * frame..], bytes_one[7 * frame..]);
    }

    #[test]
    fn an_input_error_comes_after_the_pairs_read_before_it() {
        let (result, bytes, calls) = stream(5, true, 2, false);
        assert!(
            result
                .unwrap_err()
                .to_string()
                .contains("broken on purpose")
        );
        assert_eq!((bytes.len(), calls), (4 * 3 * 24 * 16, 4));
        let (single, bytes, _) = stream(1, false, 2, true);
        assert_eq!(single.unwrap().results, 0);
        assert!(bytes.is_empty());
    }
}

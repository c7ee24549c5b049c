//! What computes one pair into an output buffer: the host's pair engine,
//! the cues when asked, and the rows of an image whose output rows have
//! padding. The streaming thread holds one (the pair's tiles on every
//! thread, [`super::imp`]); each thread that computes whole pairs holds its
//! own ([`super::workers`]). And how a pair's output goes out: once per
//! label, stamped ([`outputs_of`]).

use gst_video::prelude::*;
use reynoldsflow_cues::Region;
use reynoldsflow_host::Gray;
use reynoldsflow_host::cues::{self as host_cues, Cues};
use reynoldsflow_host::engine::PairEngine;
use reynoldsflow_host::settings::Settings;

use super::message;
use crate::cues;

/// One pair's image (not yet stamped) and cues.
pub(super) struct PairOutput {
    pub(super) image: gst::Buffer,
    /// The cues' regions and level, when `cues=true`.
    pub(super) cues: Option<(Vec<Region>, f64)>,
}

/// Why a pair gave no output: the element error to post.
#[derive(Debug)]
pub(super) enum Failure {
    /// The settings (or the cues' frame size) refuse it.
    Settings(String),
    /// The computation failed.
    Stream(String),
    /// No output buffer could be made.
    Buffer,
}

impl Failure {
    /// Post it on `element`.
    pub(super) fn post(&self, element: &super::ReynoldsFlow) {
        match self {
            Self::Settings(m) => {
                gst::element_error!(element, gst::LibraryError::Settings, ("{m}"))
            }
            Self::Stream(m) => gst::element_error!(element, gst::StreamError::Failed, ("{m}")),
            Self::Buffer => gst::element_error!(
                element,
                gst::ResourceError::NoSpaceLeft,
                ("Cannot make an output buffer")
            ),
        }
    }
}

/// The engine and cues of one thread, built for one generation of the
/// properties.
pub(super) struct Pairs {
    /// The properties generation they were built for.
    pub(super) generation: u64,
    engine: PairEngine,
    cues: Option<Cues>,
    /// An image's rows where the output's have padding.
    scratch: Vec<u8>,
}

impl Pairs {
    /// The engine of `settings` on its `threads`, with cues when asked:
    /// checked, a failure names the property at fault.
    pub(super) fn new(settings: &Settings, cues: bool, generation: u64) -> Result<Self, Failure> {
        let settings_failure = |e| Failure::Settings(message(&e));
        let engine = PairEngine::new(settings)
            .map_err(settings_failure)?
            .keep_magnitudes(cues);
        let cues = match cues {
            true => Some(Cues::new(settings).map_err(settings_failure)?),
            false => None,
        };
        Ok(Self {
            generation,
            engine,
            cues,
            scratch: Vec::new(),
        })
    }

    /// The pair `(prev, next)` through the engine, into a new output
    /// buffer of `out_info`, and its cues.
    pub(super) fn pair(
        &mut self,
        out_info: &gst_video::VideoInfo,
        prev: &Gray,
        next: &Gray,
    ) -> Result<PairOutput, Failure> {
        let (width, height) = prev.size();
        let row = 3 * width;
        let failed = |e| Failure::Stream(message(&e));
        let mut image = gst::Buffer::with_size(out_info.size()).map_err(|_| Failure::Buffer)?;
        {
            let buffer = image.get_mut().expect("a new buffer is writable");
            let mut frame = gst_video::VideoFrameRef::from_buffer_ref_writable(buffer, out_info)
                .map_err(|_| Failure::Buffer)?;
            let stride = frame.plane_stride()[0] as usize;
            let plane = frame.plane_data_mut(0).map_err(|_| Failure::Buffer)?;
            if stride == row {
                // Straight into the output.
                let plane = plane.get_mut(..row * height).ok_or(Failure::Buffer)?;
                self.engine.image(prev, next, plane).map_err(failed)?;
            } else {
                self.scratch.resize(row * height, 0);
                self.engine
                    .image(prev, next, &mut self.scratch)
                    .map_err(failed)?;
                copy_rows(plane, stride, &self.scratch, row);
            }
        }
        let cues = match self.cues.as_mut() {
            Some(cues) => {
                let magnitudes = self
                    .engine
                    .magnitudes()
                    .ok_or_else(|| Failure::Stream("the pair's magnitudes were not kept".into()))?;
                let regions = cues.regions(&magnitudes).map_err(|e| {
                    Failure::Settings(format!(
                        "cues: {e} (they cover frames up to {} px a side)",
                        host_cues::MAX_SIDE
                    ))
                })?;
                let regions = regions.to_vec();
                Some((regions, cues.level()))
            }
            None => None,
        };
        Ok(PairOutput { image, cues })
    }
}

/// `rgb`'s rows of `row` bytes into `plane`, rows `stride` bytes apart,
/// the padding after each row zero (no byte leaves unwritten).
fn copy_rows(plane: &mut [u8], stride: usize, rgb: &[u8], row: usize) {
    for (dst, src) in plane.chunks_mut(stride).zip(rgb.chunks(row)) {
        let (pixels, padding) = dst.split_at_mut(row.min(dst.len()));
        pixels.copy_from_slice(&src[..pixels.len()]);
        padding.fill(0);
    }
}

/// A buffer's timing, given to the output that carries its label.
#[derive(Clone, Copy, Debug)]
pub(super) struct Stamps {
    pub(super) pts: Option<gst::ClockTime>,
    dts: Option<gst::ClockTime>,
    pub(super) duration: Option<gst::ClockTime>,
    offset: u64,
    offset_end: u64,
}

impl Stamps {
    pub(super) fn of(buffer: &gst::BufferRef) -> Self {
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

/// A pair's output once per label, stamped (the copy for an earlier label
/// shares the image's memory), `DISCONT` on the first when `discont` (then
/// cleared), with its cues as metas (and their message posted).
pub(super) fn outputs_of(
    element: &super::ReynoldsFlow,
    output: PairOutput,
    labels: &[Stamps],
    discont: &mut bool,
) -> Vec<gst::Buffer> {
    let last = labels.len().saturating_sub(1);
    let mut buffers = Vec::with_capacity(labels.len());
    let PairOutput { mut image, cues } = output;
    for (i, stamps) in labels.iter().enumerate() {
        let mut out = match i == last {
            true => std::mem::replace(&mut image, gst::Buffer::new()),
            false => image.copy(),
        };
        let buffer = out.make_mut();
        stamps.apply(buffer);
        if std::mem::take(discont) {
            buffer.set_flags(gst::BufferFlags::DISCONT);
        }
        if let Some((regions, level)) = &cues {
            cues::add_metas(buffer, regions);
            let structure = cues::message_structure(stamps.pts, *level, regions);
            let message = gst::message::Element::builder(structure)
                .src(element)
                .build();
            let _ = element.post_message(message);
        }
        buffers.push(out);
    }
    buffers
}

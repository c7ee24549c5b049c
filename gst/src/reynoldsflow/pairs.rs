//! What computes one pair into an output buffer: the host's pair engine,
//! the cues when asked, and the rows of an image whose output rows have
//! padding. The streaming thread holds one (the pair's tiles on every
//! thread, [`super::imp`]); each thread that computes whole pairs holds its
//! own ([`super::workers`]).

use gst_video::prelude::*;
use reynoldsflow_cues::Region;
use reynoldsflow_host::Gray;
use reynoldsflow_host::cues::{self as host_cues, Cues};
use reynoldsflow_host::pair_engine::PairEngine;
use reynoldsflow_host::settings::Settings;

use super::message;

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

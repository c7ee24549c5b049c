//! Frame sequences for `reynoldsflow run` and `dataset`: every input kind
//! becomes a [`FrameSource`] that yields 8-bit gray frames one at a time, so
//! no video is ever held in memory whole.
//!
//! | input | how it is read | frame labels (output stems) |
//! |---|---|---|
//! | Y4M file or stream (`.y4m`, or `-` starting with `YUV4MPEG2`) | [`y4m`]: any 8-bit chroma layout, only the Y plane is used | `000000`, `000001`, … |
//! | folder of frames, or a glob (`'frames/*.png'`) | [`folder`]: PNG, JPEG, PGM/PPM in natural order (`f2` before `f10`); colour through BT.601 | each file's stem |
//! | raw 8-bit gray frames (`--raw WxH`, from `-` or a file) | [`raw`]: `W·H` bytes per frame, back to back | `000000`, … |
//! | any other file (MP4, AVI, MKV, …) | [`ffmpeg`]: an `ffmpeg` subprocess decodes to 8-bit gray Y4M | `000000`, … |
//! | nothing | [`synthetic`]: the built-in demo scene | `000000`, … |
//!
//! Any of them can be put behind [`sampled::Sampled`] (`--step`, `--fps`,
//! `--resize`, `--short-side`), which picks and resizes frames before the
//! pairs are formed.

use std::fs::File;
use std::io::{self, Read};
use std::path::{Path, PathBuf};

use crate::limits::Limits;
use crate::settings::Setting;
use crate::{Gray, HostError};

pub mod ffmpeg;
pub mod folder;
pub mod natural;
pub mod raw;
pub mod sampled;
pub mod synthetic;
pub mod y4m;

/// One frame of a sequence.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Frame {
    /// The pixels.
    pub gray: Gray,
    /// Its label: the stem every output of the result labelled with this
    /// frame is named after (a file stem, or a zero-padded index).
    pub stem: String,
    /// Its position in the input, from 0 (the source frame index that
    /// `--step` and `--fps` pick by, and that status records report).
    pub index: usize,
}

/// A source of frames, read one at a time.
pub trait FrameSource: Send {
    /// The next frame, `None` at the end of the sequence. An error names the
    /// input and the frame.
    fn next_frame(&mut self) -> Result<Option<Frame>, HostError>;

    /// The next frame into `frame`, reusing its buffers where the source
    /// can (a long run then allocates no frame memory once warm); `false`
    /// at the end of the sequence, `frame` unspecified after an error.
    fn next_frame_into(&mut self, frame: &mut Frame) -> Result<bool, HostError> {
        Ok(match self.next_frame()? {
            Some(next) => {
                *frame = next;
                true
            }
            None => false,
        })
    }

    /// How many frames the whole sequence has, when known before reading it
    /// (for progress display only).
    fn frame_count_hint(&self) -> Option<usize> {
        None
    }

    /// Frame rate `(numerator, denominator)` in frames per second, when the
    /// input states one.
    fn frame_rate(&self) -> Option<(u32, u32)> {
        None
    }
}

/// A source whose first frame has been read ahead, so its size is known
/// before the sequence is run (`verify` must know it to read the captured
/// stream); the frame is still the first one the source yields.
pub struct Peeked {
    first: Option<Frame>,
    size: (usize, usize),
    rest: Box<dyn FrameSource>,
}

impl Peeked {
    /// Read the first frame of `source`; `None` when it has no frame at all.
    pub fn new(mut source: Box<dyn FrameSource>) -> Result<Option<Self>, HostError> {
        Ok(source.next_frame()?.map(|first| Self {
            size: first.gray.size(),
            first: Some(first),
            rest: source,
        }))
    }

    /// The frame size, from the first frame (every source holds the
    /// frames after it to that size).
    pub fn size(&self) -> (usize, usize) {
        self.size
    }
}

impl FrameSource for Peeked {
    fn next_frame(&mut self) -> Result<Option<Frame>, HostError> {
        match self.first.take() {
            Some(first) => Ok(Some(first)),
            None => self.rest.next_frame(),
        }
    }

    fn next_frame_into(&mut self, frame: &mut Frame) -> Result<bool, HostError> {
        match self.first.take() {
            Some(first) => {
                *frame = first;
                Ok(true)
            }
            None => self.rest.next_frame_into(frame),
        }
    }

    fn frame_count_hint(&self) -> Option<usize> {
        self.rest.frame_count_hint()
    }

    fn frame_rate(&self) -> Option<(u32, u32)> {
        self.rest.frame_rate()
    }
}

/// The label of frame `index` of a video-like input: six digits at least,
/// so the labels sort in frame order as plain strings.
pub fn index_stem(index: usize) -> String {
    let mut stem = String::new();
    write_index_stem(&mut stem, index);
    stem
}

/// [`index_stem`] into `stem`, reusing its memory.
pub fn write_index_stem(stem: &mut String, index: usize) {
    use std::fmt::Write;
    stem.clear();
    write!(stem, "{index:06}").expect("writing to a String");
}

impl Frame {
    /// A frame with no pixels yet (not a valid [`Gray`]), for
    /// [`FrameSource::next_frame_into`] to fill.
    pub(crate) fn empty() -> Self {
        Self {
            gray: Gray {
                width: 0,
                height: 0,
                pixels: Vec::new(),
            },
            stem: String::new(),
            index: 0,
        }
    }
}

/// A refused input: `path: problem` (an [`HostError::Io`] of kind
/// `InvalidData`, so the message is exactly that).
pub fn input_error(path: impl Into<PathBuf>, problem: impl Into<String>) -> HostError {
    HostError::io(
        path,
        io::Error::new(io::ErrorKind::InvalidData, problem.into()),
    )
}

/// What `INPUT` names, before it is opened.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum InputSpec {
    /// No input: the built-in demo sequence.
    Demo,
    /// Standard input (`-`): a Y4M stream, or raw frames with `raw`.
    Stdin {
        /// `Some((w, h))`: raw 8-bit gray frames of that size.
        raw: Option<(usize, usize)>,
    },
    /// A path: file, folder or glob pattern.
    Path {
        /// The path as given.
        path: PathBuf,
        /// `Some((w, h))`: a file of raw 8-bit gray frames of that size.
        raw: Option<(usize, usize)>,
    },
}

/// The name an input is reported by.
pub fn display_name(spec: &InputSpec) -> String {
    match spec {
        InputSpec::Demo => "built-in demo sequence".to_owned(),
        InputSpec::Stdin { .. } => "stdin".to_owned(),
        InputSpec::Path { path, .. } => path.display().to_string(),
    }
}

/// Whether a file name has a wildcard (`*`, `?`, `[`).
fn has_wildcard(s: &str) -> bool {
    s.contains(['*', '?', '['])
}

/// Open `spec` as a frame source. Files are told apart by their first
/// bytes (`YUV4MPEG2` is Y4M, an image signature is a single image and
/// refused, anything else goes to ffmpeg); folders and glob patterns are
/// frame folders. No frame over `limits` is read.
pub fn open(spec: &InputSpec, limits: Limits) -> Result<Box<dyn FrameSource>, HostError> {
    match spec {
        InputSpec::Demo => Ok(Box::new(synthetic::Demo::new())),
        InputSpec::Stdin { raw: Some((w, h)) } => Ok(Box::new(raw::RawSource::new(
            PathBuf::from("stdin"),
            Box::new(io::stdin()),
            *w,
            *h,
            limits,
        )?)),
        InputSpec::Stdin { raw: None } => {
            let name = PathBuf::from("stdin");
            let mut stdin = io::BufReader::new(io::stdin());
            let head = peek(&mut stdin, &name)?;
            if head.starts_with(y4m::MAGIC) {
                return Ok(Box::new(y4m::Y4mSource::new(
                    name,
                    Box::new(stdin),
                    None,
                    limits,
                )?));
            }
            let what = if head.is_empty() {
                "is empty"
            } else {
                "is not a Y4M stream"
            };
            // Raw frames are read only with their size set.
            Err(HostError::setting(
                Setting::Raw,
                format!(
                    "{} {what}; give the size WxH of raw 8-bit gray frames, or pipe Y4M (e.g. ffmpeg -i clip.mp4 -f yuv4mpegpipe -pix_fmt gray -)",
                    name.display()
                ),
            ))
        }
        InputSpec::Path {
            path,
            raw: Some((w, h)),
        } => {
            let file = File::open(path).map_err(|e| HostError::io(path, e))?;
            let len = file.metadata().ok().map(|m| m.len());
            let mut source = raw::RawSource::new(
                path.clone(),
                Box::new(io::BufReader::new(file)),
                *w,
                *h,
                limits,
            )?;
            source.set_total_bytes(len);
            Ok(Box::new(source))
        }
        InputSpec::Path { path, raw: None } => open_path(path, limits),
    }
}

fn open_path(path: &Path, limits: Limits) -> Result<Box<dyn FrameSource>, HostError> {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    if !path.exists() && has_wildcard(name) {
        return Ok(Box::new(folder::FolderSource::glob(path, limits)?));
    }
    let meta = std::fs::metadata(path).map_err(|e| HostError::io(path, e))?;
    if meta.is_dir() {
        return Ok(Box::new(folder::FolderSource::dir(path, limits)?));
    }
    let file = File::open(path).map_err(|e| HostError::io(path, e))?;
    let mut reader = io::BufReader::new(file);
    let head = peek(&mut reader, path)?;
    if head.starts_with(y4m::MAGIC) {
        return Ok(Box::new(y4m::Y4mSource::new(
            path.to_owned(),
            Box::new(reader),
            Some(meta.len()),
            limits,
        )?));
    }
    if head.is_empty() {
        return Err(input_error(path, "empty file"));
    }
    if is_image(&head) {
        return Err(input_error(
            path,
            "is a single image; a sequence needs a folder or glob of frames (or use `reynoldsflow pair F0 F1`)",
        ));
    }
    drop(reader);
    Ok(Box::new(ffmpeg::FfmpegSource::spawn(path, limits)?))
}

/// PNG, JPEG or PNM by signature.
fn is_image(head: &[u8]) -> bool {
    matches!(
        head,
        [b'P', b'1'..=b'7', ..] | [0x89, b'P', b'N', b'G', ..] | [0xff, 0xd8, 0xff, ..]
    )
}

/// The first bytes of a buffered reader, without consuming them.
pub fn peek<R: io::BufRead>(reader: &mut R, name: &Path) -> Result<Vec<u8>, HostError> {
    loop {
        match reader.fill_buf() {
            Ok(buf) => return Ok(buf[..buf.len().min(16)].to_vec()),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(HostError::io(name, e)),
        }
    }
}

/// Read until `buf` is full or the input ends; the number of bytes read.
pub fn read_full(reader: &mut dyn Read, buf: &mut [u8]) -> io::Result<usize> {
    let mut filled = 0;
    while filled < buf.len() {
        match reader.read(&mut buf[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        }
    }
    Ok(filled)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_stems_sort_in_frame_order() {
        assert_eq!(index_stem(7), "000007");
        assert_eq!(index_stem(1_234_567), "1234567");
        assert!(is_image(b"\x89PNG\r\n\x1a\n"));
        assert!(!is_image(b"YUV4MPEG2 W1"));
        assert!(has_wildcard("f*.png") && !has_wildcard("f1.png"));
    }
}

//! YUV4MPEG2 (Y4M) input: a text header line, then per frame a `FRAME`
//! line and the planes. Only the Y plane is used; the chroma planes are
//! skipped, so every chroma layout works (`C420jpeg`, `C420paldv`,
//! `C420mpeg2`, `C420`, `C422`, `C444`, `C444alpha`, `C411`, `Cmono`, and
//! no `C` at all, which means 4:2:0). Layouts with more than 8 bits per
//! sample (`C420p10`, `Cmono16`, …) are refused by name.

use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

use super::{Frame, FrameSource, input_error, read_full, write_index_stem};
use crate::HostError;
use crate::limits::{self, Limits};

/// The first bytes of every Y4M stream.
pub const MAGIC: &[u8] = b"YUV4MPEG2";

/// Longest header or `FRAME` line accepted.
const MAX_LINE: usize = 4096;

/// What the stream header says.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Header {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Frame rate `F num:den`, when given and non-zero.
    pub frame_rate: Option<(u32, u32)>,
    /// The chroma layout (`C…`), `420jpeg` when absent.
    pub chroma: String,
    /// Bytes after the Y plane in each frame (chroma, alpha).
    pub extra_bytes: usize,
    /// Bytes of the header line, newline included.
    pub header_bytes: usize,
}

/// Bits per sample of a chroma layout name, from its suffix (`p10`, `mono16`).
fn sample_bits(chroma: &str) -> Option<u32> {
    let digits = chroma
        .strip_prefix("mono")
        .filter(|d| !d.is_empty())
        .or_else(|| chroma.rsplit_once('p').map(|(_, d)| d))?;
    digits.parse().ok()
}

/// Bytes after the Y plane for an 8-bit chroma layout.
fn extra_bytes(chroma: &str, w: usize, h: usize) -> Option<usize> {
    let half = |n: usize| n.div_ceil(2);
    Some(match chroma {
        "420jpeg" | "420paldv" | "420mpeg2" | "420" => 2 * half(w) * half(h),
        "422" => 2 * half(w) * h,
        "411" => 2 * w.div_ceil(4) * h,
        "444" => 2 * w * h,
        "444alpha" => 3 * w * h,
        "mono" => 0,
        _ => return None,
    })
}

/// Why a header line was refused.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum HeaderError {
    /// Not a Y4M header, or one this reader does not take.
    Invalid(String),
    /// A frame over the size limit.
    TooLarge(limits::TooLarge),
}

impl HeaderError {
    /// The host's error about the input `name`.
    pub fn about(self, name: &Path) -> HostError {
        match self {
            HeaderError::Invalid(problem) => input_error(name, problem),
            HeaderError::TooLarge(too_large) => too_large.about(name.display()),
        }
    }
}

impl From<String> for HeaderError {
    fn from(problem: String) -> Self {
        HeaderError::Invalid(problem)
    }
}

/// Parse the header line (without its newline); a frame size over
/// `limits` is refused.
pub fn parse_header(line: &[u8], limits: Limits) -> Result<Header, HeaderError> {
    let text = std::str::from_utf8(line).map_err(|_| "the Y4M header is not text".to_owned())?;
    let mut tokens = text.split(' ').filter(|t| !t.is_empty());
    if tokens.next() != Some("YUV4MPEG2") {
        return Err("not a Y4M stream (no YUV4MPEG2 header)".to_owned().into());
    }
    let (mut width, mut height, mut frame_rate) = (None, None, None);
    let mut chroma = "420jpeg".to_owned();
    for token in tokens {
        // The tag is the first character, which need not be one byte.
        let tag_len = token.chars().next().map_or(0, char::len_utf8);
        let (tag, value) = token.split_at(tag_len);
        match tag {
            "W" => width = value.parse::<usize>().ok().filter(|&v| v > 0),
            "H" => height = value.parse::<usize>().ok().filter(|&v| v > 0),
            "F" => {
                frame_rate = value
                    .split_once(':')
                    .and_then(|(n, d)| Some((n.parse::<u32>().ok()?, d.parse::<u32>().ok()?)))
                    .filter(|&(n, d)| n > 0 && d > 0);
            }
            "C" => chroma = value.to_owned(),
            // I (interlacing), A (aspect), X (extensions): not needed for the Y plane.
            _ => {}
        }
    }
    let (Some(width), Some(height)) = (width, height) else {
        return Err("the Y4M header lacks a valid width (W) or height (H)"
            .to_owned()
            .into());
    };
    limits
        .check_frame_size(width, height)
        .map_err(HeaderError::TooLarge)?;
    let extra_bytes = match extra_bytes(&chroma, width, height) {
        Some(n) => n,
        None => {
            return Err(HeaderError::Invalid(match sample_bits(&chroma) {
                Some(bits) if bits > 8 => format!(
                    "colour space C{chroma} has {bits}-bit samples; only 8-bit Y4M is supported \
                     (convert with e.g. ffmpeg -i in.y4m -pix_fmt gray -f yuv4mpegpipe out.y4m)"
                ),
                _ => format!("unknown Y4M colour space C{chroma}"),
            }));
        }
    };
    Ok(Header {
        width,
        height,
        frame_rate,
        chroma,
        extra_bytes,
        header_bytes: line.len() + 1,
    })
}

/// Read one `\n`-terminated line (without the newline). `Ok(None)` at a
/// clean end of input; an error if the input ends inside the line or the
/// line is longer than 4096 bytes.
pub fn read_line(reader: &mut dyn BufRead) -> Result<Option<Vec<u8>>, String> {
    let mut line = Vec::new();
    let n = reader
        .take(MAX_LINE as u64 + 1)
        .read_until(b'\n', &mut line)
        .map_err(|e| e.to_string())?;
    if n == 0 {
        return Ok(None);
    }
    if line.pop() != Some(b'\n') {
        return Err(if n > MAX_LINE {
            format!("a header line is longer than {MAX_LINE} bytes")
        } else {
            "the input ends inside a header line".to_owned()
        });
    }
    Ok(Some(line))
}

/// A Y4M stream read frame by frame.
pub struct Y4mSource {
    name: PathBuf,
    reader: Box<dyn BufRead + Send>,
    header: Header,
    index: usize,
    scratch: Vec<u8>,
    count_hint: Option<usize>,
    /// The file's length when opened, and the bytes read since: a clean
    /// end before that length means the file shrank while being read.
    file_len: Option<u64>,
    position: u64,
    done: bool,
}

impl Y4mSource {
    /// Read the header of `reader` (reported as `name`), its frame size
    /// within `limits`; `file_len`, when known, gives the frame count hint.
    pub fn new(
        name: PathBuf,
        mut reader: Box<dyn BufRead + Send>,
        file_len: Option<u64>,
        limits: Limits,
    ) -> Result<Self, HostError> {
        let line = match read_line(&mut *reader) {
            Ok(Some(line)) => line,
            Ok(None) => return Err(input_error(name, "empty input; expected a Y4M header")),
            Err(e) => return Err(input_error(name, e)),
        };
        let header = parse_header(&line, limits).map_err(|e| e.about(&name))?;
        // With bare FRAME lines, each frame takes 6 + Y + extra bytes.
        let per_frame = 6 + header.width * header.height + header.extra_bytes;
        let count_hint = file_len.map(|len| {
            (len.saturating_sub(header.header_bytes as u64) / per_frame as u64) as usize
        });
        Ok(Self {
            name,
            reader,
            position: header.header_bytes as u64,
            header,
            index: 0,
            scratch: Vec::new(),
            count_hint,
            file_len,
            done: false,
        })
    }

    /// The stream's header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// A clean end of input, unless the file was longer when opened (a
    /// file truncated at a frame boundary would otherwise pass as a shorter
    /// video).
    fn end(&self) -> Result<bool, String> {
        match self.file_len {
            Some(len) if self.position < len => Err(format!(
                "the input ends after frame {} at byte {}, but the file had {len} bytes when opened: it was truncated while being read",
                self.index, self.position
            )),
            _ => Ok(false),
        }
    }

    fn read_frame(&mut self, frame: &mut Frame) -> Result<bool, String> {
        let index = self.index;
        let line = match read_line(&mut *self.reader) {
            Ok(Some(line)) => line,
            Ok(None) => return self.end(),
            Err(e) => return Err(format!("frame {index}: {e} (truncated file?)")),
        };
        if !line.starts_with(b"FRAME") {
            let shown = String::from_utf8_lossy(&line[..line.len().min(16)]).into_owned();
            return Err(format!(
                "frame {index}: expected a FRAME line, found {shown:?} (corrupt or truncated Y4M, or a wrong colour space in the header)"
            ));
        }
        let (w, h) = (self.header.width, self.header.height);
        let frame_bytes = w * h + self.header.extra_bytes;
        // A reused buffer of the frame's size is overwritten as it stands.
        let pixels = &mut frame.gray.pixels;
        pixels.resize(w * h, 0);
        let got = read_full(&mut *self.reader, pixels).map_err(|e| e.to_string())?;
        let mut got_extra = 0;
        if got == pixels.len() {
            // Skip the chroma planes through a bounded scratch buffer.
            let mut left = self.header.extra_bytes;
            self.scratch.resize(left.clamp(1, 1 << 16), 0);
            while left > 0 {
                let chunk = left.min(self.scratch.len());
                let n = read_full(&mut *self.reader, &mut self.scratch[..chunk])
                    .map_err(|e| e.to_string())?;
                got_extra += n;
                if n < chunk {
                    break;
                }
                left -= n;
            }
        }
        let total = got + got_extra;
        if total < frame_bytes {
            return Err(format!(
                "truncated: frame {index} has {total} of its {frame_bytes} bytes ({w}x{h}, C{})",
                self.header.chroma
            ));
        }
        // The header has checked that both sides are at least 1.
        (frame.gray.width, frame.gray.height) = (w, h);
        write_index_stem(&mut frame.stem, index);
        frame.index = index;
        self.position += (line.len() + 1 + frame_bytes) as u64;
        self.index += 1;
        Ok(true)
    }
}

impl FrameSource for Y4mSource {
    fn next_frame(&mut self) -> Result<Option<Frame>, HostError> {
        if self.done {
            return Ok(None);
        }
        let mut frame = Frame::empty();
        Ok(self.next_frame_into(&mut frame)?.then_some(frame))
    }

    fn next_frame_into(&mut self, frame: &mut Frame) -> Result<bool, HostError> {
        if self.done {
            return Ok(false);
        }
        let read = self
            .read_frame(frame)
            .map_err(|e| input_error(&self.name, e))?;
        self.done = !read;
        Ok(read)
    }

    fn frame_count_hint(&self) -> Option<usize> {
        self.count_hint
    }

    fn frame_rate(&self) -> Option<(u32, u32)> {
        self.header.frame_rate
    }
}

#[cfg(test)]
mod tests {
    /// Found by the `y4m` fuzz target: a tag that is a multi-byte
    /// character split inside it and panicked.
    #[test]
    fn a_non_ascii_tag_is_ignored_not_a_panic() {
        let header = parse_header(
            "YUV4MPEG2 W3 H2 Cmono \u{152}noo".as_bytes(),
            Limits::default(),
        )
        .unwrap();
        assert_eq!((header.width, header.height), (3, 2));
        let crash: &[u8] = b"YUV4MPEG2 H\0\0\x003 F30000:1 Ip A1:1 Cmono XF3 300YUV4MPEG2 W3 \xc5\x92noo XYSCSS=420J;PEG";
        assert!(parse_header(crash, Limits::default()).is_err());
    }

    use super::*;

    fn source(bytes: Vec<u8>) -> Result<Y4mSource, HostError> {
        Y4mSource::new(
            "t.y4m".into(),
            Box::new(std::io::Cursor::new(bytes)),
            None,
            Limits::default(),
        )
    }

    fn stream(header: &str, frames: &[&[u8]]) -> Vec<u8> {
        let mut out = format!("{header}\n").into_bytes();
        for f in frames {
            out.extend_from_slice(b"FRAME\n");
            out.extend_from_slice(f);
        }
        out
    }

    #[test]
    fn every_8bit_layout_keeps_only_y() {
        // 3x3 frames: chroma sizes differ per layout.
        let y: Vec<u8> = (1..=9).collect();
        for (c, extra) in [
            ("", 8),
            (" C420jpeg", 8),
            (" C420paldv", 8),
            (" C420mpeg2", 8),
            (" C420", 8),
            (" C422", 12),
            (" C411", 6),
            (" C444", 18),
            (" C444alpha", 27),
            (" Cmono", 0),
        ] {
            let frame: Vec<u8> = y.iter().copied().chain(vec![200; extra]).collect();
            let bytes = stream(
                &format!("YUV4MPEG2 W3 H3 F25:1 Ip A1:1{c} XYSCSS=420JPEG"),
                &[&frame, &frame],
            );
            let mut src = source(bytes).unwrap();
            assert_eq!(src.frame_rate(), Some((25, 1)));
            let a = src.next_frame().unwrap().unwrap();
            assert_eq!(a.gray.pixels, y, "{c}");
            assert_eq!(a.stem, "000000");
            assert_eq!(src.next_frame().unwrap().unwrap().stem, "000001");
            assert!(src.next_frame().unwrap().is_none(), "{c}");
            assert!(src.next_frame().unwrap().is_none(), "{c}");
        }
    }

    #[test]
    fn refuses_deep_samples_unknown_layouts_and_truncation() {
        for (c, needle) in [
            ("C420p10", "10-bit"),
            ("C444p12", "12-bit"),
            ("Cmono16", "16-bit"),
            ("Cxyz", "unknown Y4M colour space"),
        ] {
            let err = source(stream(&format!("YUV4MPEG2 W2 H2 {c}"), &[]))
                .err()
                .unwrap()
                .to_string();
            assert!(err.contains(needle) && err.starts_with("t.y4m: "), "{err}");
        }
        let err = source(b"YUV4MPEG2 W2\n".to_vec())
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("height"), "{err}");
        let mut src = source(stream("YUV4MPEG2 W2 H2 Cmono", &[&[1, 2, 3, 4], &[1, 2]])).unwrap();
        src.next_frame().unwrap();
        let err = src.next_frame().unwrap_err().to_string();
        assert!(
            err.contains("truncated: frame 1 has 2 of its 4 bytes"),
            "{err}"
        );
        let mut src =
            source(b"YUV4MPEG2 W2 H2 Cmono\nFRAME\n\x01\x02\x03\x04FRA".to_vec()).unwrap();
        src.next_frame().unwrap();
        assert!(
            src.next_frame()
                .unwrap_err()
                .to_string()
                .contains("frame 1")
        );
        let mut src = source(b"YUV4MPEG2 W1 H1 Cmono\nFRAME\n\x01GARBAGE\n".to_vec()).unwrap();
        src.next_frame().unwrap();
        assert!(
            src.next_frame()
                .unwrap_err()
                .to_string()
                .contains("expected a FRAME")
        );
    }
}

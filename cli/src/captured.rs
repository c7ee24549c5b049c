//! What a device produced, read back frame by frame for `reynoldsflow
//! verify`: exactly the formats `reynoldsflow run` writes, so a device's
//! capture is checked against `run`'s own bytes.
//!
//! | format | `run` writes it with | one frame |
//! |---|---|---|
//! | `rgb24` | `--out - --format rgb24` | `3·W·H` bytes, `R, G, B` per pixel, no header |
//! | `y4m` | `--out - --format y4m` | a `FRAME` line, then the `Y`, `Cb`, `Cr` planes of `W·H` bytes each (`C444`) |
//! | `png-dir` | `--out DIR` | `DIR/STEM.png`, RGB8; the folder's PNGs in natural order of their names |
//!
//! A Y4M capture is compared in YCbCr, as it stands: converting it back to
//! RGB would lose what `run`'s (lossy) conversion lost, and hide or invent
//! differences. The frame size always comes from the input, so a capture
//! of another size is refused before anything is compared.

use std::fs::File;
use std::io::{self, BufRead, BufReader};
use std::path::{Path, PathBuf};

use reynoldsflow_host::limits::Limits;
use reynoldsflow_host::sequence::{folder, input_error, peek, read_full, y4m};
use reynoldsflow_host::settings::Choice;
use reynoldsflow_host::{HostError, io::image_file};

/// The format of a capture (`--captured-format`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CapturedFormat {
    /// Raw RGB8 frames back to back, 3*W*H bytes each (run --out - --format rgb24).
    Rgb24,
    /// YUV4MPEG2 C444 (run --out - --format y4m), compared in YCbCr.
    Y4m,
    /// A folder of RGB8 PNGs in natural order of their names (run --out DIR).
    PngDir,
}

impl Choice for CapturedFormat {
    const ALL: &'static [Self] = &[Self::Rgb24, Self::Y4m, Self::PngDir];
    fn name(self) -> &'static str {
        match self {
            Self::Rgb24 => "rgb24",
            Self::Y4m => "y4m",
            Self::PngDir => "png-dir",
        }
    }
    fn help(self) -> &'static str {
        match self {
            Self::Rgb24 => {
                "Raw RGB8 frames back to back, 3*W*H bytes each (run --out - --format rgb24)"
            }
            Self::Y4m => "YUV4MPEG2 C444 (run --out - --format y4m), compared in YCbCr",
            Self::PngDir => "A folder of RGB8 PNGs in natural order of their names (run --out DIR)",
        }
    }
}

impl CapturedFormat {
    /// The format a path implies: a folder is `png-dir`, a `.y4m` file
    /// `y4m`, any other file `rgb24` (standard input is told by its first
    /// bytes instead, in [`Captured::open`]).
    pub fn of_path(path: &Path) -> Self {
        if path.is_dir() {
            CapturedFormat::PngDir
        } else if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("y4m"))
        {
            CapturedFormat::Y4m
        } else {
            CapturedFormat::Rgb24
        }
    }

    /// How its frames hold their bytes.
    pub fn layout(self) -> Layout {
        match self {
            CapturedFormat::Rgb24 | CapturedFormat::PngDir => Layout::Rgb,
            CapturedFormat::Y4m => Layout::Ycbcr444,
        }
    }
}

/// Where the bytes of a pixel are in a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// `R, G, B` of each pixel side by side.
    Rgb,
    /// Three planes, `Y` then `Cb` then `Cr`, one byte per pixel each.
    Ycbcr444,
}

impl Layout {
    /// The channels' names, in order.
    pub fn channels(self) -> [&'static str; 3] {
        match self {
            Layout::Rgb => ["R", "G", "B"],
            Layout::Ycbcr444 => ["Y", "Cb", "Cr"],
        }
    }

    /// The index of `channel` of pixel `pixel` in a frame of `pixels` pixels.
    pub fn index(self, pixel: usize, channel: usize, pixels: usize) -> usize {
        match self {
            Layout::Rgb => 3 * pixel + channel,
            Layout::Ycbcr444 => channel * pixels + pixel,
        }
    }
}

/// Where the frames come from.
enum Frames {
    /// A byte stream: raw RGB24, or Y4M past its header.
    Stream {
        reader: Box<dyn BufRead + Send>,
        y4m: bool,
    },
    /// PNG files, in frame order.
    Pngs(Vec<PathBuf>),
}

/// A capture, read one frame at a time.
pub struct Captured {
    name: PathBuf,
    format: CapturedFormat,
    width: usize,
    height: usize,
    frames: Frames,
    /// Frames read so far.
    read: usize,
    /// What a frame file's or the stream's header may state.
    limits: Limits,
}

impl Captured {
    /// Open `path` (`-`: standard input) as frames of `width × height`,
    /// in `format`, or the format the path implies. Fails, naming the
    /// capture, when it cannot be read in that format or holds frames of
    /// another size; no header over `limits` is believed.
    pub fn open(
        path: &Path,
        format: Option<CapturedFormat>,
        (width, height): (usize, usize),
        limits: Limits,
    ) -> Result<Self, HostError> {
        let stdin = path.as_os_str() == "-";
        let name = if stdin {
            PathBuf::from("stdin")
        } else {
            path.to_owned()
        };
        let mut reader: Box<dyn BufRead + Send> = if stdin {
            if format == Some(CapturedFormat::PngDir) {
                return Err(input_error(
                    &name,
                    "--captured-format png-dir reads a folder, not standard input",
                ));
            }
            Box::new(BufReader::new(io::stdin()))
        } else {
            if format == Some(CapturedFormat::PngDir) || path.is_dir() {
                return Self::open_dir(path, format, (width, height), limits);
            }
            let file = File::open(path).map_err(|e| HostError::io(path, e))?;
            Box::new(BufReader::new(file))
        };
        let format = match format {
            Some(f) => f,
            // Standard input has no name to go by: Y4M announces itself, as `run` reads it.
            None if stdin => match peek(&mut reader, &name)?.starts_with(y4m::MAGIC) {
                true => CapturedFormat::Y4m,
                false => CapturedFormat::Rgb24,
            },
            None => CapturedFormat::of_path(path),
        };
        let y4m = format == CapturedFormat::Y4m;
        if y4m {
            read_y4m_header(&mut *reader, &name, (width, height), limits)?;
        }
        Ok(Self {
            name,
            format,
            width,
            height,
            frames: Frames::Stream { reader, y4m },
            read: 0,
            limits,
        })
    }

    fn open_dir(
        path: &Path,
        format: Option<CapturedFormat>,
        (width, height): (usize, usize),
        limits: Limits,
    ) -> Result<Self, HostError> {
        match format {
            Some(CapturedFormat::PngDir) if !path.is_dir() => {
                if !path.exists() {
                    return Err(HostError::io(
                        path,
                        io::Error::from(io::ErrorKind::NotFound),
                    ));
                }
                return Err(input_error(
                    path,
                    "is not a folder; --captured-format png-dir reads a folder of PNGs (run --out DIR)",
                ));
            }
            Some(f @ (CapturedFormat::Rgb24 | CapturedFormat::Y4m)) => {
                return Err(input_error(
                    path,
                    format!(
                        "is a folder; --captured-format {} reads a file (a folder of PNGs is png-dir)",
                        f.name()
                    ),
                ));
            }
            _ => {}
        }
        let is_png = |name: &str| {
            Path::new(name)
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("png"))
        };
        // `run --out DIR` names its PNGs after the input's frames, which it
        // reads in natural order: the same order puts them back in frame order.
        let files = folder::list(path, is_png)?;
        Ok(Self {
            name: path.to_owned(),
            format: CapturedFormat::PngDir,
            width,
            height,
            frames: Frames::Pngs(files),
            read: 0,
            limits,
        })
    }

    /// The capture's name in messages (`stdin` for `-`).
    pub fn name(&self) -> &Path {
        &self.name
    }

    /// Its format.
    pub fn format(&self) -> CapturedFormat {
        self.format
    }

    /// Frames read so far.
    pub fn frames_read(&self) -> usize {
        self.read
    }

    /// The file of frame `index`, for a folder of PNGs.
    pub fn frame_file(&self, index: usize) -> Option<&Path> {
        match &self.frames {
            Frames::Pngs(files) => files.get(index).map(PathBuf::as_path),
            Frames::Stream { .. } => None,
        }
    }

    /// Bytes of one frame: three per pixel in every format.
    pub fn frame_bytes(&self) -> usize {
        3 * self.width * self.height
    }

    /// The next frame's bytes into `out` (in [`CapturedFormat::layout`]);
    /// `false` at the end of the capture. A frame cut short is an error
    /// naming the bytes it has and the bytes a frame needs.
    pub fn next_frame(&mut self, out: &mut Vec<u8>) -> Result<bool, HostError> {
        let (index, (w, h), frame_bytes) =
            (self.read, (self.width, self.height), self.frame_bytes());
        let read = match &mut self.frames {
            Frames::Pngs(files) => {
                let Some(file) = files.get(index) else {
                    return Ok(false);
                };
                let image = image_file::read_rgb8(file, self.limits)?;
                if (image.width, image.height) != (w, h) {
                    return Err(input_error(
                        file,
                        format!(
                            "frame {index} is {}x{}, but the input's frames are {w}x{h}",
                            image.width, image.height
                        ),
                    ));
                }
                *out = image.bytes;
                true
            }
            Frames::Stream { reader, y4m } => {
                let what = if *y4m { "C444 Y4M" } else { "rgb24" };
                if *y4m && !read_frame_line(&mut **reader, &self.name, index)? {
                    return Ok(false);
                }
                out.resize(frame_bytes, 0);
                let got =
                    read_full(&mut **reader, out).map_err(|e| HostError::io(&self.name, e))?;
                if got == 0 && !*y4m {
                    return Ok(false);
                }
                if got < frame_bytes {
                    return Err(input_error(
                        &self.name,
                        format!(
                            "truncated: frame {index} has {got} of its {frame_bytes} bytes \
                             (a {w}x{h} {what} frame is 3 x {w} x {h} bytes)"
                        ),
                    ));
                }
                true
            }
        };
        self.read += usize::from(read);
        Ok(read)
    }
}

/// Read and check the Y4M header: `C444` (what `run --format y4m` writes)
/// at the input's size. The frame rate, aspect and interlacing tags do not
/// touch the pixels and are not checked.
fn read_y4m_header(
    reader: &mut dyn BufRead,
    name: &Path,
    (width, height): (usize, usize),
    limits: Limits,
) -> Result<(), HostError> {
    let line = match y4m::read_line(reader) {
        Ok(Some(line)) => line,
        Ok(None) => return Err(input_error(name, "empty; expected a Y4M header")),
        Err(e) => return Err(input_error(name, e)),
    };
    let header = y4m::parse_header(&line, limits).map_err(|e| e.about(name))?;
    if header.chroma != "444" {
        return Err(input_error(
            name,
            format!(
                "the Y4M stream is C{}; run --format y4m writes C444, the only layout verify compares \
                 (subsampled chroma has lost the bytes to compare)",
                header.chroma
            ),
        ));
    }
    if (header.width, header.height) != (width, height) {
        return Err(input_error(
            name,
            format!(
                "its frames are {}x{}, but the input's are {width}x{height}",
                header.width, header.height
            ),
        ));
    }
    Ok(())
}

/// A Y4M frame's `FRAME` line (parameters after it allowed); `false` at a
/// clean end of the stream.
fn read_frame_line(reader: &mut dyn BufRead, name: &Path, index: usize) -> Result<bool, HostError> {
    let line = match y4m::read_line(reader) {
        Ok(Some(line)) => line,
        Ok(None) => return Ok(false),
        Err(e) => {
            return Err(input_error(
                name,
                format!("frame {index}: {e} (truncated?)"),
            ));
        }
    };
    if !line.starts_with(b"FRAME") {
        let shown = String::from_utf8_lossy(&line[..line.len().min(16)]).into_owned();
        return Err(input_error(
            name,
            format!(
                "frame {index}: expected a FRAME line, found {shown:?} (corrupt or truncated Y4M)"
            ),
        ));
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stream(bytes: &[u8], y4m: bool) -> Captured {
        Captured {
            name: "t".into(),
            format: if y4m {
                CapturedFormat::Y4m
            } else {
                CapturedFormat::Rgb24
            },
            width: 2,
            height: 1,
            frames: Frames::Stream {
                reader: Box::new(io::Cursor::new(bytes.to_vec())),
                y4m,
            },
            read: 0,
            limits: Limits::default(),
        }
    }

    #[test]
    fn raw_frames_then_a_truncation_naming_the_bytes() {
        let mut c = stream(&[1, 2, 3, 4, 5, 6, 7, 8], false);
        let mut out = Vec::new();
        assert!(c.next_frame(&mut out).unwrap());
        assert_eq!(out, [1, 2, 3, 4, 5, 6]);
        let err = c.next_frame(&mut out).unwrap_err().to_string();
        assert!(
            err.contains("truncated: frame 1 has 2 of its 6 bytes (a 2x1 rgb24 frame"),
            "{err}"
        );
        let mut c = stream(&[9; 6], false);
        assert!(c.next_frame(&mut out).unwrap());
        assert!(!c.next_frame(&mut out).unwrap());
        assert_eq!(c.frames_read(), 1);
    }

    #[test]
    fn y4m_frames_need_their_frame_line_and_whole_planes() {
        let mut c = stream(b"FRAME\nabcdefFRAME Ix\nab", true);
        let mut out = Vec::new();
        assert!(c.next_frame(&mut out).unwrap());
        assert_eq!(out, b"abcdef");
        let err = c.next_frame(&mut out).unwrap_err().to_string();
        assert!(err.contains("frame 1 has 2 of its 6 bytes"), "{err}");
        let err = stream(b"FROM\n", true).next_frame(&mut out).unwrap_err();
        assert!(err.to_string().contains("expected a FRAME line"), "{err}");
    }

    #[test]
    fn headers_must_be_c444_at_the_input_size() {
        let check = |h: &str| {
            read_y4m_header(
                &mut io::Cursor::new(h.as_bytes()),
                Path::new("c.y4m"),
                (2, 1),
                Limits::default(),
            )
            .map_err(|e| e.to_string())
        };
        assert!(check("YUV4MPEG2 W2 H1 F30:1 C444\n").is_ok());
        assert!(check("YUV4MPEG2 W2 H1\n").unwrap_err().contains("C420jpeg"));
        assert!(
            check("YUV4MPEG2 W4 H1 C444\n")
                .unwrap_err()
                .contains("its frames are 4x1, but the input's are 2x1")
        );
        assert!(check("").unwrap_err().contains("empty"));
    }

    #[test]
    fn layouts_place_channels() {
        assert_eq!(Layout::Rgb.index(2, 1, 10), 7);
        assert_eq!(Layout::Ycbcr444.index(2, 1, 10), 12);
        assert_eq!(
            CapturedFormat::of_path(Path::new("a.Y4M")),
            CapturedFormat::Y4m
        );
        assert_eq!(
            CapturedFormat::of_path(Path::new("a.rgb")),
            CapturedFormat::Rgb24
        );
    }
}

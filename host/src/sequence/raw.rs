//! Raw 8-bit gray frames back to back (`--raw WxH`): `W·H` bytes each, row
//! major, from standard input or a file. The input must end on a frame
//! boundary.

use std::io::Read;
use std::path::PathBuf;

use super::{Frame, FrameSource, index_stem, input_error, read_full};
use crate::limits::Limits;
use crate::settings::Setting;
use crate::{Gray, HostError};

/// Raw frames read from any reader.
pub struct RawSource {
    name: PathBuf,
    reader: Box<dyn Read + Send>,
    width: usize,
    height: usize,
    index: usize,
    count_hint: Option<usize>,
    /// The input's length when opened, when known (a file).
    total_bytes: Option<u64>,
    done: bool,
}

impl RawSource {
    /// Frames of `width × height` from `reader`, reported as `name`; a
    /// size over `limits` is refused.
    pub fn new(
        name: PathBuf,
        reader: Box<dyn Read + Send>,
        width: usize,
        height: usize,
        limits: Limits,
    ) -> Result<Self, HostError> {
        if width == 0 || height == 0 {
            return Err(HostError::setting(
                Setting::Raw,
                format!("{width}x{height} is not a usable frame size"),
            ));
        }
        limits
            .check_frame_size(width, height)
            .map_err(|e| e.about(name.display()))?;
        Ok(Self {
            name,
            reader,
            width,
            height,
            index: 0,
            count_hint: None,
            total_bytes: None,
            done: false,
        })
    }

    /// The input's length in bytes, for the frame count hint.
    pub fn set_total_bytes(&mut self, len: Option<u64>) {
        let frame = (self.width * self.height) as u64;
        self.count_hint = len.map(|l| (l / frame) as usize);
        self.total_bytes = len;
    }
}

impl FrameSource for RawSource {
    fn next_frame(&mut self) -> Result<Option<Frame>, HostError> {
        if self.done {
            return Ok(None);
        }
        let size = self.width * self.height;
        let mut pixels = vec![0u8; size];
        let got =
            read_full(&mut *self.reader, &mut pixels).map_err(|e| HostError::io(&self.name, e))?;
        if got == 0 {
            self.done = true;
            let read = (self.index * size) as u64;
            if let Some(len) = self.total_bytes.filter(|&len| read < len) {
                // A file cut at a frame boundary while being read: not a shorter input.
                return Err(input_error(
                    &self.name,
                    format!(
                        "the input ends after frame {} at byte {read}, but the file had {len} bytes when opened: it was truncated while being read",
                        self.index
                    ),
                ));
            }
            return Ok(None);
        }
        if got < size {
            self.done = true;
            // The input, or the frame size it was read with, is wrong.
            return Err(HostError::setting(
                Setting::Raw,
                format!(
                    "{}: truncated: the input ends {got} bytes into frame {} (a {}x{} frame is {size} bytes; is that frame size right?)",
                    self.name.display(),
                    self.index,
                    self.width,
                    self.height
                ),
            ));
        }
        let index = self.index;
        self.index += 1;
        Ok(Some(Frame {
            gray: Gray::new(self.width, self.height, pixels)?,
            stem: index_stem(index),
            index,
        }))
    }

    fn frame_count_hint(&self) -> Option<usize> {
        self.count_hint
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_frames_then_a_clear_truncation() {
        let bytes: Vec<u8> = (0..14).collect();
        let mut src = RawSource::new(
            "stdin".into(),
            Box::new(std::io::Cursor::new(bytes)),
            3,
            2,
            Limits::default(),
        )
        .unwrap();
        assert_eq!(
            src.next_frame().unwrap().unwrap().gray.pixels,
            [0, 1, 2, 3, 4, 5]
        );
        assert_eq!(src.next_frame().unwrap().unwrap().stem, "000001");
        let err = src.next_frame().unwrap_err().to_string();
        assert!(
            err.starts_with("raw: stdin: truncated: the input ends 2 bytes into frame 2"),
            "{err}"
        );
        assert!(src.next_frame().unwrap().is_none());
    }
}

//! A `sensor_msgs/Image` to the 8-bit gray frame the engine reads: `mono8`
//! as it is, the 8-bit colour encodings through the BT.601 luma that
//! `reynoldsflow run` applies to colour frames ([`luma_bt601`], SPEC §1).
//! Rows are read at the message's `step`, so padded rows work; a message
//! whose sizes do not add up is refused, never read out of bounds.

use std::fmt;

use reynoldsflow_core::MAX_SIDE;
use reynoldsflow_host::{Gray, luma_bt601};

use crate::msg::Image;

/// The encodings the node reads (names of sensor_msgs/image_encodings).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Encoding {
    /// 8-bit gray.
    Mono8,
    /// 8-bit R, G, B.
    Rgb8,
    /// 8-bit B, G, R (OpenCV's order, most USB camera drivers').
    Bgr8,
    /// 8-bit R, G, B, alpha.
    Rgba8,
    /// 8-bit B, G, R, alpha.
    Bgra8,
}

/// What the node says about each encoding it reads.
pub const ACCEPTED: &str = "mono8, rgb8, bgr8, rgba8 or bgra8";

impl Encoding {
    /// The encoding named `name`, if the node reads it.
    pub fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "mono8" => Self::Mono8,
            "rgb8" => Self::Rgb8,
            "bgr8" => Self::Bgr8,
            "rgba8" => Self::Rgba8,
            "bgra8" => Self::Bgra8,
            _ => return None,
        })
    }

    /// Its name on the wire.
    pub fn name(self) -> &'static str {
        match self {
            Self::Mono8 => "mono8",
            Self::Rgb8 => "rgb8",
            Self::Bgr8 => "bgr8",
            Self::Rgba8 => "rgba8",
            Self::Bgra8 => "bgra8",
        }
    }

    /// Bytes per pixel.
    fn bytes(self) -> usize {
        match self {
            Self::Mono8 => 1,
            Self::Rgb8 | Self::Bgr8 => 3,
            Self::Rgba8 | Self::Bgra8 => 4,
        }
    }
}

/// Why a message is not a frame. Each names what to fix on the publisher.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// An encoding the node does not read.
    Encoding(String),
    /// A side of 0, or beyond the engine's.
    Size {
        /// Columns.
        width: u32,
        /// Rows.
        height: u32,
    },
    /// Rows shorter than their pixels.
    Step {
        /// The message's step.
        step: u32,
        /// Bytes of one row's pixels.
        row_bytes: usize,
    },
    /// Fewer bytes than the rows need.
    Data {
        /// Bytes in the message.
        len: usize,
        /// Bytes the rows need.
        needed: usize,
    },
}

impl FrameError {
    /// A short key for rate-limited logging: the same problem once, not at
    /// every frame.
    pub fn kind(&self) -> String {
        match self {
            Self::Encoding(e) => format!("encoding {e}"),
            Self::Size { .. } => "size".into(),
            Self::Step { .. } => "step".into(),
            Self::Data { .. } => "data".into(),
        }
    }
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Encoding(e) => write!(
                f,
                "encoding '{e}' is not read; publish {ACCEPTED} (e.g. through image_proc or cv_bridge)"
            ),
            Self::Size { width, height } => write!(
                f,
                "a {width}x{height} image; each side must be 1 to {MAX_SIDE} px"
            ),
            Self::Step { step, row_bytes } => write!(
                f,
                "step {step} is shorter than a row's {row_bytes} bytes of pixels"
            ),
            Self::Data { len, needed } => {
                write!(f, "{len} bytes of data, {needed} needed for step x height")
            }
        }
    }
}

impl std::error::Error for FrameError {}

/// The frame of `image`, and its encoding.
pub fn gray(image: &Image) -> Result<(Gray, Encoding), FrameError> {
    let encoding = Encoding::parse(&image.encoding)
        .ok_or_else(|| FrameError::Encoding(image.encoding.clone()))?;
    let (width, height) = (image.width as usize, image.height as usize);
    if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
        return Err(FrameError::Size {
            width: image.width,
            height: image.height,
        });
    }
    let row_bytes = width * encoding.bytes();
    let step = image.step as usize;
    if step < row_bytes {
        return Err(FrameError::Step {
            step: image.step,
            row_bytes,
        });
    }
    // The last row needs its pixels only, not its padding.
    let needed = step * (height - 1) + row_bytes;
    if image.data.len() < needed {
        return Err(FrameError::Data {
            len: image.data.len(),
            needed,
        });
    }
    let mut pixels = Vec::with_capacity(width * height);
    let rows = image
        .data
        .chunks(step)
        .take(height)
        .map(|r| &r[..row_bytes]);
    // Byte offsets of R, G and B in a pixel.
    let (r, g, b) = match encoding {
        Encoding::Mono8 => {
            rows.for_each(|row| pixels.extend_from_slice(row));
            return Ok((gray_frame(width, height, pixels), encoding));
        }
        Encoding::Rgb8 | Encoding::Rgba8 => (0, 1, 2),
        Encoding::Bgr8 | Encoding::Bgra8 => (2, 1, 0),
    };
    let n = encoding.bytes();
    for row in rows {
        pixels.extend(row.chunks_exact(n).map(|p| luma_bt601(p[r], p[g], p[b])));
    }
    Ok((gray_frame(width, height, pixels), encoding))
}

fn gray_frame(width: usize, height: usize, pixels: Vec<u8>) -> Gray {
    Gray {
        width,
        height,
        pixels,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(encoding: &str, width: u32, height: u32, step: u32, data: Vec<u8>) -> Image {
        Image {
            encoding: encoding.into(),
            width,
            height,
            step,
            data,
            ..Image::default()
        }
    }

    #[test]
    fn mono8_is_read_as_it_is_at_its_step() {
        // 2x2 with one byte of padding per row.
        let msg = image("mono8", 2, 2, 3, vec![1, 2, 99, 3, 4]);
        let (g, e) = gray(&msg).unwrap();
        assert_eq!(e, Encoding::Mono8);
        assert_eq!((g.width, g.height, g.pixels), (2, 2, vec![1, 2, 3, 4]));
    }

    #[test]
    fn colour_is_the_luma_run_reads_from_a_png() {
        let rgb = [255u8, 0, 0, 10, 200, 30, 0, 0, 255];
        let reference = Gray::from_rgb8(3, 1, &rgb).unwrap().pixels;
        let bgr: Vec<u8> = rgb.chunks(3).flat_map(|p| [p[2], p[1], p[0]]).collect();
        let rgba: Vec<u8> = rgb.chunks(3).flat_map(|p| [p[0], p[1], p[2], 7]).collect();
        let bgra: Vec<u8> = rgb.chunks(3).flat_map(|p| [p[2], p[1], p[0], 7]).collect();
        for (name, data, n) in [
            ("rgb8", rgb.to_vec(), 3),
            ("bgr8", bgr, 3),
            ("rgba8", rgba, 4),
            ("bgra8", bgra, 4),
        ] {
            let (g, e) = gray(&image(name, 3, 1, 3 * n, data)).unwrap();
            assert_eq!(e.name(), name);
            assert_eq!(g.pixels, reference, "{name}");
        }
    }

    #[test]
    fn bad_messages_are_refused_with_what_to_fix() {
        let refuse = |msg: Image| gray(&msg).unwrap_err();
        let e = refuse(image("yuv422", 2, 2, 4, vec![0; 8]));
        assert_eq!(e, FrameError::Encoding("yuv422".into()));
        assert!(e.to_string().contains("'yuv422'"));
        assert!(matches!(
            refuse(image("mono8", 0, 2, 0, vec![])),
            FrameError::Size { .. }
        ));
        assert!(matches!(
            refuse(image("bgr8", 2, 2, 5, vec![0; 12])),
            FrameError::Step {
                step: 5,
                row_bytes: 6
            }
        ));
        assert_eq!(
            refuse(image("mono8", 4, 3, 5, vec![0; 13])),
            FrameError::Data {
                len: 13,
                needed: 14
            }
        );
        // The last row needs no padding.
        assert!(gray(&image("mono8", 4, 3, 5, vec![0; 14])).is_ok());
        let huge = u32::try_from(MAX_SIDE + 1).unwrap();
        assert!(matches!(
            refuse(image("mono8", huge, 1, huge, vec![])),
            FrameError::Size { .. }
        ));
    }
}

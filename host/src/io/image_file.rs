//! Image files: 8-bit PGM/PPM (binary or ASCII), PNG and JPEG in, as
//! [`Gray`] (colour through BT.601, alpha ignored); RGB8 PNG and JPEG out.
//!
//! Refused with a typed [`ImageProblem`]: samples wider than 8 bits, and
//! PNM files whose maxval is not 255 (their samples would need a rescale
//! the SPEC does not define). PNG files of 1, 2 or 4 bits and palette PNGs
//! are expanded to 8 bits as the PNG standard prescribes.

use std::fs;
use std::io::Cursor;
use std::path::Path;

use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::codecs::pnm::PnmDecoder;
use image::{
    DynamicImage, ExtendedColorType, ImageDecoder, ImageEncoder, ImageFormat, ImageReader,
};

use crate::limits::Limits;
use crate::settings::choices;
use crate::{Gray, HostError, ImageProblem, io::atomic, io::decoder_guard};

/// An RGB8 image, row-major, `3 · width · height` bytes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rgb8 {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `[R, G, B]` per pixel.
    pub bytes: Vec<u8>,
}

/// The container, from the file's first bytes (never its name).
fn sniff(bytes: &[u8]) -> Option<ImageFormat> {
    match bytes {
        [b'P', b'1'..=b'7', ..] => Some(ImageFormat::Pnm),
        [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n', ..] => Some(ImageFormat::Png),
        [0xff, 0xd8, 0xff, ..] => Some(ImageFormat::Jpeg),
        _ => None,
    }
}

fn decode_error(e: image::ImageError) -> ImageProblem {
    ImageProblem::Decode(e.to_string())
}

/// The decoder, if the size its header states is within `limits`.
fn within_limit<D: ImageDecoder>(decoder: D, limits: Limits) -> Result<D, ImageProblem> {
    let (w, h) = decoder.dimensions();
    limits
        .check_frame_size(w as usize, h as usize)
        .map_err(ImageProblem::TooLarge)?;
    Ok(decoder)
}

/// Decode any supported container into an image of 8-bit samples or fail.
/// The header's size is checked against the [`Limits`] before the pixels are
/// decoded, so a header claiming a huge image costs nothing.
fn decode(bytes: &[u8], limits: Limits) -> Result<DynamicImage, ImageProblem> {
    let format = sniff(bytes).ok_or(ImageProblem::UnknownFormat)?;
    let image = if format == ImageFormat::Pnm {
        let decoder = PnmDecoder::new(Cursor::new(bytes)).map_err(decode_error)?;
        let maxval = decoder.header().maximal_sample();
        if maxval != 255 {
            return Err(ImageProblem::Maxval { maxval });
        }
        DynamicImage::from_decoder(within_limit(decoder, limits)?).map_err(decode_error)?
    } else {
        // PNG and JPEG through their crates, whose panics on malformed
        // data are refusals too.
        decoder_guard::guarded(|| {
            let decoder = ImageReader::with_format(Cursor::new(bytes), format)
                .into_decoder()
                .map_err(decode_error)?;
            DynamicImage::from_decoder(within_limit(decoder, limits)?).map_err(decode_error)
        })
        .map_err(|panic| {
            ImageProblem::Decode(format!(
                "malformed {format:?} data (the decoder failed: {panic})"
            ))
        })??
    };
    match image {
        DynamicImage::ImageLuma8(_)
        | DynamicImage::ImageLumaA8(_)
        | DynamicImage::ImageRgb8(_)
        | DynamicImage::ImageRgba8(_) => Ok(image),
        DynamicImage::ImageLuma16(_)
        | DynamicImage::ImageLumaA16(_)
        | DynamicImage::ImageRgb16(_)
        | DynamicImage::ImageRgba16(_) => Err(ImageProblem::NotEightBit { bits: 16 }),
        DynamicImage::ImageRgb32F(_) | DynamicImage::ImageRgba32F(_) => {
            Err(ImageProblem::NotEightBit { bits: 32 })
        }
        other => Err(ImageProblem::Decode(format!(
            "unsupported pixel layout {:?}",
            other.color()
        ))),
    }
}

/// Decode an image file's bytes into a gray frame (SPEC §1).
pub fn decode_gray(bytes: &[u8], limits: Limits) -> Result<Gray, ImageProblem> {
    let image = decode(bytes, limits)?;
    let (width, height) = (image.width() as usize, image.height() as usize);
    let pixels: Vec<u8> = match image {
        DynamicImage::ImageLuma8(b) => b.into_raw(),
        DynamicImage::ImageLumaA8(b) => b.into_raw().chunks_exact(2).map(|p| p[0]).collect(),
        DynamicImage::ImageRgb8(b) => {
            return gray_or_empty(Gray::from_rgb8(width, height, b.as_raw()));
        }
        DynamicImage::ImageRgba8(b) => b
            .into_raw()
            .chunks_exact(4)
            .map(|p| crate::gray::luma_bt601(p[0], p[1], p[2]))
            .collect(),
        _ => unreachable!("decode() returns 8-bit layouts only"),
    };
    gray_or_empty(Gray::new(width, height, pixels))
}

fn gray_or_empty(gray: Result<Gray, HostError>) -> Result<Gray, ImageProblem> {
    gray.map_err(|_| ImageProblem::Decode("image has no pixels".into()))
}

/// Read an 8-bit image file as a gray frame.
pub fn read_gray(path: &Path, limits: Limits) -> Result<Gray, HostError> {
    let bytes = fs::read(path).map_err(|e| HostError::io(path, e))?;
    decode_gray(&bytes, limits).map_err(|problem| image_error(path, problem))
}

/// The error of refusing the image file `path`: one over the size limit
/// names the limit's setting ([`crate::limits::TooLarge::about`]).
fn image_error(path: &Path, problem: ImageProblem) -> HostError {
    match problem {
        ImageProblem::TooLarge(too_large) => too_large.about(path.display()),
        problem => HostError::Image {
            path: path.to_owned(),
            problem,
        },
    }
}

/// Read an RGB8 image file (a representation), exactly as stored; any
/// other pixel layout is refused.
pub fn read_rgb8(path: &Path, limits: Limits) -> Result<Rgb8, HostError> {
    let bytes = fs::read(path).map_err(|e| HostError::io(path, e))?;
    let refuse = |problem| image_error(path, problem);
    match decode(&bytes, limits).map_err(refuse)? {
        DynamicImage::ImageRgb8(b) => Ok(Rgb8 {
            width: b.width() as usize,
            height: b.height() as usize,
            bytes: b.into_raw(),
        }),
        other => Err(refuse(ImageProblem::Decode(format!(
            "expected RGB8, found {:?}",
            other.color()
        )))),
    }
}

/// How hard a PNG's DEFLATE works: smaller files against time, the pixels
/// the same at every setting (PNG is lossless).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PngCompression {
    /// fdeflate's PNG-tuned DEFLATE (the `png` crate's fast path), every
    /// row Paeth-filtered: at 640×480 an order of magnitude faster than
    /// `Default`, the files about as small (docs/PERFORMANCE.md,
    /// `scripts/bench-dataset`). On representations of real footage Paeth
    /// alone makes files as small as the adaptive choice per row, in 5–10 %
    /// less time.
    #[default]
    Fast,
    /// zlib's default level (flate2).
    Default,
    /// zlib's best level: the most time, files a few % smaller at most.
    Best,
}

choices!(PngCompression {
    Fast => "fast", "fdeflate's PNG-tuned DEFLATE: the fastest, files as small as zlib's default";
    Default => "default", "zlib's default level";
    Best => "best", "zlib's best level: the most time, files a few % smaller at most";
});

/// How a JPEG's chroma (Cb, Cr) is sampled against its luma (Y).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum JpegSubsampling {
    /// Chroma at full resolution: a pixel's three channels stay its own,
    /// which a representation whose channels mean different things
    /// (`[|v_d|, |v_c|, f]`) needs; what JPEGs were before this setting.
    #[default]
    S444,
    /// Chroma at half resolution both ways: about 2/3 the bytes and half
    /// the encoding time, colour edges (the channels' differences) blurred
    /// over 2×2 pixels.
    S420,
}

choices!(JpegSubsampling {
    S444 => "444", "chroma at full resolution: each pixel's channels stay its own";
    S420 => "420", "chroma at half resolution both ways: smaller, colour edges blurred";
});

/// The bytes of a PNG holding an RGB8 image, at the default compression
/// ([`PngCompression::Fast`]).
///
/// # Panics
/// If `rgb.len() != 3 · width · height`.
pub fn encode_png(width: usize, height: usize, rgb: &[u8]) -> Result<Vec<u8>, HostError> {
    encode_png_with(width, height, rgb, PngCompression::default())
}

/// [`encode_png`] at `compression`.
///
/// # Panics
/// If `rgb.len() != 3 · width · height`.
pub fn encode_png_with(
    width: usize,
    height: usize,
    rgb: &[u8],
    compression: PngCompression,
) -> Result<Vec<u8>, HostError> {
    assert_eq!(
        rgb.len(),
        3 * width * height,
        "rgb must hold 3 · width · height bytes"
    );
    let too_large =
        || HostError::invalid("image", format!("{width}x{height} is too large for PNG"));
    let (w, h) = (
        u32::try_from(width).map_err(|_| too_large())?,
        u32::try_from(height).map_err(|_| too_large())?,
    );
    let (level, filter) = match compression {
        PngCompression::Fast => (CompressionType::Fast, FilterType::Paeth),
        PngCompression::Default => (CompressionType::Default, FilterType::Adaptive),
        PngCompression::Best => (CompressionType::Best, FilterType::Adaptive),
    };
    let mut png = Vec::with_capacity(rgb.len() / 2);
    PngEncoder::new_with_quality(&mut png, level, filter)
        .write_image(rgb, w, h, ExtendedColorType::Rgb8)
        .map_err(|e| HostError::invalid("image", format!("cannot encode PNG: {e}")))?;
    Ok(png)
}

/// The bytes of a baseline JPEG of an RGB8 image at `quality` (1 to 100:
/// the IJG scaling of the standard tables, as libjpeg's and the `image`
/// crate's) with `subsampling`. The `jpeg-encoder` crate's scalar code (its
/// SIMD path rounds differently), so the same bytes on every target.
///
/// # Panics
/// If `rgb.len() != 3 · width · height`.
pub fn encode_jpeg(
    width: usize,
    height: usize,
    rgb: &[u8],
    quality: u8,
    subsampling: JpegSubsampling,
) -> Result<Vec<u8>, HostError> {
    assert_eq!(
        rgb.len(),
        3 * width * height,
        "rgb must hold 3 · width · height bytes"
    );
    let too_large = || {
        HostError::invalid(
            "image",
            format!("{width}x{height} is too large for JPEG (65535 a side)"),
        )
    };
    let side = |n: usize| u16::try_from(n).map_err(|_| too_large());
    let (w, h) = (side(width)?, side(height)?);
    let mut jpeg = Vec::with_capacity(rgb.len() / 4);
    let mut encoder = jpeg_encoder::Encoder::new(&mut jpeg, quality.clamp(1, 100));
    encoder.set_sampling_factor(match subsampling {
        JpegSubsampling::S444 => jpeg_encoder::SamplingFactor::R_4_4_4,
        JpegSubsampling::S420 => jpeg_encoder::SamplingFactor::R_4_2_0,
    });
    encoder
        .encode(rgb, w, h, jpeg_encoder::ColorType::Rgb)
        .map_err(|e| HostError::invalid("image", format!("cannot encode JPEG: {e}")))?;
    Ok(jpeg)
}

/// Write an RGB8 PNG atomically (see [`atomic`]).
pub fn write_png(path: &Path, width: usize, height: usize, rgb: &[u8]) -> Result<(), HostError> {
    atomic::write_file(path, &encode_png(width, height, rgb)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::{Choice, parse_choice};

    fn png(color: ExtendedColorType, w: u32, h: u32, data: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        PngEncoder::new(&mut out)
            .write_image(data, w, h, color)
            .unwrap();
        out
    }

    #[test]
    fn a_jpeg_that_panics_its_decoder_is_refused() {
        // Found by fuzzing: zune-jpeg 0.5.15 unwraps `None` in its AVX2 IDCT
        // on this file (on CPUs without AVX2 it may decode or fail plainly).
        let bytes = include_bytes!("../../tests/data/jpeg-decoder-panic.jpg");
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            let Err(ImageProblem::Decode(message)) = decode_gray(bytes, Limits::default()) else {
                panic!("decoded or refused otherwise");
            };
            assert!(
                message.starts_with("malformed Jpeg data (the decoder failed: "),
                "{message}"
            );
        }
        match decode_gray(bytes, Limits::default()) {
            Ok(gray) => assert_eq!(gray.pixels.len(), gray.width * gray.height),
            Err(ImageProblem::Decode(_)) => {}
            Err(other) => panic!("unexpected error: {other}"),
        }
    }

    #[test]
    fn reads_pgm_binary_and_ascii() {
        let p5 = [b"P5\n# a comment\n3 1\n255\n".as_slice(), &[0, 128, 255]].concat();
        assert_eq!(
            decode_gray(&p5, Limits::default()).unwrap(),
            Gray::new(3, 1, vec![0, 128, 255]).unwrap()
        );
        let p2 = b"P2 2 2 255\n 1 2\n 3 255\n";
        assert_eq!(
            decode_gray(p2, Limits::default()).unwrap(),
            Gray::new(2, 2, vec![1, 2, 3, 255]).unwrap()
        );
    }

    #[test]
    fn colour_goes_through_bt601_and_alpha_is_ignored() {
        let rgb = png(ExtendedColorType::Rgb8, 2, 1, &[255, 0, 0, 0, 0, 255]);
        assert_eq!(
            decode_gray(&rgb, Limits::default()).unwrap().pixels,
            vec![76, 29]
        );
        let rgba = png(
            ExtendedColorType::Rgba8,
            2,
            1,
            &[255, 0, 0, 0, 0, 0, 255, 7],
        );
        assert_eq!(
            decode_gray(&rgba, Limits::default()).unwrap().pixels,
            vec![76, 29]
        );
        let la = png(ExtendedColorType::La8, 2, 1, &[9, 0, 200, 255]);
        assert_eq!(
            decode_gray(&la, Limits::default()).unwrap().pixels,
            vec![9, 200]
        );
        let ppm = [b"P6 1 1 255\n".as_slice(), &[0, 255, 0]].concat();
        assert_eq!(
            decode_gray(&ppm, Limits::default()).unwrap().pixels,
            vec![150]
        );
    }

    #[test]
    fn refuses_wide_samples_other_maxvals_and_unknown_data() {
        let l16 = png(ExtendedColorType::L16, 1, 1, &[1, 2]);
        assert_eq!(
            decode_gray(&l16, Limits::default()),
            Err(ImageProblem::NotEightBit { bits: 16 })
        );
        let p5_16 = [b"P5 1 1 65535\n".as_slice(), &[1, 2]].concat();
        assert_eq!(
            decode_gray(&p5_16, Limits::default()),
            Err(ImageProblem::Maxval { maxval: 65535 })
        );
        let p2_15 = b"P2 1 1 15\n7\n";
        assert_eq!(
            decode_gray(p2_15, Limits::default()),
            Err(ImageProblem::Maxval { maxval: 15 })
        );
        assert_eq!(
            decode_gray(b"hello world", Limits::default()),
            Err(ImageProblem::UnknownFormat)
        );
        assert!(matches!(
            decode_gray(b"P5 4 4 255\n\x01\x02", Limits::default()),
            Err(ImageProblem::Decode(_))
        ));
        assert!(matches!(
            decode_gray(&[0xff, 0xd8, 0xff, 0], Limits::default()),
            Err(ImageProblem::Decode(_))
        ));
    }

    #[test]
    fn reads_gray_and_colour_jpeg() {
        use image::codecs::jpeg::JpegEncoder;
        let jpeg = |color, data: &[u8]| {
            let mut out = Vec::new();
            JpegEncoder::new_with_quality(&mut out, 100)
                .write_image(data, 8, 8, color)
                .unwrap();
            out
        };
        let gray =
            decode_gray(&jpeg(ExtendedColorType::L8, &[200; 64]), Limits::default()).unwrap();
        assert_eq!(gray.size(), (8, 8));
        assert!(
            gray.pixels.iter().all(|&p| p.abs_diff(200) <= 1),
            "{:?}",
            gray.pixels
        );
        // Pure green, lossy: luma near 150.
        let green: Vec<u8> = (0..64).flat_map(|_| [0, 255, 0]).collect();
        let gray = decode_gray(&jpeg(ExtendedColorType::Rgb8, &green), Limits::default()).unwrap();
        assert!(
            gray.pixels.iter().all(|&p| p.abs_diff(150) <= 3),
            "{:?}",
            gray.pixels
        );
    }

    /// A 97×61 RGB8 image of smooth ramps, flat areas and noise: every
    /// PNG row filter and DEFLATE path gets used.
    fn textured_rgb() -> (usize, usize, Vec<u8>) {
        let (w, h) = (97, 61);
        let mut state = 7u32;
        let rgb = (0..w * h)
            .flat_map(|i| {
                let (x, y) = (i % w, i / w);
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let noise = (state >> 24) as u8;
                [
                    (x * 2) as u8,
                    if y < 30 { 90 } else { noise },
                    (x ^ y) as u8,
                ]
            })
            .collect();
        (w, h, rgb)
    }

    #[test]
    fn png_is_lossless_at_every_compression_and_the_settings_differ() {
        let (w, h, rgb) = textured_rgb();
        let mut sizes = Vec::new();
        for &compression in PngCompression::ALL {
            let png = encode_png_with(w, h, &rgb, compression).unwrap();
            let decoded = image::load_from_memory(&png).unwrap();
            assert_eq!(decoded.as_rgb8().unwrap().as_raw(), &rgb, "{compression:?}");
            sizes.push(png.len());
        }
        assert_ne!(sizes[0], sizes[1], "fast and default are other encoders");
        assert_eq!(
            encode_png(w, h, &rgb).unwrap(),
            encode_png_with(w, h, &rgb, PngCompression::Fast).unwrap()
        );
    }

    /// The quantization tables (DQT segments) of a JPEG, in file order.
    fn dqt(jpeg: &[u8]) -> Vec<Vec<u8>> {
        let mut tables = Vec::new();
        let mut at = 2;
        while at + 4 <= jpeg.len() && jpeg[at] == 0xff && jpeg[at + 1] != 0xda {
            let len = usize::from(u16::from_be_bytes([jpeg[at + 2], jpeg[at + 3]]));
            if jpeg[at + 1] == 0xdb {
                // One or more tables of 1 + 64 bytes (8-bit precision).
                tables.extend(jpeg[at + 4..at + 2 + len].chunks(65).map(<[u8]>::to_vec));
            }
            at += 2 + len;
        }
        tables
    }

    #[test]
    fn jpeg_quality_means_what_it_meant_and_both_samplings_decode() {
        let (w, h, rgb) = textured_rgb();
        for quality in [10, 50, 95, 100] {
            // The tables of the `image` crate's encoder, which wrote
            // --image-format jpg before: the IJG scaling of Annex K's.
            let mut before = Vec::new();
            image::codecs::jpeg::JpegEncoder::new_with_quality(&mut before, quality)
                .write_image(&rgb, w as u32, h as u32, ExtendedColorType::Rgb8)
                .unwrap();
            assert_eq!(dqt(&before).len(), 2, "luma and chroma tables");
            for &subsampling in JpegSubsampling::ALL {
                let jpeg = encode_jpeg(w, h, &rgb, quality, subsampling).unwrap();
                assert_eq!(dqt(&jpeg), dqt(&before), "q{quality} {subsampling:?}");
                let decoded = image::load_from_memory(&jpeg).unwrap().to_rgb8();
                assert_eq!(decoded.dimensions(), (w as u32, h as u32));
            }
        }
        assert_eq!(
            parse_choice::<JpegSubsampling>("420"),
            Ok(JpegSubsampling::S420)
        );
        assert!(
            parse_choice::<JpegSubsampling>("422")
                .unwrap_err()
                .contains("444, 420")
        );
        assert_eq!(parse_choice("best"), Ok(PngCompression::Best));
    }

    #[test]
    fn png_round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("rep.png");
        let rgb: Vec<u8> = (0..2 * 3 * 3).map(|i| (i * 14) as u8).collect();
        write_png(&path, 3, 2, &rgb).unwrap();
        assert_eq!(
            read_rgb8(&path, Limits::default()).unwrap(),
            Rgb8 {
                width: 3,
                height: 2,
                bytes: rgb
            }
        );
    }
}

//! What `reynoldsflow run` and `dataset` write for each result, and where.
//!
//! In an output folder `DIR`, the result labelled with frame `STEM` is
//!
//! | file | with | content |
//! |---|---|---|
//! | `DIR/STEM.png` | (default; `--no-rep` drops it) | RGB8 image of the `--variant` ([`Variant`]) |
//! | `DIR/hsv/STEM.png` | `--viz` | colour-wheel coding of `v_R` (`crate::engine::viz`) |
//! | `DIR/v_c/STEM.npy`, `DIR/v_d/STEM.npy`, `DIR/v_R/STEM.npy` | `--npy` (or `--npy=v_R,…`) | float64 (or `--npy-dtype f32`/`f16`: rounded to nearest), shape `(H, W, 2)`, C order, last axis `(x, y)` in pixels (x right, y down) |
//! | `DIR/v_R/STEM.flo` (or `v_c/`, `v_d/`) | `--flo` (or `--flo=v_c,…`) | Middlebury `.flo` ([`flo`]): `f32` `(u, v)` |
//!
//! PNGs are compressed as `--png-compression` says ([`PngCompression`]).
//! With `--image-format jpg` the images are `STEM.jpg` (baseline JPEG of
//! `--jpeg-quality` and `--jpeg-subsampling`, [`JpegSubsampling`]), not PNGs.
//!
//! so every kind of output of one frame has the same stem, in a folder of
//! its own. Each file is written to a hidden temp name in its folder
//! (`.rfXXXXXX.tmp`, short whatever the name) and renamed into place when complete: a file
//! under its final name is never partial. Temp files left by a killed run
//! are removed by the next run into the same folder ([`clean_stale_temps`]).
//!
//! Or, with `--out -`, the `--variant` images go to standard output
//! ([`StreamFormat`]).

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use npyz::WriterBuilder;

use crate::engine::Image;
use crate::engine::page_buffer::ByteBuffer;
pub use crate::io::image_file::{JpegSubsampling, PngCompression};
use crate::settings::choices;
use crate::{HostError, io::atomic, io::image_file};
use background::Stage;

mod background;
#[cfg(feature = "crash-injection")]
pub mod crash_injection;
pub mod flo;

pub use crate::engine::PairFields;
pub use crate::settings::Variant;

/// A field written by `--npy` and `--flo`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Field {
    /// Curl-free field `v_c`.
    VC,
    /// Divergence-free field `v_d`.
    VD,
    /// ReynoldsFlow `v_R = v_c + v_d`.
    VR,
}

impl Field {
    /// The name on the command line, and of its output folder.
    pub fn name(self) -> &'static str {
        match self {
            Field::VC => "v_c",
            Field::VD => "v_d",
            Field::VR => "v_R",
        }
    }
}

/// `--npy-dtype`: the element type of `.npy` fields.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NpyDtype {
    /// IEEE binary16 (`<f2`), each float64 value rounded to nearest (ties to even).
    F16,
    /// IEEE binary32 (`<f4`), each value rounded to nearest (ties to even).
    F32,
    /// IEEE binary64 (`<f8`): the values as computed.
    #[default]
    F64,
}

choices!(NpyDtype {
    F16 => "f16", "IEEE binary16 (<f2), each float64 value rounded to nearest (ties to even)";
    F32 => "f32", "IEEE binary32 (<f4), each value rounded to nearest (ties to even)";
    F64 => "f64", "IEEE binary64 (<f8): the values as computed";
});

/// `--image-format`: how images are stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// PNG, lossless (`STEM.png`).
    Png {
        /// How hard its DEFLATE works (`--png-compression`).
        compression: PngCompression,
    },
    /// Baseline JPEG of this quality, 1 to 100 (`STEM.jpg`), lossy.
    Jpeg {
        /// The encoder's quality, 1 to 100.
        quality: u8,
        /// The chroma sampling (`--jpeg-subsampling`).
        subsampling: JpegSubsampling,
    },
}

impl Default for ImageFormat {
    fn default() -> Self {
        ImageFormat::Png {
            compression: PngCompression::default(),
        }
    }
}

/// `--image-format`'s names on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormatName {
    /// Lossless PNG (the default).
    Png,
    /// Lossy JPEG (--jpeg-quality).
    Jpg,
}

choices!(ImageFormatName {
    Png => "png", "Lossless PNG (the default)";
    Jpg => "jpg", "Lossy JPEG, at the JPEG quality set";
});

/// The JPEG quality when `--jpeg-quality` is not given.
pub const DEFAULT_JPEG_QUALITY: u8 = 95;

impl ImageFormat {
    /// The file extension.
    pub fn extension(self) -> &'static str {
        match self {
            ImageFormat::Png { .. } => "png",
            ImageFormat::Jpeg { .. } => "jpg",
        }
    }

    /// An RGB8 image of `width × height` in this format.
    pub fn encode(self, width: usize, height: usize, rgb: &[u8]) -> Result<Vec<u8>, HostError> {
        match self {
            ImageFormat::Png { compression } => {
                image_file::encode_png_with(width, height, rgb, compression)
            }
            ImageFormat::Jpeg {
                quality,
                subsampling,
            } => image_file::encode_jpeg(width, height, rgb, quality, subsampling),
        }
    }
}

/// A list of fields, as `--npy=v_c,v_R` gives it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Fields(pub Vec<Field>);

/// Parse a comma-separated list of `v_c`, `v_d`, `v_R` (sorted, no repeats).
pub fn parse_field_list(s: &str) -> Result<Fields, String> {
    parse_fields(s).map(Fields)
}

/// Parse a comma-separated list of `v_c`, `v_d`, `v_R` (sorted, no repeats).
pub fn parse_fields(s: &str) -> Result<Vec<Field>, String> {
    let mut fields = Vec::new();
    for part in s.split(',').map(str::trim) {
        let field = match part {
            "v_c" => Field::VC,
            "v_d" => Field::VD,
            "v_R" | "v_r" => Field::VR,
            _ => {
                return Err(format!(
                    "'{part}' is not a field; expected v_c, v_d or v_R (comma-separated)"
                ));
            }
        };
        fields.push(field);
    }
    fields.sort();
    fields.dedup();
    Ok(fields)
}

impl PairFields {
    /// The `(x, y)` planes of a field.
    pub fn field(&self, field: Field) -> (Vec<f64>, Vec<f64>) {
        let p = &self.planes;
        match field {
            Field::VC => (p.v_c.u.clone(), p.v_c.v.clone()),
            Field::VD => (p.v_d.u.clone(), p.v_d.v.clone()),
            Field::VR => {
                let v_r = p.v_r();
                (v_r.u, v_r.v)
            }
        }
    }
}

/// What to write per result.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputSpec {
    /// The image `DIR/STEM.png` (and the stream) shows.
    pub variant: Variant,
    /// Write `DIR/STEM.png`.
    pub rep: bool,
    /// Write `DIR/hsv/STEM.png`.
    pub viz: bool,
    /// Fields written as `.npy`.
    pub npy: Vec<Field>,
    /// Fields written as `.flo`.
    pub flo: Vec<Field>,
    /// Colour-wheel radius in pixels; `None`: each frame's longest vector.
    pub hsv_max: Option<f64>,
    /// The element type of the `.npy` fields.
    pub npy_dtype: NpyDtype,
    /// How the images are stored.
    pub image_format: ImageFormat,
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self {
            variant: Variant::Dc,
            rep: true,
            viz: false,
            npy: Vec::new(),
            flo: Vec::new(),
            hsv_max: None,
            npy_dtype: NpyDtype::F64,
            image_format: ImageFormat::default(),
        }
    }
}

impl OutputSpec {
    /// Whether anything at all is written.
    pub fn writes_anything(&self) -> bool {
        self.rep || self.viz || !self.npy.is_empty() || !self.flo.is_empty()
    }

    /// Whether the `--variant` images are all that is written (what a
    /// stream carries, and what `verify` compares).
    pub fn images_only(&self) -> bool {
        self.rep && !self.viz && self.npy.is_empty() && self.flo.is_empty()
    }

    /// Whether the `--variant` image is made from the fields (the colour
    /// wheel) rather than from the representation's bytes alone.
    pub fn image_needs_fields(&self) -> bool {
        self.shown().needs_fields()
    }

    /// Whether any output of a result needs the fields, not only the
    /// representation's bytes (which can be computed without them).
    pub fn needs_fields(&self) -> bool {
        (self.rep && self.image_needs_fields())
            || self.viz
            || !self.npy.is_empty()
            || !self.flo.is_empty()
    }

    /// The RGB8 image of the `--variant`.
    pub fn image(&self, f: &PairFields) -> Vec<u8> {
        self.shown().of(f)
    }

    /// Turn the representation `[|v_d|, |v_c|, f]` into the `--variant`'s
    /// image in place ([`Image::arrange`]).
    pub fn arrange(&self, rgb: &mut [u8]) {
        self.shown().arrange(rgb);
    }

    /// The colour wheel (`DIR/hsv/`), whatever the `--variant`.
    fn wheel(&self) -> Image {
        Image {
            variant: Variant::Hsv,
            hsv_max: self.hsv_max,
        }
    }

    /// The image the `--variant` shows.
    pub fn shown(&self) -> Image {
        Image {
            variant: self.variant,
            hsv_max: self.hsv_max,
        }
    }

    /// Sub-folders of the output folder this spec writes into.
    pub fn subdirs(&self) -> Vec<&'static str> {
        let mut dirs = Vec::new();
        if self.viz {
            dirs.push("hsv");
        }
        for f in [Field::VC, Field::VD, Field::VR] {
            if self.npy.contains(&f) || self.flo.contains(&f) {
                dirs.push(f.name());
            }
        }
        dirs
    }

    /// Every file of one result: `(path relative to the output folder, bytes)`.
    pub fn files(&self, stem: &str, f: &PairFields) -> Result<Vec<(PathBuf, Vec<u8>)>, HostError> {
        let (w, h) = (f.planes.width(), f.planes.height());
        let mut files = Vec::new();
        if self.rep {
            files.push(self.image_file(stem, w, h, &self.image(f))?);
        }
        if self.viz {
            let image = self.image_format.encode(w, h, &self.wheel().of(f))?;
            let name = format!("{stem}.{}", self.image_format.extension());
            files.push((Path::new("hsv").join(name), image));
        }
        for field in [Field::VC, Field::VD, Field::VR] {
            let (npy, flo) = (self.npy.contains(&field), self.flo.contains(&field));
            if !(npy || flo) {
                continue;
            }
            let (x, y) = f.field(field);
            let dir = Path::new(field.name());
            if npy {
                let npy = encode_npy_xy_as(self.npy_dtype, h, w, &x, &y);
                files.push((dir.join(format!("{stem}.npy")), npy));
            }
            if flo {
                files.push((dir.join(format!("{stem}.flo")), flo::encode(w, h, &x, &y)?));
            }
        }
        Ok(files)
    }

    /// The options as one canonical line (for dataset completion markers):
    /// the types of `--npy-dtype` and `--image-format` appear only when
    /// they are not the defaults, so markers made before them still match.
    pub fn describe(&self) -> String {
        let list = |v: &[Field]| v.iter().map(|f| f.name()).collect::<Vec<_>>().join(",");
        let mut line = format!(
            "variant={} rep={} viz={} npy=[{}] flo=[{}] hsv_max={:?}",
            self.variant.name(),
            self.rep,
            self.viz,
            list(&self.npy),
            list(&self.flo),
            self.hsv_max
        );
        if self.npy_dtype != NpyDtype::F64 {
            line += &format!(" npy_dtype={}", self.npy_dtype.name());
        }
        match self.image_format {
            ImageFormat::Png { compression } if compression != PngCompression::default() => {
                line += &format!(" png={}", compression.name());
            }
            ImageFormat::Png { .. } => {}
            ImageFormat::Jpeg {
                quality,
                subsampling,
            } => {
                line += &format!(" image=jpg:{quality}");
                if subsampling != JpegSubsampling::default() {
                    line += &format!(":{}", subsampling.name());
                }
            }
        }
        line
    }

    /// The file `STEM.png` (or `.jpg`) of the `--variant` image.
    fn image_file(
        &self,
        stem: &str,
        width: usize,
        height: usize,
        image: &[u8],
    ) -> Result<(PathBuf, Vec<u8>), HostError> {
        let bytes = self.image_format.encode(width, height, image)?;
        let name = format!("{stem}.{}", self.image_format.extension());
        Ok((PathBuf::from(name), bytes))
    }
}

/// A `.npy` of shape `(height, width, 2)`, float64, C order: `[..., 0]` is
/// `x`, `[..., 1]` is `y`.
pub fn encode_npy_xy(height: usize, width: usize, x: &[f64], y: &[f64]) -> Vec<u8> {
    encode_npy_xy_as(NpyDtype::F64, height, width, x, y)
}

/// [`encode_npy_xy`] with elements of `dtype`, each value rounded to
/// nearest (ties to even) from float64.
pub fn encode_npy_xy_as(
    dtype: NpyDtype,
    height: usize,
    width: usize,
    x: &[f64],
    y: &[f64],
) -> Vec<u8> {
    assert!(
        x.len() == height * width && y.len() == height * width,
        "plane size"
    );
    let values = x.iter().zip(y).flat_map(|(a, b)| [*a, *b]);
    let shape = [height as u64, width as u64, 2];
    match dtype {
        NpyDtype::F64 => npy_bytes(&shape, values),
        // `as` rounds to nearest, ties to even.
        NpyDtype::F32 => npy_bytes(&shape, values.map(|v| v as f32)),
        // Directly from f64 (not through f32, which would round twice).
        NpyDtype::F16 => npy_bytes(&shape, values.map(half::f16::from_f64)),
    }
}

/// A C-order `.npy` of `shape` holding `values`, in NumPy's default dtype
/// for `T` (little-endian).
fn npy_bytes<T: npyz::Serialize + npyz::AutoSerialize>(
    shape: &[u64],
    values: impl Iterator<Item = T>,
) -> Vec<u8> {
    let count: u64 = shape.iter().product();
    let mut bytes = Vec::with_capacity(128 + std::mem::size_of::<T>() * count as usize);
    let mut writer = npyz::WriteOptions::<T>::new()
        .default_dtype()
        .shape(shape)
        .writer(&mut bytes)
        .begin_nd()
        .expect("writing to memory");
    writer.extend(values).expect("writing to memory");
    writer.finish().expect("writing to memory");
    bytes
}

/// Parse a `.npy` of shape `(H, W, 2)` float64: `(H, W, x plane, y plane)`.
pub fn decode_npy_xy(bytes: &[u8]) -> Result<(usize, usize, Vec<f64>, Vec<f64>), String> {
    let npy = crate::io::npy::open(bytes)?;
    let [h, w, 2] = *npy.shape() else {
        return Err(format!("shape {:?} is not (H, W, 2)", npy.shape()));
    };
    if npy.order() != npyz::Order::C {
        return Err("Fortran order".to_owned());
    }
    let values = npy
        .into_vec::<f64>()
        .map_err(|e| format!("not float64: {e}"))?;
    let x = values.iter().step_by(2).copied().collect();
    let y = values.iter().skip(1).step_by(2).copied().collect();
    Ok((h as usize, w as usize, x, y))
}

/// `--format` of `--out -`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StreamFormat {
    /// Raw RGB8 frames back to back, 3*W*H bytes each, no header.
    #[default]
    Rgb24,
    /// YUV4MPEG2 C444 with the input's frame rate; BT.601 limited range
    /// (lossy: RGB becomes YCbCr).
    Y4m,
}

choices!(StreamFormat {
    Rgb24 => "rgb24", "Raw RGB8 frames back to back, 3*W*H bytes each, no header";
    Y4m => "y4m", "YUV4MPEG2 C444 with the input's frame rate; BT.601 limited range (lossy: RGB becomes YCbCr)";
});

/// The Y4M stream header for `w × h` frames at `fps`.
pub fn y4m_header(width: usize, height: usize, fps: (u32, u32)) -> String {
    format!(
        "YUV4MPEG2 W{width} H{height} F{}:{} Ip A1:1 C444\n",
        fps.0, fps.1
    )
}

/// A Y4M `C444` frame (`FRAME` line and the Y, Cb, Cr planes) of an RGB8
/// image, BT.601 limited range in integer arithmetic:
/// `Y = 16 + (66R + 129G + 25B + 128) >> 8`,
/// `Cb = 128 + (−38R − 74G + 112B + 128) >> 8`,
/// `Cr = 128 + (112R − 94G − 18B + 128) >> 8`.
pub fn y4m_frame(rgb: &[u8]) -> Vec<u8> {
    let mut out = vec![0; 6 + 3 * (rgb.len() / 3)];
    y4m_frame_write(rgb, &mut out);
    out
}

/// [`y4m_frame`] into `out` (its whole length), reusing its memory. Fails
/// only when the system refuses the memory.
pub fn y4m_frame_into(rgb: &[u8], out: &mut impl ByteBuffer) -> Result<(), HostError> {
    y4m_frame_write(rgb, out.overwrite(6 + 3 * (rgb.len() / 3))?);
    Ok(())
}

/// [`y4m_frame`] into `out`, exactly its length.
fn y4m_frame_write(rgb: &[u8], out: &mut [u8]) {
    let n = rgb.len() / 3;
    let (header, planes_out) = out.split_at_mut(6.min(out.len()));
    header.copy_from_slice(b"FRAME\n");
    let planes: [fn(i32, i32, i32) -> i32; 3] = [
        |r, g, b| 16 + ((66 * r + 129 * g + 25 * b + 128) >> 8),
        |r, g, b| 128 + ((-38 * r - 74 * g + 112 * b + 128) >> 8),
        |r, g, b| 128 + ((112 * r - 94 * g - 18 * b + 128) >> 8),
    ];
    for (plane, out) in planes
        .into_iter()
        .zip(planes_out.chunks_exact_mut(n.max(1)))
    {
        for (o, p) in out.iter_mut().zip(rgb.chunks_exact(3)) {
            *o = plane(i32::from(p[0]), i32::from(p[1]), i32::from(p[2])).clamp(0, 255) as u8;
        }
    }
}

/// The threads of a [`DirWriter::in_background`] of `run` and `dataset`:
/// two, so that one result's files are flushed to disk while the next
/// one's are encoded (a flush costs some milliseconds, as long as the
/// engine's pair at 640×480).
pub const WRITER_THREADS: usize = 2;

/// Writes results into an output folder: in the caller's thread, or
/// ([`DirWriter::in_background`]) encoded and written by threads of its own.
#[derive(Debug)]
pub struct DirWriter {
    folder: Arc<Folder>,
    background: Option<Stage<Output>>,
}

/// The output folder and what goes into it, shared with the writer threads.
#[derive(Debug)]
struct Folder {
    root: PathBuf,
    spec: OutputSpec,
    /// Each file written ([`DirWriter::recording`]).
    written: Option<Mutex<Vec<Written>>>,
}

/// A file a [`DirWriter::recording`] wrote.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Written {
    /// Relative to the output folder, `/`-separated.
    pub path: String,
    /// Bytes.
    pub size: u64,
    /// XXH3-128 of the bytes, hex ([`crate::io::content_hash::hash_bytes`]).
    pub hash: String,
}

/// One result for the writer threads to encode and write.
enum Output {
    Fields(String, PairFields),
    Image(String, usize, usize, Vec<u8>),
}

impl DirWriter {
    /// Create `root` and the spec's sub-folders, and remove temp files a
    /// killed run left there. Fails, naming the folder, when it cannot be
    /// created or written.
    pub fn prepare(root: &Path, spec: &OutputSpec) -> Result<Self, HostError> {
        let not_writable = |path: &Path, e: std::io::Error| {
            HostError::io(
                path,
                std::io::Error::new(e.kind(), format!("output folder not writable: {e}")),
            )
        };
        if root.exists() && !root.is_dir() {
            return Err(crate::sequence::input_error(
                root,
                "output exists and is not a folder",
            ));
        }
        fs::create_dir_all(root).map_err(|e| not_writable(root, e))?;
        for sub in spec.subdirs() {
            let dir = root.join(sub);
            fs::create_dir_all(&dir).map_err(|e| not_writable(&dir, e))?;
        }
        // Probe: a folder that exists but refuses new files fails now, not mid-run.
        tempfile::Builder::new()
            .prefix(".reynoldsflow-probe.")
            .tempfile_in(root)
            .map_err(|e| not_writable(root, e))?;
        // Every side folder, asked for now or not: a run killed with other
        // flags leaves its temps there too.
        for sub in ["", "hsv", "v_c", "v_d", "v_R"] {
            clean_stale_temps(&root.join(sub))?;
        }
        Ok(Self {
            folder: Arc::new(Folder {
                root: root.to_owned(),
                spec: spec.clone(),
                written: None,
            }),
            background: None,
        })
    }

    /// Keep the path and size of every file written, for [`Self::written`].
    /// Before [`Self::in_background`].
    pub fn recording(mut self) -> Self {
        Arc::get_mut(&mut self.folder)
            .expect("recording before in_background")
            .written = Some(Mutex::new(Vec::new()));
        self
    }

    /// Encode and write each result on `threads` threads of its own, so
    /// that the engine's thread goes on to the next pair meanwhile (each
    /// file still flushed to disk, then renamed into place). A write's
    /// failure is returned by a later write or by [`Self::flush`], which
    /// waits for every result handed over; dropping the writer waits too.
    pub fn in_background(mut self, threads: usize) -> Result<Self, HostError> {
        // The crash tests' hook must find no other file being written when
        // it aborts: one thread there.
        let threads = if cfg!(feature = "crash-injection") {
            1
        } else {
            threads
        };
        let folder = Arc::clone(&self.folder);
        self.background = Some(Stage::spawn(threads, move |output| match output {
            Output::Fields(stem, fields) => folder.write_files(&folder.spec.files(&stem, &fields)?),
            Output::Image(stem, w, h, image) => {
                folder.write_files(&[folder.spec.image_file(&stem, w, h, &image)?])
            }
        })?);
        Ok(self)
    }

    /// Wait until every result handed over is written (nothing to wait for
    /// unless [`Self::in_background`]); the first failure, if any.
    pub fn flush(&self) -> Result<(), HostError> {
        self.background.as_ref().map_or(Ok(()), Stage::flush)
    }

    /// Every file written so far, sorted by path (empty unless
    /// [`Self::recording`]).
    pub fn written(&self) -> Vec<Written> {
        let Some(written) = &self.folder.written else {
            return Vec::new();
        };
        let mut files = written.lock().expect("no panics holding it").clone();
        files.sort();
        files
    }

    /// The output folder.
    pub fn root(&self) -> &Path {
        &self.folder.root
    }

    /// What is written per result.
    pub fn spec(&self) -> &OutputSpec {
        &self.folder.spec
    }

    /// Write every file of the result labelled `stem`.
    pub fn write(&self, stem: &str, fields: PairFields) -> Result<(), HostError> {
        match &self.background {
            Some(stage) => stage.submit(Output::Fields(stem.to_owned(), fields)),
            None => self
                .folder
                .write_files(&self.folder.spec.files(stem, &fields)?),
        }
    }

    /// Write the result labelled `stem` of a spec that needs no fields
    /// ([`OutputSpec::needs_fields`]): `STEM.png` of `image`, the
    /// `--variant` image of `width × height` pixels.
    pub fn write_image(
        &self,
        stem: &str,
        width: usize,
        height: usize,
        image: &[u8],
    ) -> Result<(), HostError> {
        let spec = &self.folder.spec;
        debug_assert!(!spec.needs_fields(), "{spec:?}");
        if !spec.rep {
            return Ok(());
        }
        match &self.background {
            Some(stage) => stage.submit(Output::Image(
                stem.to_owned(),
                width,
                height,
                image.to_vec(),
            )),
            None => self
                .folder
                .write_files(&[spec.image_file(stem, width, height, image)?]),
        }
    }

    /// `--keep-count`: copy every file of the result `from` to the stem `to`.
    pub fn repeat(&self, from: &str, to: &str) -> Result<(), HostError> {
        // The files of `from` may still be on their way.
        self.flush()?;
        let (root, spec) = (&self.folder.root, &self.folder.spec);
        let mut dirs: Vec<&str> = Vec::new();
        if spec.rep {
            dirs.push("");
        }
        dirs.extend(spec.subdirs());
        for dir in dirs {
            for ext in ["png", "jpg", "npy", "flo"] {
                // Named, not `with_extension`: a stem may hold a dot (`img.002`).
                let src = root.join(dir).join(format!("{from}.{ext}"));
                if !src.is_file() {
                    continue;
                }
                let bytes = fs::read(&src).map_err(|e| HostError::io(&src, e))?;
                self.folder
                    .put(&Path::new(dir).join(format!("{to}.{ext}")), &bytes)?;
            }
        }
        Ok(())
    }
}

impl Folder {
    fn write_files(&self, files: &[(PathBuf, Vec<u8>)]) -> Result<(), HostError> {
        #[cfg(feature = "crash-injection")]
        crash_injection::abort_hook(&self.root, files);
        for (rel, bytes) in files {
            self.put(rel, bytes)?;
        }
        Ok(())
    }

    /// Write `bytes` to the output folder's `rel`.
    fn put(&self, rel: &Path, bytes: &[u8]) -> Result<(), HostError> {
        atomic::write_file(&self.root.join(rel), bytes)?;
        if let Some(written) = &self.written {
            let mut written = written.lock().expect("no panics holding it");
            let path: Vec<_> = rel
                .components()
                .map(|c| c.as_os_str().to_string_lossy())
                .collect();
            written.push(Written {
                path: path.join("/"),
                size: bytes.len() as u64,
                hash: crate::io::content_hash::hash_bytes(bytes),
            });
        }
        Ok(())
    }
}

/// Remove the temp files of interrupted atomic writes in `dir`: hidden
/// names ending in `.tmp` (`.rfXXXXXX.tmp`, as [`atomic`] names them).
pub fn clean_stale_temps(dir: &Path) -> Result<usize, HostError> {
    let Ok(entries) = fs::read_dir(dir) else {
        return Ok(0);
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        if name.starts_with('.') && name.ends_with(".tmp") && entry.path().is_file() {
            fs::remove_file(entry.path()).map_err(|e| HostError::io(entry.path(), e))?;
            removed += 1;
        }
    }
    Ok(removed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Flow, FlowPlanes};

    fn fields() -> PairFields {
        PairFields {
            planes: FlowPlanes {
                v_c: Flow::from_parts(2, 1, vec![1.0, 0.0], vec![0.0, 2.0]),
                v_d: Flow::from_parts(2, 1, vec![0.5, 0.0], vec![0.0, -1.0]),
            },
            rep: vec![10, 20, 30, 40, 50, 60],
        }
    }

    #[test]
    fn variants_permute_the_representation() {
        let f = fields();
        let spec = |variant| OutputSpec {
            variant,
            ..OutputSpec::default()
        };
        assert_eq!(spec(Variant::Dc).image(&f), f.rep);
        assert_eq!(spec(Variant::Dc0).image(&f), [10, 0, 30, 40, 0, 60]);
        assert_eq!(spec(Variant::Cd).image(&f), [20, 10, 30, 50, 40, 60]);
        assert_eq!(spec(Variant::Hsv).image(&f).len(), 6);
        assert_eq!(f.field(Field::VR), (vec![1.5, 0.0], vec![0.0, 1.0]));
    }

    #[test]
    fn npy_xy_round_trip_and_fields_parse() {
        let bytes = encode_npy_xy(1, 2, &[1.0, 2.0], &[3.0, 4.0]);
        assert_eq!(
            decode_npy_xy(&bytes).unwrap(),
            (1, 2, vec![1.0, 2.0], vec![3.0, 4.0])
        );
        assert_eq!(parse_fields("v_R,v_c,v_R"), Ok(vec![Field::VC, Field::VR]));
        assert!(parse_fields("v_x").unwrap_err().contains("v_c, v_d or v_R"));
    }

    #[test]
    fn y4m_conversion_hits_the_bt601_anchors() {
        let frame = y4m_frame(&[0, 0, 0, 255, 255, 255, 255, 0, 0]);
        assert_eq!(&frame[..6], b"FRAME\n");
        assert_eq!(&frame[6..9], [16, 235, 82]);
        assert_eq!(&frame[9..12], [128, 128, 90]);
        assert_eq!(&frame[12..15], [128, 128, 240]);
        assert_eq!(
            y4m_header(4, 2, (25, 1)),
            "YUV4MPEG2 W4 H2 F25:1 Ip A1:1 C444\n"
        );
    }
}

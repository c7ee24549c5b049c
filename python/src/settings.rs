//! Keyword arguments: Python's names for the host's one
//! [`Settings`](reynoldsflow_host::settings::Settings) (the engine, its
//! parameters and the image variant, checked by the host as every front
//! end's), parsed in one place for every function.

use multiversion::multiversion;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyFloat, PyString, PyTuple};
use reynoldsflow_core::IntensityScale;
use reynoldsflow_host::HostError;
use reynoldsflow_host::dataset::ItemSettings;
use reynoldsflow_host::engine::PairEngine;
use reynoldsflow_host::outputs::{
    self, DEFAULT_JPEG_QUALITY, Fields, ImageFormat, JpegSubsampling, NpyDtype, OutputSpec,
    PngCompression, Variant,
};
use reynoldsflow_host::sequence::sampled::{self, FramePlan, Rate};
use reynoldsflow_host::settings::{
    self, EngineKind, FirstFrame, ScaleArg, Settings, TileSize, parse_choice,
};
use reynoldsflow_host::stop::Stop;

use crate::errors::{host_error, value_error};

/// The keywords every computing function takes: the engine and its parameters.
const FIELD_KEYS: &[&str] = &["engine", "intensity_scale", "lam", "tile"];

/// The keywords of the functions that make images.
pub const IMAGE_KEYS: &[&str] = &["scale", "variant", "hsv_max", "layout"];

/// The keywords that pick and resize frames (`--step`, `--fps`,
/// `--resize`, `--short-side`).
pub const FRAME_KEYS: &[&str] = &["resize", "short_side", "step", "fps"];

/// `convert`'s own keywords.
pub const CONVERT_KEYS: &[&str] = &[
    "scale",
    "variant",
    "hsv_max",
    "resize",
    "short_side",
    "step",
    "fps",
    "npy_dtype",
    "image_format",
    "jpeg_quality",
    "jpeg_subsampling",
    "png_compression",
    "rep",
    "viz",
    "npy",
    "flo",
    "keep_count",
    "max_frames",
    "threads",
    "force",
];

/// A function's keyword arguments, taken one by one; any left over is a
/// `TypeError`, as Python raises for an unknown keyword.
pub struct Kwargs<'py> {
    function: String,
    dict: Bound<'py, PyDict>,
}

impl<'py> Kwargs<'py> {
    /// The keywords of `function`, which takes [`FIELD_KEYS`] and `own`.
    pub fn new(
        py: Python<'py>,
        function: &str,
        dict: Option<&Bound<'py, PyDict>>,
        own: &[&str],
    ) -> PyResult<Self> {
        let dict = match dict {
            Some(d) => d.copy()?,
            None => PyDict::new(py),
        };
        for key in dict.keys() {
            let key: String = key.extract()?;
            if !FIELD_KEYS.contains(&key.as_str()) && !own.contains(&key.as_str()) {
                return Err(PyTypeError::new_err(format!(
                    "{function}() got an unexpected keyword argument '{key}'"
                )));
            }
        }
        Ok(Self {
            function: function.to_owned(),
            dict,
        })
    }

    /// The value of `key` if given (and not None).
    fn take(&mut self, key: &str) -> PyResult<Option<Bound<'py, PyAny>>> {
        let value = self.dict.get_item(key)?;
        self.dict.del_item(key).ok();
        Ok(value.filter(|v| !v.is_none()))
    }

    /// The object given for `key` (not None), unconverted.
    pub fn object(&mut self, key: &str) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.take(key)
    }

    /// `key` extracted as `T`, with the keyword named in a `TypeError`.
    fn get<T>(&mut self, key: &str) -> PyResult<Option<T>>
    where
        T: for<'a> FromPyObject<'a, 'py>,
    {
        let function = self.function.clone();
        self.take(key)?
            .map(|v| {
                v.extract::<T>().map_err(|_| {
                    PyTypeError::new_err(format!(
                        "{function}(): {key}: {} is not the expected type",
                        v.get_type()
                            .name()
                            .map_or_else(|_| "value".to_owned(), |n| n.to_string())
                    ))
                })
            })
            .transpose()
    }

    /// A boolean keyword, False by default.
    pub fn flag(&mut self, key: &str) -> PyResult<bool> {
        Ok(self.get::<bool>(key)?.unwrap_or(false))
    }

    /// `resize`, `short_side`, `step`, `fps`: which frames make pairs, at
    /// what size.
    pub fn frame_plan(&mut self) -> PyResult<FramePlan> {
        let function = self.function.clone();
        let bad = |key: &str, e: String| value_error(format!("{function}(): {key}: {e}"));
        let resize = match self.take("resize")? {
            None => None,
            Some(v) => {
                let text = if let Ok(s) = v.cast::<PyString>() {
                    s.to_cow()?.into_owned()
                } else {
                    let (w, h): (i64, i64) = v.extract().map_err(|_| {
                        PyTypeError::new_err(format!(
                            "{function}(): resize: expected (width, height) or 'WxH'"
                        ))
                    })?;
                    format!("{w}x{h}")
                };
                Some(sampled::parse_resize(&text).map_err(|e| bad("resize", e))?)
            }
        };
        let short_side = self
            .get::<i64>("short_side")?
            .map(|n| sampled::parse_short_side(&n.to_string()).map_err(|e| bad("short_side", e)))
            .transpose()?;
        let step = match self.get::<i64>("step")? {
            None => None,
            Some(k) if k >= 1 => Some(k as u64),
            Some(k) => return Err(bad("step", format!("{k}; expected at least 1"))),
        };
        let fps = self
            .take("fps")?
            .map(|v| rate(&v).map_err(|e| bad("fps", e)))
            .transpose()?;
        if resize.is_some() && short_side.is_some() {
            return Err(value_error(format!(
                "{function}(): give resize or short_side, not both"
            )));
        }
        if step.is_some() && fps.is_some() {
            return Err(value_error(format!(
                "{function}(): give step or fps, not both"
            )));
        }
        Ok(FramePlan::new(step, fps, resize.or(short_side)))
    }

    /// No keyword may be left (for functions without [`Settings`]).
    pub fn done(self) -> PyResult<()> {
        match self.dict.keys().iter().next() {
            Some(key) => Err(PyTypeError::new_err(format!(
                "{}() got an unexpected keyword argument {key}",
                self.function
            ))),
            None => Ok(()),
        }
    }

    /// `max_frames`: at least 1, or None.
    pub fn max_frames(&mut self) -> PyResult<Option<u64>> {
        match self.get::<i64>("max_frames")? {
            None => Ok(None),
            Some(n) if n >= 1 => Ok(Some(n as u64)),
            Some(n) => Err(value_error(format!(
                "{}(): max_frames = {n}; expected at least 1",
                self.function
            ))),
        }
    }

    /// A frame rate keyword (`source_fps`).
    pub fn rate(&mut self, key: &str) -> PyResult<Option<Rate>> {
        let function = self.function.clone();
        self.take(key)?
            .map(|v| rate(&v).map_err(|e| value_error(format!("{function}(): {key}: {e}"))))
            .transpose()
    }

    /// `first_frame`: what a stream's first frame gives, default the
    /// library's.
    pub fn first_frame(&mut self) -> PyResult<FirstFrame> {
        match self.get::<String>("first_frame")? {
            Some(name) => choice::<FirstFrame>("first_frame", &name),
            None => Ok(settings::DEFAULT_FIRST_FRAME),
        }
    }

    /// `threads`: at least 1, default every core.
    pub fn threads(&mut self) -> PyResult<usize> {
        match self.get::<i64>("threads")? {
            None => Ok(std::thread::available_parallelism().map_or(1, |n| n.get())),
            Some(n @ 1..=1024) => Ok(n as usize),
            Some(n) => Err(value_error(format!(
                "{}(): threads = {n}; expected 1 to 1024 (or None: every core)",
                self.function
            ))),
        }
    }
}

/// A rate: a number, a `fractions.Fraction`, or a string such as
/// `"30000/1001"`, as `--fps` parses it.
fn rate(value: &Bound<'_, PyAny>) -> Result<Rate, String> {
    let text = if let Ok(s) = value.cast::<PyString>() {
        s.to_cow().map_err(|e| e.to_string())?.into_owned()
    } else if let (Ok(n), Ok(d)) = (value.getattr("numerator"), value.getattr("denominator")) {
        format!("{n}/{d}")
    } else {
        value.str().map_err(|e| e.to_string())?.to_string()
    };
    sampled::parse_rate(&text)
}

/// `rgb`'s R, G and B bytes as three planes, one after the other in
/// `out`. Compiled for AVX2 too, chosen at run time: the stride-3 reads
/// vectorise there, about 6x faster than x86-64's baseline (10 against
/// 65 µs a 320x240 image), a tenth of a pair's computation.
#[multiversion(targets("x86_64+avx2"))]
fn planes(rgb: &[u8], out: &mut [u8]) {
    let pixels = rgb.as_chunks::<3>().0;
    for (channel, plane) in out.chunks_exact_mut(pixels.len().max(1)).enumerate() {
        for (byte, pixel) in plane.iter_mut().zip(pixels) {
            *byte = pixel[channel];
        }
    }
}

/// The memory layout of returned images.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Layout {
    /// `(..., H, W, 3)`, as NumPy, OpenCV and PIL hold images.
    #[default]
    Hwc,
    /// `(..., 3, H, W)`, channels first, as torchvision's tensors.
    Chw,
}

impl Layout {
    /// `rgb` (RGB8 pixels) written into `out` (as many bytes) in this
    /// layout: a copy, or its R, G and B planes one after the other.
    pub fn place(self, rgb: &[u8], out: &mut [u8]) {
        match self {
            Layout::Hwc => out.copy_from_slice(rgb),
            Layout::Chw => planes(rgb, out),
        }
    }

    /// The shape of `count` images (or one, for `None`) of `h × w`.
    pub fn shape(self, count: Option<usize>, h: usize, w: usize) -> Vec<usize> {
        let one = match self {
            Layout::Hwc => [h, w, 3],
            Layout::Chw => [3, h, w],
        };
        count.into_iter().chain(one).collect()
    }
}

/// `settings` under this API's keyword names, as plain Python values.
pub fn keywords<'py>(
    py: Python<'py>,
    settings: &Settings,
    layout: Layout,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("engine", settings.engine.name())?;
    d.set_item("scale", settings.scale.to_string())?;
    let s = settings.intensity_scale;
    d.set_item("intensity_scale", format!("{}/{}", s.num(), s.den()))?;
    d.set_item("lam", settings.lambda)?;
    d.set_item("tile", settings.tile.map(|t| (t.width, t.height)))?;
    d.set_item("variant", settings.variant.name())?;
    d.set_item("hsv_max", settings.hsv_max)?;
    d.set_item(
        "layout",
        match layout {
            Layout::Hwc => "hwc",
            Layout::Chw => "chw",
        },
    )?;
    Ok(d)
}

/// A call's checked settings, and the layout of the images it returns.
pub struct CallSettings {
    settings: Settings,
    layout: Layout,
}

/// The value of `key` named `name`, as the host's settings name it.
fn choice<T: settings::Choice>(key: &str, name: &str) -> PyResult<T> {
    parse_choice(name).map_err(|e| value_error(format!("{key}: {e}")))
}

/// `scale`: "minmax", "fixed:KD,KC" or a pair (k_d, k_c).
fn parse_scale(value: &Bound<'_, PyAny>) -> PyResult<ScaleArg> {
    if let Ok(s) = value.cast::<PyString>() {
        return settings::parse_scale(&s.to_cow()?).map_err(|e| value_error(format!("scale: {e}")));
    }
    let (k_d, k_c): (f64, f64) = value.extract().map_err(|_| {
        PyTypeError::new_err(
            "scale: expected 'minmax', 'fixed:KD,KC' or a pair (k_d, k_c) of numbers",
        )
    })?;
    for k in [k_d, k_c] {
        if !(k.is_finite() && k >= 0.0) {
            return Err(value_error(format!(
                "scale: gain {k} is not a non-negative number"
            )));
        }
    }
    Ok(ScaleArg::Fixed { k_d, k_c })
}

/// The exact ratio of 32-bit integers that is `x` as a float, by continued
/// fractions (`1/255` as a float gives back 1/255), if there is one.
fn ratio_of_float(x: f64) -> Option<(u32, u32)> {
    if !(x.is_finite() && x > 0.0) {
        return None;
    }
    let (mut h0, mut h1, mut k0, mut k1) = (0u128, 1u128, 1u128, 0u128);
    let mut r = x;
    for _ in 0..64 {
        let a = r.floor();
        let a_int = a as u128;
        let (h2, k2) = (a_int * h1 + h0, a_int * k1 + k0);
        if h2 > u128::from(u32::MAX) || k2 > u128::from(u32::MAX) {
            return None;
        }
        if h2 as f64 / k2 as f64 == x {
            return Some((h2 as u32, k2 as u32));
        }
        (h0, h1, k0, k1) = (h1, h2, k1, k2);
        let frac = r - a;
        if frac == 0.0 {
            return None;
        }
        r = 1.0 / frac;
    }
    None
}

/// `intensity_scale`: a float (taken as the exact ratio it rounds from,
/// e.g. 1/255), a `fractions.Fraction` or int, a pair (num, den), or a
/// string "1/255".
fn parse_intensity_scale(value: &Bound<'_, PyAny>) -> PyResult<IntensityScale> {
    let fail = |e: String| value_error(format!("intensity_scale: {e}"));
    if let Ok(s) = value.cast::<PyString>() {
        return settings::parse_intensity_scale(&s.to_cow()?).map_err(fail);
    }
    let (num, den): (u64, u64) = if let Ok(f) = value.cast::<PyFloat>() {
        let x = f.value();
        ratio_of_float(x)
            .map(|(n, d)| (u64::from(n), u64::from(d)))
            .ok_or_else(|| {
                fail(format!(
                    "{x} is not a ratio of 32-bit integers; give it exactly, e.g. (1, 255) or '1/255'"
                ))
            })?
    } else if let Ok(t) = value.cast::<PyTuple>() {
        t.extract().map_err(|_| {
            PyTypeError::new_err("intensity_scale: a pair (num, den) of non-negative integers")
        })?
    } else if let (Ok(n), Ok(d)) = (value.getattr("numerator"), value.getattr("denominator")) {
        (n.extract()?, d.extract()?)
    } else {
        return Err(PyTypeError::new_err(
            "intensity_scale: expected a float, a fractions.Fraction, a pair (num, den) or a string such as '1/255'",
        ));
    };
    let (num, den) = match (u32::try_from(num), u32::try_from(den)) {
        (Ok(n), Ok(d)) => (n, d),
        _ => {
            return Err(fail(format!(
                "{num}/{den} does not fit a ratio of 32-bit integers"
            )));
        }
    };
    IntensityScale::new(num, den).map_err(|e| fail(format!("{num}/{den}: {e}")))
}

impl CallSettings {
    /// Take the computing keywords from `kw`; none may be left.
    pub fn parse(mut kw: Kwargs<'_>) -> PyResult<Self> {
        let engine = match kw.get::<String>("engine")? {
            Some(name) => choice::<EngineKind>("engine", &name)?,
            None => settings::DEFAULT_ENGINE,
        };
        let scale = kw
            .take("scale")?
            .map_or(Ok(settings::DEFAULT_SCALE), |v| parse_scale(&v))?;
        let intensity_scale = kw
            .take("intensity_scale")?
            .map_or(Ok(settings::DEFAULT_INTENSITY_SCALE), |v| {
                parse_intensity_scale(&v)
            })?;
        let lambda = kw.get::<f64>("lam")?.unwrap_or(settings::DEFAULT_LAMBDA);
        let tile = kw
            .get::<(usize, usize)>("tile")?
            .map(|(width, height)| {
                if width == 0 || height == 0 {
                    Err(value_error("tile: (width, height), both at least 1"))
                } else {
                    Ok(TileSize { width, height })
                }
            })
            .transpose()?;
        let variant = match kw.get::<String>("variant")? {
            Some(name) => choice::<Variant>("variant", &name)?,
            None => settings::DEFAULT_VARIANT,
        };
        // Checked with the rest by `Settings::compute` below.
        let hsv_max = kw.get::<f64>("hsv_max")?;
        let layout = match kw.get::<String>("layout")?.as_deref() {
            None | Some("hwc") => Layout::Hwc,
            Some("chw") => Layout::Chw,
            Some(other) => {
                return Err(value_error(format!(
                    "layout = '{other}'; expected 'hwc' ((H, W, 3), the default) or 'chw' ((3, H, W), channels first as torchvision)"
                )));
            }
        };
        if let Some(key) = kw.dict.keys().iter().next() {
            return Err(PyTypeError::new_err(format!(
                "{}() got an unexpected keyword argument {key}",
                kw.function
            )));
        }
        let call = Self {
            settings: Settings {
                engine,
                scale,
                intensity_scale,
                lambda,
                tile,
                variant,
                hsv_max,
                ..Settings::default()
            },
            layout,
        };
        call.settings.compute().map_err(host_error)?;
        Ok(call)
    }

    /// The settings as keywords: `{"engine": "fixed", "lam": 0.0001, ...}`.
    pub fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        keywords(py, &self.settings, self.layout)
    }

    /// The layout of returned images.
    pub fn layout(&self) -> Layout {
        self.layout
    }

    /// The host's pair engine of these settings, on `threads` threads
    /// (checked as `reynoldsflow pair` checks them).
    pub fn pair_engine(&self, threads: usize) -> Result<PairEngine, HostError> {
        PairEngine::new(&Settings {
            threads: Some(threads),
            ..self.settings.clone()
        })
    }
}

/// `npy`/`flo`: None or False (none), True (`all`), "v_c,v_R" or a list of names.
fn field_list(value: Option<Bound<'_, PyAny>>, key: &str, all: &str) -> PyResult<Option<Fields>> {
    let Some(value) = value else {
        return Ok(None);
    };
    let names = if let Ok(b) = value.extract::<bool>() {
        if !b {
            return Ok(None);
        }
        all.to_owned()
    } else if let Ok(s) = value.extract::<String>() {
        s
    } else if let Ok(list) = value.extract::<Vec<String>>() {
        list.join(",")
    } else {
        return Err(PyTypeError::new_err(format!(
            "{key}: expected True, a list of field names or a string such as 'v_c,v_R'"
        )));
    };
    outputs::parse_field_list(&names)
        .map(Some)
        .map_err(|e| value_error(format!("{key}: {e}")))
}

/// `convert`'s keywords as the settings of a dataset's items, and `force`.
pub fn convert_settings(mut kw: Kwargs<'_>) -> PyResult<(ItemSettings, bool)> {
    let rep = kw.get::<bool>("rep")?.unwrap_or(true);
    let viz = kw.flag("viz")?;
    let npy = field_list(kw.take("npy")?, "npy", "v_c,v_d,v_R")?;
    let flo = field_list(kw.take("flo")?, "flo", "v_R")?;
    let keep_count = kw.flag("keep_count")?;
    let max_frames = kw.max_frames()?;
    let threads = kw.threads()?;
    let force = kw.flag("force")?;
    let plan = kw.frame_plan()?;
    let npy_dtype = match kw.get::<String>("npy_dtype")?.as_deref() {
        None => None,
        Some("float64") => Some(NpyDtype::F64),
        Some("float32") => Some(NpyDtype::F32),
        Some("float16") => Some(NpyDtype::F16),
        Some(other) => Some(choice::<NpyDtype>("npy_dtype", other)?),
    };
    let image_format = match kw.get::<String>("image_format")?.as_deref() {
        None | Some("png") => None,
        Some("jpg" | "jpeg") => Some(()),
        Some(other) => {
            return Err(value_error(format!(
                "image_format = '{other}'; expected 'png' or 'jpg'"
            )));
        }
    };
    let jpeg_quality = match kw.get::<i64>("jpeg_quality")? {
        None => None,
        Some(q @ 1..=100) => Some(q as u8),
        Some(q) => {
            return Err(value_error(format!(
                "jpeg_quality = {q}; expected 1 to 100"
            )));
        }
    };
    let jpeg_subsampling = kw
        .get::<String>("jpeg_subsampling")?
        .map(|name| choice::<JpegSubsampling>("jpeg_subsampling", &name))
        .transpose()?;
    let png_compression = kw
        .get::<String>("png_compression")?
        .map(|name| choice::<PngCompression>("png_compression", &name))
        .transpose()?;
    if (jpeg_quality.is_some() || jpeg_subsampling.is_some()) && image_format.is_none() {
        return Err(value_error(
            "jpeg_quality and jpeg_subsampling apply to image_format='jpg' only",
        ));
    }
    if png_compression.is_some() && image_format.is_some() {
        return Err(value_error(
            "png_compression applies to PNG images; drop it or image_format='jpg'",
        ));
    }
    if npy_dtype.is_some() && npy.is_none() {
        return Err(value_error(
            "npy_dtype applies to npy; give npy=True (or field names)",
        ));
    }
    let call = CallSettings::parse(kw)?;
    let spec = OutputSpec {
        variant: call.settings.variant,
        rep,
        viz,
        npy: npy.map(|f| f.0).unwrap_or_default(),
        flo: flo.map(|f| f.0).unwrap_or_default(),
        hsv_max: call.settings.hsv_max,
        npy_dtype: npy_dtype.unwrap_or_default(),
        image_format: match image_format {
            None => ImageFormat::Png {
                compression: png_compression.unwrap_or_default(),
            },
            Some(()) => ImageFormat::Jpeg {
                quality: jpeg_quality.unwrap_or(DEFAULT_JPEG_QUALITY),
                subsampling: jpeg_subsampling.unwrap_or_default(),
            },
        },
    };
    let item = ItemSettings {
        settings: Settings {
            threads: Some(threads),
            ..call.settings
        },
        spec,
        keep_count,
        max_frames,
        plan,
        limits: crate::frame_limits(),
        stop: Stop::new(),
    };
    Ok((item, force))
}

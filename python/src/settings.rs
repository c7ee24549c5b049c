//! Keyword arguments: the engine, its parameters and the image variant, as
//! the command line's `ComputeArgs`/`OutputArgs` (checked by the host the
//! same way), parsed in one place for every function.

use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyFloat, PyString, PyTuple};
use reynoldsflow_core::IntensityScale;
use reynoldsflow_host::cli::run::{ComputeArgs, EngineArgs, OutputArgs};
use reynoldsflow_host::cli::values::{self, EngineKind, ScaleArg, TileSize};
use reynoldsflow_host::outputs::{self, Fields, OutputSpec, Variant};
use reynoldsflow_host::pipeline::Compute;

use crate::errors::{host_error, value_error};

/// The keywords every computing function takes: the engine and its parameters.
const FIELD_KEYS: &[&str] = &["engine", "intensity_scale", "lam", "tile"];

/// The keywords of the functions that make images.
pub const IMAGE_KEYS: &[&str] = &["scale", "variant", "hsv_max"];

/// `convert`'s own keywords.
pub const CONVERT_KEYS: &[&str] = &[
    "scale",
    "variant",
    "hsv_max",
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
    function: &'static str,
    dict: Bound<'py, PyDict>,
}

impl<'py> Kwargs<'py> {
    /// The keywords of `function`, which takes [`FIELD_KEYS`] and `own`.
    pub fn new(
        py: Python<'py>,
        function: &'static str,
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
        Ok(Self { function, dict })
    }

    /// The value of `key` if given (and not None).
    fn take(&mut self, key: &str) -> PyResult<Option<Bound<'py, PyAny>>> {
        let value = self.dict.get_item(key)?;
        self.dict.del_item(key).ok();
        Ok(value.filter(|v| !v.is_none()))
    }

    /// `key` extracted as `T`, with the keyword named in a `TypeError`.
    fn get<T>(&mut self, key: &str) -> PyResult<Option<T>>
    where
        T: for<'a> FromPyObject<'a, 'py>,
    {
        let function = self.function;
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

/// The checked engine, parameters and image of a call.
pub struct Settings {
    compute: ComputeArgs,
    variant: Variant,
    hsv_max: Option<f64>,
}

fn parse_engine(name: &str) -> PyResult<EngineKind> {
    match name {
        "fixed" => Ok(EngineKind::Fixed),
        "float" => Ok(EngineKind::Float),
        _ => Err(value_error(format!(
            "engine = '{name}'; expected 'fixed' (the core, what embedded targets compute) or 'float' (the float64 reference)"
        ))),
    }
}

fn parse_variant(name: &str) -> PyResult<Variant> {
    match name {
        "dc" => Ok(Variant::Dc),
        "dc0" => Ok(Variant::Dc0),
        "cd" => Ok(Variant::Cd),
        "hsv" => Ok(Variant::Hsv),
        _ => Err(value_error(format!(
            "variant = '{name}'; expected 'dc', 'dc0', 'cd' or 'hsv'"
        ))),
    }
}

/// `scale`: "minmax", "fixed:KD,KC" or a pair (k_d, k_c).
fn parse_scale(value: &Bound<'_, PyAny>) -> PyResult<ScaleArg> {
    if let Ok(s) = value.cast::<PyString>() {
        return values::parse_scale(&s.to_cow()?).map_err(|e| value_error(format!("scale: {e}")));
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
        return values::parse_intensity_scale(&s.to_cow()?).map_err(fail);
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

impl Settings {
    /// Take the computing keywords from `kw`; none may be left.
    pub fn parse(mut kw: Kwargs<'_>) -> PyResult<Self> {
        let engine = parse_engine(
            &kw.get::<String>("engine")?
                .unwrap_or_else(|| "fixed".into()),
        )?;
        let scale = kw
            .take("scale")?
            .map_or(Ok(ScaleArg::MinMax), |v| parse_scale(&v))?;
        let intensity_scale = kw
            .take("intensity_scale")?
            .map_or(Ok(IntensityScale::PER_255), |v| parse_intensity_scale(&v))?;
        let lambda = kw.get::<f64>("lam")?.unwrap_or(1e-4);
        if !(lambda.is_finite() && lambda > 0.0) {
            return Err(value_error(format!(
                "lam = {lambda}; expected a positive number (e.g. 1e-4)"
            )));
        }
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
        let variant = parse_variant(&kw.get::<String>("variant")?.unwrap_or_else(|| "dc".into()))?;
        let hsv_max = kw.get::<f64>("hsv_max")?;
        if hsv_max.is_some_and(|r| !(r.is_finite() && r > 0.0)) {
            return Err(value_error("hsv_max: expected a positive number of pixels"));
        }
        if let Some(key) = kw.dict.keys().iter().next() {
            return Err(PyTypeError::new_err(format!(
                "{}() got an unexpected keyword argument {key}",
                kw.function
            )));
        }
        let settings = Self {
            compute: ComputeArgs {
                engine,
                scale,
                intensity_scale,
                lambda,
                tile,
            },
            variant,
            hsv_max,
        };
        settings.compute()?;
        Ok(settings)
    }

    /// The host's computation, checked as `reynoldsflow pair` checks it.
    pub fn compute(&self) -> PyResult<Compute> {
        self.compute.compute().map_err(host_error)
    }

    /// The image to return.
    pub fn output_spec(&self) -> OutputSpec {
        OutputSpec {
            variant: self.variant,
            hsv_max: self.hsv_max,
            ..OutputSpec::default()
        }
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

/// `convert`'s keywords as the command line's arguments, and `force`.
pub fn convert_args(mut kw: Kwargs<'_>) -> PyResult<(EngineArgs, OutputArgs, bool)> {
    let rep = kw.get::<bool>("rep")?.unwrap_or(true);
    let viz = kw.flag("viz")?;
    let npy = field_list(kw.take("npy")?, "npy", "v_c,v_d,v_R")?;
    let flo = field_list(kw.take("flo")?, "flo", "v_R")?;
    let keep_count = kw.flag("keep_count")?;
    let max_frames = match kw.get::<i64>("max_frames")? {
        None => None,
        Some(n) if n >= 1 => Some(n as u64),
        Some(n) => {
            return Err(value_error(format!(
                "max_frames = {n}; expected at least 1"
            )));
        }
    };
    let threads = kw.threads()? as u32;
    let force = kw.flag("force")?;
    let settings = Settings::parse(kw)?;
    let engine = EngineArgs {
        compute: settings.compute,
        threads: Some(threads),
    };
    let output = OutputArgs {
        variant: settings.variant,
        no_rep: !rep,
        viz,
        hsv_max: settings.hsv_max,
        npy,
        flo,
        keep_count,
        max_frames,
    };
    Ok((engine, output, force))
}

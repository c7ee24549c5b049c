//! The command line's names for the library's settings: the flag of each
//! [`Setting`] (so the host's errors print as `--lambda: …`), and clap
//! parsers of the settings' [`Choice`]s, with their help lines.

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use reynoldsflow_host::HostError;
use reynoldsflow_host::settings::{Choice, Setting};

/// The flag that sets `setting`.
pub fn flag(setting: Setting) -> &'static str {
    match setting {
        Setting::Engine => "--engine",
        Setting::Scale => "--scale",
        Setting::IntensityScale => "--intensity-scale",
        Setting::Lambda => "--lambda",
        Setting::Tile => "--tile",
        Setting::Threads => "--threads",
        Setting::Variant => "--variant",
        Setting::HsvMax => "--hsv-max",
        Setting::FirstFrame => "--first-frame",
        Setting::Rep => "--no-rep",
        Setting::Npy => "--npy",
        Setting::NpyDtype => "--npy-dtype",
        Setting::Flo => "--flo",
        Setting::ImageFormat => "--image-format",
        Setting::JpegQuality => "--jpeg-quality",
        Setting::Resize => "--resize",
        Setting::ShortSide => "--short-side",
        Setting::Step => "--step",
        Setting::Fps => "--fps",
        Setting::Raw => "--raw",
        Setting::Shard => "--shard",
        Setting::MaxPixels => "--max-pixels",
        Setting::FilesFrom => "--files-from",
        _ => setting.name(),
    }
}

/// A host error as one line, a setting named by its flag.
pub fn message(e: &HostError) -> String {
    match e {
        HostError::Setting { setting, problem } => format!("{}: {problem}", flag(*setting)),
        e => e.to_string(),
    }
}

/// A clap parser of the values of `T`, listed with their help lines.
pub fn choice<T: Choice + Clone + Send + Sync>() -> impl TypedValueParser<Value = T> {
    PossibleValuesParser::new(
        T::ALL
            .iter()
            .map(|v| PossibleValue::new(v.name()).help(v.help())),
    )
    .try_map(|name| T::from_name(&name).ok_or_else(|| format!("expected one of {}", T::names())))
}

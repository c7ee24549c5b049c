//! One set of defaults: the C API's `rf_config_init` writes the values the
//! host's `Settings::default()` holds (the CLI, the element, the node and
//! Python each test their own mapping onto `Settings`).

use reynoldsflow_capi::{rf_config, rf_scaling, rf_variant};
use reynoldsflow_core::Params;
use reynoldsflow_host::outputs::Variant;
use reynoldsflow_host::settings::{self, ScaleArg, Settings};

#[test]
fn the_c_api_defaults_are_the_host_settings_defaults() {
    let c = rf_config::new(64, 48);
    let host = Settings::default();
    let s = host.intensity_scale;
    assert_eq!((c.scale_num, c.scale_den), (s.num(), s.den()));
    assert_eq!(c.lambda, host.lambda);
    assert_eq!(host.scale, ScaleArg::MinMax);
    assert_eq!(c.scaling, rf_scaling::RF_SCALING_PER_FRAME_MINMAX as u32);
    assert_eq!((c.k_d, c.k_c), settings::DEFAULT_FIXED_GAINS);
    let variant = match host.variant {
        Variant::Dc => rf_variant::RF_VARIANT_DC,
        Variant::Dc0 => rf_variant::RF_VARIANT_DC0,
        Variant::Cd => rf_variant::RF_VARIANT_CD,
        Variant::Hsv => panic!("the C API has no colour wheel"),
    };
    assert_eq!(c.variant, variant as u32);
    assert_eq!((c.tile_width, c.flags), (0, 0));
}

#[test]
fn the_core_defaults_are_the_host_settings_defaults() {
    let host = Settings::default();
    assert_eq!(Params::DEFAULT.scale, host.intensity_scale);
    // λ in the core is the host's default rounded to Q32.32.
    assert_eq!(
        Params::DEFAULT.lambda,
        fixed::types::U32F32::from_num(host.lambda)
    );
}

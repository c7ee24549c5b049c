//! Any configuration and any call sequence gets a status, never a panic or
//! a write outside the buffers given: random `rf_config`s (NaN, infinities,
//! huge sides, unknown enums), then whole frames, rows and streams on the
//! accepted ones.

use core::ffi::c_void;
use core::ptr;

use proptest::prelude::*;
use reynoldsflow_capi::*;

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(-1.0),
        1 => Just(0.0),
        6 => Just(1e-4),
        1 => Just(65535.9),
        1 => Just(65536.0),
        1 => -10.0..100_000.0f64,
        4 => 0.0..0.3f64,
    ]
}

prop_compose! {
    fn any_config()(
        width in prop_oneof![8 => 1u32..48, 1 => Just(0), 1 => Just(70_000)],
        height in prop_oneof![8 => 1u32..24, 1 => Just(0), 1 => Just(u32::MAX)],
        scale_num in prop_oneof![8 => Just(1u32), 1 => 0u32..4, 1 => Just(u32::MAX)],
        scale_den in prop_oneof![8 => Just(255u32), 1 => 0u32..600, 1 => Just(u32::MAX)],
        lambda in any_f64(),
        scaling in 0u32..4,
        k_d in any_f64(),
        k_c in any_f64(),
        variant in 0u32..4,
        tile_width in prop_oneof![Just(0u32), 1u32..50],
        flags in prop_oneof![4 => Just(0u32), 4 => Just(RF_FLAG_ROW_FIELDS), 1 => any::<u32>()],
    ) -> rf_config {
        rf_config { width, height, scale_num, scale_den, lambda, scaling, k_d, k_c, variant, tile_width, flags }
    }
}

unsafe extern "C" fn count_rows(user: *mut c_void, row: *const rf_row) {
    // SAFETY: `user` is the `usize` the test passed; `row` is valid during the call.
    unsafe { *user.cast::<usize>() += (*row).width as usize };
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn every_config_gets_a_status_and_accepted_ones_compute(config in any_config(), seed in any::<u64>()) {
        let mut bytes = 0usize;
        // SAFETY: valid pointers throughout; the memory outlives the engine's use.
        unsafe {
            let sized = rf_workspace_size(&config, &mut bytes);
            let mut memory = vec![0u8; if sized == rf_status::RF_OK { bytes } else { 64 }];
            let mut engine = ptr::null_mut();
            let init = rf_init(memory.as_mut_ptr().cast(), memory.len(), &config, &mut engine);
            prop_assert_eq!(init, sized);
            if init != rf_status::RF_OK {
                prop_assert!(engine.is_null());
                return Ok(());
            }
            let n = (config.width * config.height) as usize;
            let mut s = seed | 1;
            let mut frame = || -> Vec<u8> {
                (0..n).map(|_| { s ^= s << 13; s ^= s >> 7; s ^= s << 17; s as u8 }).collect()
            };
            let (prev, next) = (frame(), frame());
            let mut rgb = vec![0u8; 3 * n];
            let mut v_c = vec![0f32; 2 * n];
            let outputs = rf_outputs { rgb: rgb.as_mut_ptr(), rgb_len: rgb.len(), v_c: v_c.as_mut_ptr(), v_c_len: v_c.len(), ..rf_outputs::NONE };
            prop_assert_eq!(rf_represent(engine, prev.as_ptr(), next.as_ptr(), n, 0, &outputs), rf_status::RF_OK);
            let mut pixels = 0usize;
            let user = (&raw mut pixels).cast::<c_void>();
            prop_assert_eq!(rf_represent_rows(engine, prev.as_ptr(), next.as_ptr(), n, 0, Some(count_rows), user), rf_status::RF_OK);
            prop_assert_eq!(pixels, n);
            let begin = rf_stream_begin(engine);
            let full_width = config.tile_width == 0 || config.tile_width == config.width;
            let streams = config.scaling != rf_scaling::RF_SCALING_PER_FRAME_MINMAX as u32 && full_width;
            prop_assert_eq!(begin == rf_status::RF_OK, streams);
            if streams {
                let w = config.width as usize;
                pixels = 0;
                for y in 0..config.height as usize {
                    let row = |f: &[u8]| f[y * w..].as_ptr();
                    prop_assert_eq!(rf_stream_push(engine, row(&prev), row(&next), w, Some(count_rows), user), rf_status::RF_OK);
                }
                prop_assert_eq!(pixels, n);
                prop_assert_eq!(rf_stream_push(engine, prev.as_ptr(), next.as_ptr(), w, Some(count_rows), user), rf_status::RF_ERR_NO_STREAM);
            }
        }
    }
}

//! No input makes the core panic: bad geometry, buffers and parameters are
//! typed errors, and every admissible parameter runs without overflow (these
//! tests are built with overflow checks on).

use proptest::prelude::*;
use reynoldsflow_core::fixed::types::{U16F16, U32F32};
use reynoldsflow_core::{
    ByteScale, Config, Engine, Error, FieldPlanes, FieldSink, Frame, FramePair, IntensityScale,
    Params, Plan, RgbSink, RowStream, Scaling, represent,
};
use reynoldsflow_tests::{Pattern, PixelPlane, frame_pair};

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn any_geometry_is_accepted_or_refused_with_a_reason(
        w in 0usize..70_000, h in 0usize..70_000, tw in 0usize..300, th in 0usize..300,
    ) {
        match Config::new(w, h, Params::DEFAULT) {
            Err(Error::EmptyFrame) => prop_assert!(w == 0 || h == 0),
            Err(Error::FrameTooLarge) => prop_assert!(w > 65_535 || h > 65_535),
            Err(e) => prop_assert!(false, "unexpected {e}"),
            Ok(config) => match Plan::new(config, tw, th) {
                Err(Error::TileOutOfFrame) => prop_assert!(tw == 0 || th == 0),
                Err(e) => prop_assert!(false, "unexpected {e}"),
                Ok(plan) => {
                    prop_assert!(plan.tile_width() == tw.min(w));
                    let covered: usize = plan.tiles().map(|t| t.width * t.height).sum();
                    prop_assert_eq!(covered, w * h);
                }
            },
        }
    }

    #[test]
    fn any_buffer_is_checked_against_its_frame(
        len in 0usize..2000, w in 0usize..50, h in 0usize..50, stride in 0usize..60,
    ) {
        let buf = vec![7u8; len];
        match Frame::new(&buf, w, h, stride) {
            Ok(f) => {
                prop_assert!(w > 0 && h > 0 && stride >= w && (h - 1) * stride + w <= len);
                for y in -3..(h as isize + 3) {
                    prop_assert_eq!(f.clamped_row(y).len(), w);
                }
            }
            Err(Error::EmptyFrame) => prop_assert!(w == 0 || h == 0),
            Err(Error::StrideTooSmall) => prop_assert!(stride < w),
            Err(Error::BufferTooShort { needed, got }) => prop_assert!(got == len && needed > len),
            Err(e) => prop_assert!(false, "unexpected {e}"),
        }
    }

    /// Extreme but admissible parameters: the documented bounds must hold on
    /// the worst frames (saturated steps, noise), or overflow checks fire.
    #[test]
    fn admissible_parameters_never_overflow(
        num in 1u32..=1000, den_mul in 1u32..=699_050, lambda4_log2 in 0.0f64..30.0,
        pattern in 0usize..6, w in 1usize..24, h in 1usize..24, seed: u64,
    ) {
        let scale = IntensityScale::new(num, num * den_mul).unwrap();
        // λ whose Λ4 = 65536·λ/s² spans the admissible [1, 2³⁰), where representable.
        let s = 1.0 / f64::from(den_mul);
        let lambda = U32F32::from_num(2f64.powf(lambda4_log2) * s * s / 65_536.0).max(U32F32::DELTA);
        let params = Params { scale, lambda };
        let config = Config::new(w, h, params);
        prop_assume!(config.is_ok(), "λ not representable at this scale");
        let config = config.unwrap();
        let (prev, next) = frame_pair(Pattern::ALL[pattern], w, h, seed);
        let mut engine = Box::new(Engine::<64>::new());
        let plan = Plan::strips(config, Engine::<64>::MAX_TILE_WIDTH).unwrap();
        let job = plan.bind(FramePair::packed(&config, &prev, &next).unwrap()).unwrap();
        let mut rgb = vec![0; w * h * 3];
        // A sink that reads the fields too, so their conversions run.
        let mut fields = PixelPlane::new(&config);
        represent(&mut *engine, &job, Scaling::PerFrameMinMax, &mut rgb, &mut fields).unwrap();
    }
}

#[test]
fn parameter_extremes_run_on_saturated_frames() {
    let lambda_max = |s: f64| U32F32::from_num(0.999 * 16384.0 * s * s);
    let cases = [
        (IntensityScale::new(1, 1).unwrap(), lambda_max(1.0)),
        (IntensityScale::new(1, 1).unwrap(), U32F32::from_num(1e-4)),
        (IntensityScale::new(1, 699_050).unwrap(), U32F32::DELTA),
        (IntensityScale::PER_255, lambda_max(1.0 / 255.0)),
        (IntensityScale::PER_255, U32F32::DELTA),
    ];
    for (scale, lambda) in cases {
        let params = Params { scale, lambda };
        let config = Config::new(40, 30, params).unwrap_or_else(|e| panic!("{params:?}: {e}"));
        for pattern in Pattern::ALL {
            for seed in 0..4 {
                let (prev, next) = frame_pair(pattern, 40, 30, seed);
                let mut engine = Box::new(Engine::<64>::new());
                let mut rgb = vec![0; 40 * 30 * 3];
                let plan = Plan::strips(config, Engine::<64>::MAX_TILE_WIDTH).unwrap();
                let job = plan
                    .bind(FramePair::packed(&config, &prev, &next).unwrap())
                    .unwrap();
                let mut fields = PixelPlane::new(&config);
                represent(
                    &mut *engine,
                    &job,
                    Scaling::PerFrameMinMax,
                    &mut rgb,
                    &mut fields,
                )
                .unwrap();
            }
        }
    }
}

#[test]
fn mismatched_and_short_buffers_are_typed_errors() {
    let config = Config::new(8, 6, Params::DEFAULT).unwrap();
    let (a, b) = (vec![0u8; 48], vec![0u8; 47]);
    assert_eq!(
        FramePair::packed(&config, &a, &b).unwrap_err(),
        Error::BufferTooShort {
            needed: 48,
            got: 47
        }
    );
    let small = Frame::packed(&a[..42], 7, 6).unwrap();
    let full = Frame::packed(&a, 8, 6).unwrap();
    assert_eq!(
        FramePair::new(&config, small, full).unwrap_err(),
        Error::SizeMismatch
    );

    let mut rgb = vec![0u8; 8 * 6 * 3 - 1];
    let scale = ByteScale::fixed(U16F16::from_num(8));
    assert_eq!(
        RgbSink::new(&config, &mut rgb, scale, scale).unwrap_err(),
        Error::BufferTooShort {
            needed: 144,
            got: 143
        }
    );
    let mut plane = vec![Default::default(); 47];
    let planes = FieldPlanes {
        m_d: Some(&mut plane),
        ..Default::default()
    };
    assert!(matches!(
        FieldSink::new(&config, planes),
        Err(Error::BufferTooShort { .. })
    ));

    // A plan for one size, frames of another.
    let other = Config::new(9, 6, Params::DEFAULT).unwrap();
    let frames = FramePair::packed(&config, &a, &a).unwrap();
    let mut engine = Box::new(Engine::<64>::new());
    let plan = Plan::strips(other, 50).unwrap();
    assert_eq!(plan.bind(frames).unwrap_err(), Error::SizeMismatch);
    // Past the last tile: nothing computed, and said so.
    let plan = Plan::strips(config, 50).unwrap();
    let job = plan.bind(frames).unwrap();
    assert_eq!(engine.run_tile(&job, 99, &mut ()), None);
    assert_eq!(engine.run_tile(&job, 0, &mut ()), plan.tile(0));
    // An RGB plane too short is refused before anything runs.
    let mut short = vec![0u8; 8 * 6 * 3 - 1];
    assert_eq!(
        represent(&mut *engine, &job, Scaling::PerFrameMinMax, &mut short, ()),
        Err(Error::BufferTooShort {
            needed: 144,
            got: 143
        })
    );

    // Streams: strips outside the frame, short rows, rows past the end.
    assert_eq!(
        RowStream::new(&mut engine, config, 5, 4).err(),
        Some(Error::TileOutOfFrame)
    );
    assert_eq!(
        RowStream::new(&mut engine, config, 0, 0).err(),
        Some(Error::TileOutOfFrame)
    );
    let wide = Config::new(100, 2, Params::DEFAULT).unwrap();
    assert_eq!(
        RowStream::full_width(&mut engine, wide).err(),
        Some(Error::TileTooWide { max: 50 })
    );
    let mut stream = RowStream::full_width(&mut engine, config).unwrap();
    assert_eq!(
        stream.push(&a[..7], &a[..8], &mut ()),
        Err(Error::BufferTooShort { needed: 8, got: 7 })
    );
    for _ in 0..6 {
        stream.push(&a[..8], &a[..8], &mut ()).unwrap();
    }
    assert_eq!(
        stream.push(&a[..8], &a[..8], &mut ()),
        Err(Error::StreamFinished)
    );
}

//! Scaling while streaming: `PreviousFrameMinMax` gives each frame the
//! extremes of the frame before it, and `Fixed` needs no extremes at all.

use reynoldsflow_core::fixed::types::U16F16;
use reynoldsflow_core::{
    ByteScale, Config, Engine, ExtremesSink, FramePair, Params, Plan, PreviousFrameMinMax, RgbSink,
    RowStream, Scaling, byte_scales,
};
use reynoldsflow_tests::{COLS, Pattern, engine, frame_pair};

#[test]
fn previous_frame_min_max_uses_the_last_frames_extremes() {
    let (w, h) = (48, 32);
    let config = Config::new(w, h, Params::DEFAULT).unwrap();
    let plan = Plan::strips(config, Engine::<COLS>::MAX_TILE_WIDTH).unwrap();
    let first = ByteScale::fixed(U16F16::from_num(8));
    let mut scales = PreviousFrameMinMax::new(first, first);
    let mut engine = engine();
    let mut previous_extremes: Option<ExtremesSink> = None;
    for (k, pattern) in [Pattern::Smooth, Pattern::Random, Pattern::Shifted]
        .into_iter()
        .enumerate()
    {
        let (prev, next) = frame_pair(pattern, w, h, k as u64);
        let frames = FramePair::packed(&config, &prev, &next).unwrap();
        // Streamed: rows in, bytes out with the scales known before the frame.
        let (scale_d, scale_c) = scales.scales();
        let mut streamed = vec![0u8; 3 * w * h];
        {
            let rgb = RgbSink::new(&config, &mut streamed, scale_d, scale_c).unwrap();
            let mut sinks = (rgb, scales.tracker());
            let mut stream = RowStream::full_width(&mut engine, config).unwrap();
            for y in 0..h {
                stream
                    .push(&prev[y * w..][..w], &next[y * w..][..w], &mut sinks)
                    .unwrap();
            }
        }
        scales.end_frame();
        // The same frame in memory, with the scales spelled out.
        let expected_scales = match previous_extremes {
            None => (first, first),
            Some(e) => e.byte_scales(),
        };
        assert_eq!((scale_d, scale_c), expected_scales, "frame {k}");
        let mut expected = vec![0u8; 3 * w * h];
        let rgb = RgbSink::new(&config, &mut expected, scale_d, scale_c).unwrap();
        let mut extremes = ExtremesSink::default();
        let job = plan.bind(frames).unwrap();
        engine.run(&job, &mut (rgb, &mut extremes));
        assert_eq!(streamed, expected, "frame {k}");
        // Only this frame's extremes carry over to the next frame.
        let exact = byte_scales(&mut engine, &job, Scaling::PerFrameMinMax);
        assert_eq!(scales.scales(), exact, "frame {k}");
        previous_extremes = Some(extremes);
    }
}

//! Tile invariance: any tiling, and rows streamed through any column strips,
//! give exactly the whole-frame bytes and fields.

use proptest::prelude::*;
use reynoldsflow_core::{Config, Params};
use reynoldsflow_tests::{Pattern, frame_pair, run_streamed, run_tiled};

fn whole_frame(config: &Config, prev: &[u8], next: &[u8]) -> Vec<reynoldsflow_core::FlowPixel> {
    run_tiled(config, prev, next, (config.width(), config.height())).pixels
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]

    #[test]
    fn any_tiling_gives_the_whole_frame_output(
        w in 1usize..=200, h in 1usize..=200, tw in 1usize..=200, th in 1usize..=200,
        strip in 1usize..=200, pattern in 0usize..6, seed: u64,
    ) {
        let (tw, th, strip) = (tw.min(w), th.min(h), strip.min(w));
        let (prev, next) = frame_pair(Pattern::ALL[pattern], w, h, seed);
        let config = Config::new(w, h, Params::DEFAULT).unwrap();
        let whole = whole_frame(&config, &prev, &next);
        let tiled = run_tiled(&config, &prev, &next, (tw, th));
        prop_assert!(tiled.pixels == whole, "tiles {tw}x{th} differ from the whole frame");
        let streamed = run_streamed(&config, &prev, &next, strip);
        prop_assert!(streamed.pixels == whole, "rows streamed through {strip}-px strips differ");
        prop_assert_eq!(streamed.rows.iter().map(|r| r.2).sum::<usize>(), w * h);
    }
}

#[test]
fn small_tiles_cover_every_pixel_once() {
    let (w, h) = (23, 17);
    let (prev, next) = frame_pair(Pattern::Random, w, h, 7);
    let config = Config::new(w, h, Params::DEFAULT).unwrap();
    let whole = whole_frame(&config, &prev, &next);
    for tile in [(1, 1), (1, h), (w, 1), (5, 3), (22, 16)] {
        let tiled = run_tiled(&config, &prev, &next, tile);
        assert!(tiled.pixels == whole, "tile {tile:?}");
        assert_eq!(
            tiled.rows.iter().map(|r| r.2).sum::<usize>(),
            w * h,
            "tile {tile:?}"
        );
    }
}

/// A camera's rows: output row `y` must leave once row `y + 7` is in.
#[test]
fn streamed_output_leaves_seven_rows_behind_the_input() {
    use reynoldsflow_core::{Pixels, RowStream, Sink};
    struct Log(Vec<usize>);
    impl Sink for Log {
        fn row(&mut self, y: usize, _x: usize, _p: Pixels<'_>) {
            self.0.push(y);
        }
    }
    let (w, h) = (40, 30);
    let (prev, next) = frame_pair(Pattern::Smooth, w, h, 3);
    let config = Config::new(w, h, Params::DEFAULT).unwrap();
    let mut engine = reynoldsflow_tests::engine();
    let mut stream = RowStream::full_width(&mut engine, config).unwrap();
    let mut log = Log(Vec::new());
    for y in 0..h {
        stream
            .push(&prev[y * w..][..w], &next[y * w..][..w], &mut log)
            .unwrap();
        let expected: Vec<usize> = if y + 1 == h {
            (0..h).collect()
        } else {
            (0..(y + 1).saturating_sub(7)).collect()
        };
        assert_eq!(log.0, expected, "after input row {y}");
    }
    assert_eq!(
        stream.push(&prev[..w], &next[..w], &mut log),
        Err(reynoldsflow_core::Error::StreamFinished)
    );
}

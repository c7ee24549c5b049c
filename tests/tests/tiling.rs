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

/// A sink that keeps every magnitude in planes of its own, which the
/// engine's tail writes directly (`Sink::magnitude_rows`), as per-frame
/// min–max does on the host; rows it declines go through `Sink::row`.
struct OwnRows {
    width: usize,
    m_d: Vec<f32>,
    m_c: Vec<f32>,
    luma: Vec<u8>,
    /// Rows `magnitude_rows` declines (it takes the others).
    decline: fn(usize) -> bool,
    /// Rows announced through `kept_row`, and through `row`.
    kept: usize,
    handed: usize,
    /// Kept rows whose extremes, as the engine handed them, are not those
    /// of the row's magnitudes.
    wrong_extremes: usize,
}

impl reynoldsflow_core::Sink for OwnRows {
    fn reads_fields(&self) -> bool {
        false
    }

    fn row(&mut self, y: usize, x: usize, pixels: reynoldsflow_core::Pixels<'_>) {
        let at = y * self.width + x..y * self.width + x + pixels.len();
        self.m_d[at.clone()].copy_from_slice(pixels.m_d);
        self.m_c[at.clone()].copy_from_slice(pixels.m_c);
        self.luma[at].copy_from_slice(pixels.luma);
        self.handed += 1;
    }

    fn magnitude_rows(&mut self, y: usize, x: usize, width: usize) -> Option<[&mut [f32]; 2]> {
        if (self.decline)(y) {
            return None;
        }
        let at = y * self.width + x..y * self.width + x + width;
        Some([&mut self.m_d[at.clone()], &mut self.m_c[at]])
    }

    fn kept_row(
        &mut self,
        y: usize,
        x: usize,
        luma: &[u8],
        extremes: reynoldsflow_core::ExtremesSink,
    ) {
        let at = y * self.width + x..y * self.width + x + luma.len();
        let mut want = reynoldsflow_core::ExtremesSink::default();
        want.m_d.add_all(&self.m_d[at.clone()]);
        want.m_c.add_all(&self.m_c[at.clone()]);
        self.wrong_extremes += usize::from(extremes != want);
        self.luma[at].copy_from_slice(luma);
        self.kept += 1;
    }
}

#[test]
fn a_sink_keeping_magnitudes_in_its_own_rows_gets_the_same_values() {
    let (w, h) = (37, 29);
    let (prev, next) = frame_pair(Pattern::Smooth, w, h, 11);
    let config = Config::new(w, h, Params::DEFAULT).unwrap();
    let whole = whole_frame(&config, &prev, &next);
    let frames = reynoldsflow_core::FramePair::packed(&config, &prev, &next).unwrap();
    let odd_rows: fn(usize) -> bool = |y| y % 2 == 1;
    for (tile, decline) in [
        ((w, h), (|_| false) as fn(usize) -> bool),
        ((9, 7), |_| false),
        ((w, h), odd_rows),
        ((4, 29), odd_rows),
    ] {
        let plan = reynoldsflow_core::Plan::new(config, tile.0, tile.1).unwrap();
        let job = plan.bind(frames).unwrap();
        let mut sink = OwnRows {
            width: w,
            m_d: vec![-1.0; w * h],
            m_c: vec![-1.0; w * h],
            luma: vec![0; w * h],
            decline,
            kept: 0,
            handed: 0,
            wrong_extremes: 0,
        };
        reynoldsflow_tests::engine().run(&job, &mut sink);
        let what = format!("tile {tile:?}");
        for (i, px) in whole.iter().enumerate() {
            assert_eq!(sink.m_d[i].to_bits(), px.m_d.to_bits(), "{what}, pixel {i}");
            assert_eq!(sink.m_c[i].to_bits(), px.m_c.to_bits(), "{what}, pixel {i}");
            assert_eq!(sink.luma[i], px.luma, "{what}, pixel {i}");
        }
        // One call per row segment (a frame row per column of tiles), by
        // whichever way the sink chose for its row.
        let across = w.div_ceil(tile.0);
        let declined = (0..h).filter(|&y| decline(y)).count();
        assert_eq!(sink.handed, across * declined, "{what}");
        assert_eq!(sink.kept, across * (h - declined), "{what}");
        assert_eq!(sink.wrong_extremes, 0, "{what}");
    }
}

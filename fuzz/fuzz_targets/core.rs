//! The core through its public API: frame sizes 1..=300 per
//! side, any tile size, intensity scales and λ in and out of their ranges,
//! both scalings, and rows pushed through `RowStream` strip by strip with
//! arbitrary strip widths, row slack and misuse (short rows, rows past the
//! end). Refusals are typed errors; every accepted configuration gives the
//! bytes of the whole-frame `represent` on every path; nothing panics.
#![no_main]

use arbitrary::Arbitrary;
use fixed::types::{U16F16, U32F32};
use libfuzzer_sys::fuzz_target;
use reynoldsflow_core::{
    Config, Engine, Error, ExtremesSink, FramePair, IntensityScale, MemorySize, Params,
    Plan, RgbSink, RowStream, Scaling, SliceEngine, represent,
};

/// Tiles up to 80 columns (eight strips over 640 px).
const COLS: usize = 94;

#[derive(Arbitrary, Debug)]
struct Case {
    width: u16,
    height: u16,
    /// Any tile size, 0 and wider-than-the-engine included.
    tile: (u8, u16),
    /// `None`: the default `1/255`.
    scale: Option<(u32, u32)>,
    /// `None`: the default λ; else any Q32.32 bits.
    lambda: Option<u64>,
    /// `None`: per-frame min–max; else `Fixed` gains as U16F16 bits.
    gains: Option<(u32, u32)>,
    /// Pixel content: 0 noise, 1 flat, 2 saturated edges, 3 smooth motion.
    content: u8,
    seed: u32,
    /// Widths of the RowStream strips (cycled), each 1..=engine width.
    strips: Vec<u8>,
    /// Extra bytes after each pushed row (cycled).
    slack: Vec<u8>,
    /// Also try a short row and a row past the end.
    misuse: bool,
    /// Arbitrary geometry for `Config::new` alone (no computation).
    any_size: (usize, usize),
}

fn pixels(case: &Case, w: usize, h: usize, t: u32) -> Vec<u8> {
    let mut state = case.seed | 1;
    let mut noise = move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state as u8
    };
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            match case.content % 4 {
                0 => noise(),
                1 => (case.seed >> 8) as u8,
                2 => {
                    if (x + t) / 3 % 2 == y / 5 % 2 {
                        255
                    } else {
                        0
                    }
                }
                _ => ((x * 7 + y * 3 + 2 * t) % 256) as u8 ^ (noise() & 3),
            }
        })
        .collect()
}

fuzz_target!(|case: Case| {
    // Any size: a typed refusal or a configuration, never a panic.
    let _ = Config::new(case.any_size.0, case.any_size.1, Params::DEFAULT);

    let (w, h) = (
        1 + usize::from(case.width) % 300,
        1 + usize::from(case.height) % 300,
    );
    let scale = match case.scale {
        None => IntensityScale::PER_255,
        Some((num, den)) => match IntensityScale::new(num, den) {
            Ok(s) => s,
            Err(e) => return assert_eq!(e, Error::ScaleOutOfRange),
        },
    };
    let lambda = case
        .lambda
        .map_or(Params::DEFAULT_LAMBDA, U32F32::from_bits);
    let config = match Config::new(w, h, Params { scale, lambda }) {
        Ok(c) => c,
        Err(e) => return assert_eq!(e, Error::LambdaOutOfRange),
    };
    let scaling = match case.gains {
        None => Scaling::PerFrameMinMax,
        Some((d, c)) => Scaling::Fixed {
            k_d: U16F16::from_bits(d),
            k_c: U16F16::from_bits(c),
        },
    };
    let (prev, next) = (pixels(&case, w, h, 0), pixels(&case, w, h, 1));
    let frames = FramePair::packed(&config, &prev, &next).expect("frames of the config's size");
    let mut engine = Box::new(Engine::<COLS>::new());

    // The reference: whole-frame strips.
    let strips = Plan::strips(config, Engine::<COLS>::MAX_TILE_WIDTH).expect("non-empty strips");
    let mut whole = vec![0u8; 3 * w * h];
    let job = strips.bind(frames).expect("frames of the plan's size");
    represent(&mut *engine, &job, scaling, &mut whole, ()).expect("checked inputs");

    // Any accepted tiling gives the same bytes, on the array engine (a tile
    // wider than its window runs as several) and in slices sized to the tile.
    let (tw, th) = (usize::from(case.tile.0), usize::from(case.tile.1));
    match Plan::new(config, tw, th) {
        Ok(plan) => {
            let mut tiled = vec![0u8; 3 * w * h];
            let job = plan.bind(frames).expect("frames of the plan's size");
            represent(&mut *engine, &job, scaling, &mut tiled, ()).expect("checked");
            assert!(
                tiled == whole,
                "tiles {tw}x{th} of {w}x{h} differ from strips"
            );
            let size = MemorySize::for_tile_width(plan.tile_width()).expect("small sizes");
            let (mut words, mut floats) = (vec![0; size.words], vec![0.0; size.floats]);
            let (mut halves, mut bytes) = (vec![0; size.halves], vec![0; size.bytes]);
            let mut sliced = SliceEngine::new(&mut words, &mut floats, &mut halves, &mut bytes)
                .expect("memory of its size");
            assert_eq!(sliced.max_tile_width(), plan.tile_width());
            represent(&mut sliced, &job, scaling, &mut tiled, ()).expect("checked");
            assert!(
                tiled == whole,
                "tiles {tw}x{th} of {w}x{h} in slices differ"
            );
        }
        Err(Error::TileOutOfFrame) => assert!(tw == 0 || th == 0),
        Err(e) => panic!("unexpected plan error {e:?}"),
    }

    // Row streams, strip by strip: extremes first if the scaling needs them.
    let widths: Vec<usize> = if case.strips.is_empty() {
        vec![Engine::<COLS>::MAX_TILE_WIDTH]
    } else {
        case.strips
            .iter()
            .map(|&b| 1 + usize::from(b) % Engine::<COLS>::MAX_TILE_WIDTH)
            .collect()
    };
    let slack = |row: usize| {
        case.slack
            .get(row % case.slack.len().max(1))
            .map_or(0, |&s| s as usize)
    };
    let row_of = |frame: &[u8], y: usize| {
        let mut row = frame[y * w..(y + 1) * w].to_vec();
        row.resize(w + slack(y), 0xa5);
        row
    };
    let mut stream_pass = |sink: &mut dyn FnMut(&mut RowStream<&mut Engine<COLS>>, &[u8], &[u8])| {
        let (mut x, mut i) = (0, 0);
        while x < w {
            let sw = widths[i % widths.len()].min(w - x);
            let mut stream = RowStream::new(&mut *engine, config, x, sw).expect("strip fits");
            for y in 0..h {
                if case.misuse && y == h / 2 {
                    let short = vec![0u8; w - 1];
                    let err = stream.push(&short, &short, &mut ());
                    assert_eq!(
                        err,
                        Err(Error::BufferTooShort {
                            needed: w,
                            got: w - 1
                        })
                    );
                    assert_eq!(stream.rows_in(), y, "a refused row is not consumed");
                }
                sink(&mut stream, &row_of(&prev, y), &row_of(&next, y));
            }
            assert!(stream.is_finished());
            if case.misuse {
                let row = row_of(&prev, 0);
                assert_eq!(stream.push(&row, &row, &mut ()), Err(Error::StreamFinished));
            }
            x += sw;
            i += 1;
        }
    };
    let (scale_d, scale_c) = scaling
        .byte_scales(|| {
            let mut extremes = ExtremesSink::default();
            stream_pass(
                &mut |s: &mut RowStream<&mut Engine<COLS>>, p: &[u8], n: &[u8]| {
                    s.push(p, n, &mut extremes).expect("whole rows")
                },
            );
            Ok::<_, Error>(extremes)
        })
        .expect("infallible");
    let mut streamed = vec![0u8; 3 * w * h];
    let mut sink = RgbSink::new(&config, &mut streamed, scale_d, scale_c).expect("plane size");
    stream_pass(
        &mut |s: &mut RowStream<&mut Engine<COLS>>, p: &[u8], n: &[u8]| {
            s.push(p, n, &mut sink).expect("whole rows")
        },
    );
    assert!(
        streamed == whole,
        "row streams of {widths:?} over {w}x{h} differ"
    );
});

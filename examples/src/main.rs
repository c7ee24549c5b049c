//! A camera's view of the core: frame rows arrive one at a time, and each
//! output row leaves as soon as the 7 rows below it are in. Two 64-px column
//! strips cover a 96×48 frame, each with its own 19 KiB engine; the
//! representation's R channel (|v_d|) is printed as an ASCII motion map.
//!
//! `cargo run -p reynoldsflow-examples`

use reynoldsflow_core::fixed::types::U16F16;
use reynoldsflow_core::{ByteScale, Config, Engine, Error, Params, Pixels, RowStream, Sink};

const W: usize = 96;
const H: usize = 48;

/// Frame `n` of a scene: a bright 10×10 square moving 2 px right per frame
/// over a fixed textured background.
fn frame(n: usize) -> Vec<u8> {
    (0..W * H)
        .map(|i| {
            let (x, y) = (i % W, i / W);
            let inside = (20 + 2 * n..30 + 2 * n).contains(&x) && (19..29).contains(&y);
            if inside {
                230
            } else {
                ((x * 7 + y * 13) % 31 * 3 + 40) as u8
            }
        })
        .collect()
}

/// Keeps the R byte of every pixel, as rows arrive.
struct MotionMap {
    red: Vec<u8>,
    scale: ByteScale,
}

impl Sink for MotionMap {
    // |v_d| only: the engine skips the fields' conversions.
    fn reads_fields(&self) -> bool {
        false
    }

    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        for (k, &m_d) in pixels.m_d.iter().enumerate() {
            self.red[y * W + x + k] = self.scale.byte(m_d);
        }
    }
}

fn main() -> Result<(), Error> {
    let (prev, next) = (frame(0), frame(1));
    let config = Config::new(W, H, Params::DEFAULT)?;
    // Two strips of at most 64 columns: one engine each, every row to both.
    let mut engines = [Engine::<78>::new(), Engine::<78>::new()];
    let [left, right] = &mut engines;
    let mut streams = [
        RowStream::new(left, config, 0, 64)?,
        RowStream::new(right, config, 64, W - 64)?,
    ];
    let mut map = MotionMap {
        red: vec![0; W * H],
        scale: ByteScale::fixed(U16F16::from_num(8)),
    };
    for y in 0..H {
        for stream in &mut streams {
            stream.push(&prev[y * W..][..W], &next[y * W..][..W], &mut map)?;
        }
    }
    println!(
        "engine working memory: {} bytes per strip",
        Engine::<78>::WORKING_BYTES
    );
    for row in map.red.chunks(W).step_by(2) {
        let line: String = row
            .iter()
            .map(|&r| [' ', '.', ':', '*', '#'][(r as usize * 5 / 256).min(4)])
            .collect();
        println!("|{line}|");
    }
    Ok(())
}

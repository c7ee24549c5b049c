//! Rows pushed as they arrive from a camera: output leaves as soon as the
//! rows it depends on are in.

use crate::engine::Window;
use crate::{Config, Error, HALO, Memory, Sink, TileEngine};

/// One column strip of a frame fed row by row: frame row `y` of `fⁿ` and
/// `fⁿ⁺¹` goes in, and output row `y − 7` comes out (the bottom rows when
/// the last row arrives). The strip is `[x, x + width)`; a frame no wider
/// than the engine's tiles is one strip, a wider one is several streams
/// (one engine each) that every row is pushed to.
///
/// With a stored previous frame, push its row `y` beside each new row.
pub struct RowStream<'e, M: Memory> {
    engine: &'e mut TileEngine<M>,
    config: Config,
    rows_in: usize,
}

impl<'e, M: Memory> RowStream<'e, M> {
    /// Stream the strip `[x, x + width)` of frames of `config`'s size.
    pub fn new(
        engine: &'e mut TileEngine<M>,
        config: Config,
        x: usize,
        width: usize,
    ) -> Result<Self, Error> {
        if width == 0 || x.checked_add(width).is_none_or(|end| end > config.width()) {
            return Err(Error::TileOutOfFrame);
        }
        let max = engine.max_tile_width();
        if width > max {
            return Err(Error::TileTooWide { max });
        }
        engine.begin(Window {
            x_first: x as isize - HALO as isize,
            n: width + 2 * HALO,
            y_first: -(HALO as isize),
            t: 0,
        });
        Ok(Self {
            engine,
            config,
            rows_in: 0,
        })
    }

    /// Stream the whole frame width as one strip.
    pub fn full_width(engine: &'e mut TileEngine<M>, config: Config) -> Result<Self, Error> {
        Self::new(engine, config, 0, config.width())
    }

    /// Frame rows received so far.
    pub const fn rows_in(&self) -> usize {
        self.rows_in
    }

    /// Whether every row has arrived (and every output row has left).
    pub const fn is_finished(&self) -> bool {
        self.rows_in == self.config.height()
    }

    /// Push the next frame row of both frames (each at least the frame width
    /// long). The first row also fills the 7 rows above the frame, the last
    /// one the 7 below it (SPEC §2: reads outside the frame replicate).
    pub fn push<S: Sink>(&mut self, prev: &[u8], next: &[u8], sink: &mut S) -> Result<(), Error> {
        if self.is_finished() {
            return Err(Error::StreamFinished);
        }
        let needed = self.config.width();
        let (Some(prev), Some(next)) = (prev.get(..needed), next.get(..needed)) else {
            let got = prev.len().min(next.len());
            return Err(Error::BufferTooShort { needed, got });
        };
        let last = self.rows_in + 1 == self.config.height();
        let repeats = 1 + if self.rows_in == 0 { HALO } else { 0 } + if last { HALO } else { 0 };
        for _ in 0..repeats {
            self.engine.push(&self.config, prev, next, sink);
        }
        self.rows_in += 1;
        Ok(())
    }
}

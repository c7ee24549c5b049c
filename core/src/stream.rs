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
///
/// The stream holds its engine as `E`: borrowed (`&mut engine`, the usual
/// case) or owned, for a caller that keeps the stream across calls of its
/// own (the C API keeps one in the caller's working memory).
pub struct RowStream<E> {
    engine: E,
    config: Config,
    rows_in: usize,
}

/// An engine a [`RowStream`] can drive: a [`TileEngine`], owned or
/// borrowed.
pub trait EngineHandle {
    /// The engine's working memory.
    type Memory: Memory;
    /// The engine.
    fn engine(&mut self) -> &mut TileEngine<Self::Memory>;
}

impl<M: Memory> EngineHandle for TileEngine<M> {
    type Memory = M;
    #[inline(always)]
    fn engine(&mut self) -> &mut TileEngine<M> {
        self
    }
}

impl<E: EngineHandle + ?Sized> EngineHandle for &mut E {
    type Memory = E::Memory;
    #[inline(always)]
    fn engine(&mut self) -> &mut TileEngine<E::Memory> {
        (**self).engine()
    }
}

impl<'e, M: Memory> RowStream<&'e mut TileEngine<M>> {
    /// Stream the strip `[x, x + width)` of frames of `config`'s size.
    pub fn new(
        engine: &'e mut TileEngine<M>,
        config: Config,
        x: usize,
        width: usize,
    ) -> Result<Self, Error> {
        Self::start(engine, config, x, width).map_err(|(e, _)| e)
    }

    /// Stream the whole frame width as one strip.
    pub fn full_width(engine: &'e mut TileEngine<M>, config: Config) -> Result<Self, Error> {
        Self::new(engine, config, 0, config.width())
    }
}

impl<M: Memory> RowStream<TileEngine<M>> {
    /// Stream the whole frame width as one strip, owning the engine: for a
    /// caller that keeps the stream between calls of its own (the C API
    /// keeps one in the caller's working memory). A refused engine comes
    /// back with the error; [`RowStream::into_engine`] ends the stream.
    pub fn owning_full_width(
        engine: TileEngine<M>,
        config: Config,
    ) -> Result<Self, (Error, TileEngine<M>)> {
        Self::start(engine, config, 0, config.width())
    }
}

impl<E: EngineHandle> RowStream<E> {
    fn start(mut engine: E, config: Config, x: usize, width: usize) -> Result<Self, (Error, E)> {
        if width == 0 || x.checked_add(width).is_none_or(|end| end > config.width()) {
            return Err((Error::TileOutOfFrame, engine));
        }
        let max = engine.engine().max_tile_width();
        if width > max {
            return Err((Error::TileTooWide { max }, engine));
        }
        engine.engine().begin(Window {
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
            self.engine.engine().push(&self.config, prev, next, sink);
        }
        self.rows_in += 1;
        Ok(())
    }

    /// The configuration the stream was started with.
    pub const fn config(&self) -> &Config {
        &self.config
    }

    /// End the stream (finished or not) and give the engine back.
    pub fn into_engine(self) -> E {
        self.engine
    }
}

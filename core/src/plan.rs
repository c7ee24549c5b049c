//! How a frame is cut into tiles for an engine of a given capacity.

use core::num::NonZeroUsize;

use crate::{Config, Error, HALO};

/// One output tile: columns `[x, x + width)`, rows `[y, y + height)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Tile {
    /// First column.
    pub x: usize,
    /// First row.
    pub y: usize,
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
}

/// A validated tiling of a frame: tiles of `tile_width × tile_height` in
/// row-major order, the last ones in each row and column cut at the frame's
/// edge. Any tiling gives the same bytes, on any engine: a tile wider than
/// an engine's window runs as several windows (more halo, same bytes), so
/// choose tiles no wider than [`TileEngine::max_tile_width`](crate::TileEngine::max_tile_width)
/// to compute each once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Plan {
    config: Config,
    // Non-zero by construction, so tile arithmetic has no division-by-zero
    // path for the compiler to keep.
    tile_width: NonZeroUsize,
    tile_height: NonZeroUsize,
    across: NonZeroUsize,
    down: NonZeroUsize,
}

impl Plan {
    /// Tiles of `tile_width × tile_height` (each at least 1; larger than the
    /// frame means the whole frame).
    pub fn new(config: Config, tile_width: usize, tile_height: usize) -> Result<Self, Error> {
        let (w, h) = (config.width(), config.height());
        let tile_width = NonZeroUsize::new(tile_width.min(w)).ok_or(Error::TileOutOfFrame)?;
        let tile_height = NonZeroUsize::new(tile_height.min(h)).ok_or(Error::TileOutOfFrame)?;
        let across = NonZeroUsize::new(w.div_ceil(tile_width.get())).ok_or(Error::EmptyFrame)?;
        let down = NonZeroUsize::new(h.div_ceil(tile_height.get())).ok_or(Error::EmptyFrame)?;
        Ok(Self {
            config,
            tile_width,
            tile_height,
            across,
            down,
        })
    }

    /// Strips of `width` columns (e.g. an engine's
    /// [`MAX_TILE_WIDTH`](crate::Engine::MAX_TILE_WIDTH)), each the full
    /// frame height.
    pub fn strips(config: Config, width: usize) -> Result<Self, Error> {
        Self::new(config, width, config.height())
    }

    /// The configuration this plan tiles.
    pub const fn config(&self) -> &Config {
        &self.config
    }

    /// Tile width (at most the frame width).
    pub const fn tile_width(&self) -> usize {
        self.tile_width.get()
    }

    /// Tile height (at most the frame height).
    pub const fn tile_height(&self) -> usize {
        self.tile_height.get()
    }

    /// Tiles per row of tiles.
    pub const fn tiles_across(&self) -> usize {
        self.across.get()
    }

    /// Rows of tiles.
    pub const fn tiles_down(&self) -> usize {
        self.down.get()
    }

    /// Number of tiles.
    pub const fn tile_count(&self) -> usize {
        self.tiles_across() * self.tiles_down()
    }

    /// Tile `index` in row-major order (`None` past the last).
    pub fn tile(&self, index: usize) -> Option<Tile> {
        if index >= self.tile_count() {
            return None;
        }
        let (tx, ty) = (index % self.across, index / self.across);
        let (tw, th) = (self.tile_width.get(), self.tile_height.get());
        let (x, y) = (tx * tw, ty * th);
        Some(Tile {
            x,
            y,
            width: tw.min(self.config.width().saturating_sub(x)),
            height: th.min(self.config.height().saturating_sub(y)),
        })
    }

    /// Every tile, in row-major order.
    pub fn tiles(&self) -> impl Iterator<Item = Tile> + '_ {
        (0..self.tile_count()).filter_map(|i| self.tile(i))
    }

    /// Pixels the first stage computes (each tile with its 7-px halo on
    /// every side) and output pixels: their ratio is the tiling's overhead.
    pub fn first_stage_pixels(&self) -> (u64, u64) {
        let (w, h) = (self.config.width(), self.config.height());
        first_stage_pixels(w, h, self.tile_width.get(), self.tile_height.get())
    }
}

/// Pixels the first stage computes and output pixels, for a `width × height`
/// frame cut into tiles of at most `tile_width × tile_height`: every tile
/// reads its 7-px halo, so columns and rows each gain 14 per tile:
/// `(W + 14·⌈W/tw⌉) · (H + 14·⌈H/th⌉)` against `W · H`.
pub const fn first_stage_pixels(
    width: usize,
    height: usize,
    tile_width: usize,
    tile_height: usize,
) -> (u64, u64) {
    let across = width.div_ceil(if tile_width == 0 { 1 } else { tile_width });
    let down = height.div_ceil(if tile_height == 0 { 1 } else { tile_height });
    let computed = (width + 2 * HALO * across) as u64 * (height + 2 * HALO * down) as u64;
    (computed, width as u64 * height as u64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Params;

    #[test]
    fn closed_form_overhead_counts_every_tile() {
        for (w, h, tw, th) in [
            (640, 480, 80, 480),
            (37, 11, 5, 3),
            (1, 1, 1, 1),
            (100, 7, 100, 7),
        ] {
            let plan = Plan::new(Config::new(w, h, Params::DEFAULT).unwrap(), tw, th).unwrap();
            let by_tile: u64 = plan
                .tiles()
                .map(|t| ((t.width + 14) * (t.height + 14)) as u64)
                .sum();
            assert_eq!(plan.first_stage_pixels(), (by_tile, (w * h) as u64));
        }
        // The budget: 80-px strips of a 640×480 frame, overhead 1.209.
        assert_eq!(
            first_stage_pixels(640, 480, 80, 480),
            (8 * 94 * 494, 640 * 480)
        );
    }
}

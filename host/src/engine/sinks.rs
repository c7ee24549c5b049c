//! The engine's sinks: where a tile's rows go. One family, each keeping
//! the magnitudes' extremes of what it received: every pixel
//! ([`PixelRows`], the fields), or the two magnitudes alone in kept
//! planes ([`KeptRows`], per-frame min–max and the cues): of the whole
//! frame ([`KeptMagnitudes`]) or of a tile, with its segments of the RGB
//! image its bytes go to ([`TileRows`]).

use reynoldsflow_core::{ExtremesSink, FlowPixel, Pixels, Plan, Sink};

use super::bytes::{self, Isa};
use super::image::Image;
use crate::HostError;
use crate::engine::page_buffer::{ByteBuffer, PageBuffer};

/// One tile's (or the whole frame's) segments of a frame-sized plane of
/// pixels, and the extremes of the magnitudes it received: the sink that
/// keeps every pixel. Row `k` of `rows` is frame row `origin.1 + k` from
/// column `origin.0` on.
pub(crate) struct PixelRows<'a> {
    pub(crate) rows: Vec<&'a mut [FlowPixel]>,
    pub(crate) origin: (usize, usize),
    pub(crate) extremes: ExtremesSink,
}

impl<'a> PixelRows<'a> {
    /// Every tile of `plan` with its segments of `pixels`, a `width`-wide
    /// plane.
    pub(crate) fn split(plan: &Plan, width: usize, pixels: &'a mut [FlowPixel]) -> Vec<Self> {
        let (tile_width, tile_height) = (plan.tile_width(), plan.tile_height());
        let mut tiles: Vec<Self> = plan
            .tiles()
            .map(|tile| Self {
                rows: Vec::with_capacity(tile.height),
                origin: (tile.x, tile.y),
                extremes: ExtremesSink::default(),
            })
            .collect();
        for (y, row) in pixels.chunks_mut(width.max(1)).enumerate() {
            let first = (y / tile_height) * plan.tiles_across();
            let segments = row.chunks_mut(tile_width);
            for (tile, segment) in tiles[first..].iter_mut().zip(segments) {
                tile.rows.push(segment);
            }
        }
        tiles
    }

    /// The whole of `pixels`, a `width`-wide plane.
    pub(crate) fn whole(pixels: &'a mut [FlowPixel], width: usize) -> Self {
        Self {
            rows: pixels.chunks_mut(width.max(1)).collect(),
            origin: (0, 0),
            extremes: ExtremesSink::default(),
        }
    }
}

impl Sink for PixelRows<'_> {
    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        let (x0, y0) = self.origin;
        let start = x.saturating_sub(x0);
        if let Some(dst) = self
            .rows
            .get_mut(y.saturating_sub(y0))
            .and_then(|row| row.get_mut(start..start + pixels.len()))
        {
            for (dst, px) in dst.iter_mut().zip(pixels.iter()) {
                *dst = px;
            }
        }
        self.extremes.row(y, x, pixels);
    }
}

/// What per-frame min–max keeps of a pair until its scales are known: both
/// magnitudes of every pixel, each in its own plane (so that the byte step
/// reads them in lanes), in a [`PageBuffer`] (7.4 MB at 1280×720).
#[derive(Default)]
pub(crate) struct Kept {
    buffer: PageBuffer,
}

impl Kept {
    /// The planes `[|v_d|, |v_c|]` of `pixels` each (the memory grows,
    /// never shrinks: every value is overwritten).
    pub(crate) fn planes(&mut self, pixels: usize) -> Result<[&mut [f32]; 2], HostError> {
        let floats = self.buffer.floats(2 * pixels)?;
        let (m_d, m_c) = floats.split_at_mut(pixels);
        Ok([m_d, m_c])
    }
}

/// Where a kept-magnitudes sink keeps the pixels it receives: both
/// magnitudes, each in its own plane (so that the byte step reads them in
/// lanes).
pub(crate) trait KeptLayout {
    /// The kept planes' pixels `[x, x + len)` of frame row `y`, if they
    /// are this sink's.
    fn at(&mut self, y: usize, x: usize, len: usize) -> Option<[&mut [f32]; 2]>;
}

/// A sink that keeps the two magnitudes alone, laid out by `L`, and the
/// extremes of what it received: the first step of per-frame min–max
/// (the engine's tail writes the magnitudes in place,
/// [`Sink::magnitude_rows`]) and of the cues.
pub(crate) struct KeptRows<L> {
    layout: L,
    /// Of every pixel received so far.
    pub(crate) extremes: ExtremesSink,
}

impl<L: KeptLayout> Sink for KeptRows<L> {
    fn reads_fields(&self) -> bool {
        false
    }

    #[inline(always)]
    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        if let Some([m_d, m_c]) = self.layout.at(y, x, pixels.len()) {
            m_d.copy_from_slice(pixels.m_d);
            m_c.copy_from_slice(pixels.m_c);
        }
        self.extremes.row(y, x, pixels);
    }

    #[inline(always)]
    fn magnitude_rows(&mut self, y: usize, x: usize, width: usize) -> Option<[&mut [f32]; 2]> {
        self.layout.at(y, x, width)
    }

    #[inline(always)]
    fn kept_row(&mut self, _y: usize, _x: usize, _luma: &[u8], extremes: ExtremesSink) {
        self.extremes.merge(extremes);
    }
}

/// Whole-frame planes `[|v_d|, |v_c|]`, row-major, `width` wide: the
/// layout of a pair one thread computes.
pub(crate) struct FramePlanes<'a> {
    width: usize,
    planes: [&'a mut [f32]; 2],
}

impl KeptLayout for FramePlanes<'_> {
    #[inline(always)]
    fn at(&mut self, y: usize, x: usize, len: usize) -> Option<[&mut [f32]; 2]> {
        let start = y * self.width + x;
        let [m_d, m_c] = &mut self.planes;
        Some([
            m_d.get_mut(start..start + len)?,
            m_c.get_mut(start..start + len)?,
        ])
    }
}

/// The magnitudes of a whole frame, kept until its scales are known.
pub(crate) type KeptMagnitudes<'a> = KeptRows<FramePlanes<'a>>;

impl<'a> KeptMagnitudes<'a> {
    /// Nothing received yet into `planes`, each `width` wide.
    pub(crate) fn new(width: usize, planes: [&'a mut [f32]; 2]) -> Self {
        Self {
            layout: FramePlanes { width, planes },
            extremes: ExtremesSink::default(),
        }
    }

    /// The second step, once every pixel is kept: the frame's scales from
    /// the extremes, then the bytes (`luma`: `fⁿ`) into `rgb`.
    pub(crate) fn into_bytes(
        self,
        isa: Isa,
        luma: &[u8],
        rgb: &mut impl ByteBuffer,
    ) -> Result<(), HostError> {
        let (scale_d, scale_c) = self.extremes.byte_scales();
        let [m_d, m_c] = self.layout.planes;
        let rgb = rgb.overwrite(3 * luma.len())?;
        bytes::kept_to_bytes(isa, [m_d, m_c], luma, rgb, &[scale_d, scale_c]);
        Ok(())
    }
}

/// One tile's segments of the frame's kept planes and of its RGB image,
/// row by row: the layout a thread computes a tile into. Row `k` of each
/// is frame row `origin.1 + k` from column `origin.0` on.
pub(crate) struct TileSegments<'a> {
    origin: (usize, usize),
    m_d: Vec<&'a mut [f32]>,
    m_c: Vec<&'a mut [f32]>,
    rgb: Vec<&'a mut [u8]>,
}

impl KeptLayout for TileSegments<'_> {
    #[inline(always)]
    fn at(&mut self, y: usize, x: usize, len: usize) -> Option<[&mut [f32]; 2]> {
        let (x0, y0) = self.origin;
        let row = y.checked_sub(y0)?;
        let start = x.checked_sub(x0)?;
        let m_d = self.m_d.get_mut(row)?.get_mut(start..start + len)?;
        let m_c = self.m_c.get_mut(row)?.get_mut(start..start + len)?;
        Some([m_d, m_c])
    }
}

/// One tile's kept magnitudes and bytes, and the extremes it received.
pub(crate) type TileRows<'a> = KeptRows<TileSegments<'a>>;

impl<'a> TileRows<'a> {
    /// Every tile of `plan` with its segments of `planes` and `rgb`, all
    /// `width` pixels wide.
    pub(crate) fn split(
        plan: &Plan,
        width: usize,
        planes: [&'a mut [f32]; 2],
        rgb: &'a mut [u8],
    ) -> Vec<Self> {
        let mut tiles: Vec<Self> = plan
            .tiles()
            .map(|tile| KeptRows {
                layout: TileSegments {
                    origin: (tile.x, tile.y),
                    m_d: Vec::with_capacity(tile.height),
                    m_c: Vec::with_capacity(tile.height),
                    rgb: Vec::with_capacity(tile.height),
                },
                extremes: ExtremesSink::default(),
            })
            .collect();
        let (tile_width, tile_height) = (plan.tile_width(), plan.tile_height());
        let [m_d, m_c] = planes;
        let rows = m_d
            .chunks_mut(width)
            .zip(m_c.chunks_mut(width))
            .zip(rgb.chunks_mut(3 * width));
        for (y, ((m_d, m_c), rgb)) in rows.enumerate() {
            let first = (y / tile_height) * plan.tiles_across();
            let segments = m_d
                .chunks_mut(tile_width)
                .zip(m_c.chunks_mut(tile_width))
                .zip(rgb.chunks_mut(3 * tile_width));
            for (tile, ((m_d, m_c), rgb)) in tiles[first..].iter_mut().zip(segments) {
                tile.layout.m_d.push(m_d);
                tile.layout.m_c.push(m_c);
                tile.layout.rgb.push(rgb);
            }
        }
        tiles
    }

    /// The tile's bytes from its kept magnitudes, in `scales`, arranged
    /// as `image` (`luma`: the frame `width` wide).
    pub(crate) fn bytes(
        &mut self,
        isa: Isa,
        luma: &[u8],
        width: usize,
        scales: &[reynoldsflow_core::ByteScale; 2],
        image: &Image,
    ) {
        let TileSegments {
            origin: (x0, y0),
            m_d,
            m_c,
            rgb,
        } = &mut self.layout;
        let rows = m_d.iter().zip(m_c.iter()).zip(rgb.iter_mut());
        for (k, ((m_d, m_c), rgb)) in rows.enumerate() {
            let start = (*y0 + k) * width + *x0;
            let luma = &luma[start..start + m_d.len()];
            bytes::kept_to_bytes(isa, [m_d, m_c], luma, rgb, scales);
            image.arrange(rgb);
        }
    }
}

/// An RGB buffer of exactly the image's length.
pub(crate) struct Exact<'a>(pub(crate) &'a mut [u8]);

impl ByteBuffer for Exact<'_> {
    fn overwrite(&mut self, len: usize) -> Result<&mut [u8], HostError> {
        let have = self.0.len();
        self.0
            .get_mut(..len)
            .filter(|_| len == have)
            .ok_or_else(|| {
                HostError::invalid(
                    "image buffer",
                    format!("{have} bytes for an image of {len}"),
                )
            })
    }
}

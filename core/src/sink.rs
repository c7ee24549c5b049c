//! Ready-made sinks: field planes, the RGB representation, and extremes.

use crate::kernels::{KernelSet, Native};
use crate::{ByteScale, Config, Error, Extremes, FlowPixel, Pixels, Sink};

/// Check that an output plane holds a whole frame.
pub(crate) fn check_len(config: &Config, len: usize, per_pixel: usize) -> Result<(), Error> {
    let needed = config.width() * config.height() * per_pixel;
    if len < needed {
        return Err(Error::BufferTooShort { needed, got: len });
    }
    Ok(())
}

/// The pixels of one output row segment inside a row-major plane.
fn segment<T>(
    plane: &mut [T],
    width: usize,
    per_pixel: usize,
    y: usize,
    x: usize,
    len: usize,
) -> &mut [T] {
    let start = (y * width + x) * per_pixel;
    plane
        .get_mut(start..start + len * per_pixel)
        .unwrap_or(&mut [])
}

/// Which field planes [`FieldPlanes`] writes; `None` skips a plane.
#[derive(Debug, Default)]
pub struct FieldPlanes<'a> {
    /// `v_c` x, row-major, `width · height`.
    pub v_c_x: Option<&'a mut [f32]>,
    /// `v_c` y.
    pub v_c_y: Option<&'a mut [f32]>,
    /// `v_d` x.
    pub v_d_x: Option<&'a mut [f32]>,
    /// `v_d` y.
    pub v_d_y: Option<&'a mut [f32]>,
    /// `|v_c|`.
    pub m_c: Option<&'a mut [f32]>,
    /// `|v_d|`.
    pub m_d: Option<&'a mut [f32]>,
}

/// A sink that writes the fields into caller-provided planes.
#[derive(Debug)]
pub struct FieldSink<'a> {
    planes: FieldPlanes<'a>,
    width: usize,
}

impl<'a> FieldSink<'a> {
    /// Check every given plane against the frame size.
    pub fn new(config: &Config, planes: FieldPlanes<'a>) -> Result<Self, Error> {
        let lens = [
            planes.v_c_x.as_ref().map(|p| p.len()),
            planes.v_c_y.as_ref().map(|p| p.len()),
            planes.v_d_x.as_ref().map(|p| p.len()),
            planes.v_d_y.as_ref().map(|p| p.len()),
            planes.m_c.as_ref().map(|p| p.len()),
            planes.m_d.as_ref().map(|p| p.len()),
        ];
        for len in lens.into_iter().flatten() {
            check_len(config, len, 1)?;
        }
        Ok(Self {
            planes,
            width: config.width(),
        })
    }
}

/// Copy one row of the segment into its plane, if the plane is asked for.
fn write_plane<T: Copy>(
    plane: &mut Option<&mut [T]>,
    width: usize,
    (y, x): (usize, usize),
    row: &[T],
) {
    if let Some(plane) = plane {
        let out = segment(plane, width, 1, y, x, row.len());
        if let Some(row) = row.get(..out.len()) {
            out.copy_from_slice(row);
        }
    }
}

impl Sink for FieldSink<'_> {
    #[inline(always)]
    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        let (p, w) = (&mut self.planes, self.width);
        // `reads_fields` is true, so the engine gives them.
        if let Some(fields) = pixels.fields {
            write_plane(&mut p.v_c_x, w, (y, x), fields.v_c[0]);
            write_plane(&mut p.v_c_y, w, (y, x), fields.v_c[1]);
            write_plane(&mut p.v_d_x, w, (y, x), fields.v_d[0]);
            write_plane(&mut p.v_d_y, w, (y, x), fields.v_d[1]);
        }
        write_plane(&mut p.m_c, w, (y, x), pixels.m_c);
        write_plane(&mut p.m_d, w, (y, x), pixels.m_d);
    }
}

/// The representation's bytes `[R, G, B] = [|v_d|, |v_c|, fⁿ]` of one pixel.
#[inline(always)]
pub fn rgb(px: &FlowPixel, scale_d: &ByteScale, scale_c: &ByteScale) -> [u8; 3] {
    rgb_of(px.m_d, px.m_c, px.luma, [scale_d, scale_c])
}

/// [`rgb`] from the three values it reads.
#[inline(always)]
fn rgb_of(m_d: f32, m_c: f32, luma: u8, [scale_d, scale_c]: [&ByteScale; 2]) -> [u8; 3] {
    [scale_d.byte(m_d), scale_c.byte(m_c), luma]
}

/// [`rgb`] of every pixel of a row segment, into `out` (as many as the
/// shorter has), in the target's kernel set: where rows take vector lanes
/// in batches of [`RGB_BATCH`] ([`rgb_batch`]), on aarch64 sixteen pixels
/// a step in NEON lanes (`kernels/neon.rs`), one pixel at a time elsewhere.
#[inline(always)]
pub fn rgb_row(pixels: Pixels<'_>, scale_d: &ByteScale, scale_c: &ByteScale, out: &mut [[u8; 3]]) {
    Native::rgb_row(pixels, [scale_d, scale_c], out);
}

/// [`rgb_row`] as the portable kernels write it (`KernelSet::rgb_row`'s
/// default): in batches of [`RGB_BATCH`] where rows take vector lanes,
/// the rest in the set's `rgb_pixels`.
#[inline(always)]
pub(crate) fn batched_rgb_row<K: KernelSet>(
    m_d: &[f32],
    m_c: &[f32],
    luma: &[u8],
    [scale_d, scale_c]: [&ByteScale; 2],
    out: &mut [[u8; 3]],
) {
    let (mut m_d, mut m_c, mut luma, mut out) = (m_d, m_c, luma, out);
    if crate::VECTOR_ROWS {
        let (md, md_rest) = m_d.as_chunks::<RGB_BATCH>();
        let (mc, mc_rest) = m_c.as_chunks::<RGB_BATCH>();
        let (l, l_rest) = luma.as_chunks::<RGB_BATCH>();
        let (o, o_rest) = out.as_chunks_mut::<RGB_BATCH>();
        for (o, ((md, mc), l)) in o.iter_mut().zip(md.iter().zip(mc).zip(l)) {
            rgb_batch([md, mc], l, [scale_d, scale_c], o);
        }
        (m_d, m_c, luma, out) = (md_rest, mc_rest, l_rest, o_rest);
    }
    // The rest one pixel at a time, in the set's kernel.
    K::rgb_pixels(m_d, m_c, luma, [scale_d, scale_c], out);
}

/// [`rgb_row`]'s pixels one at a time (all of them on the scalar boards,
/// the batches' remainder elsewhere).
#[inline(always)]
pub(crate) fn portable_rgb_tail(
    m_d: &[f32],
    m_c: &[f32],
    luma: &[u8],
    scales: [&ByteScale; 2],
    out: &mut [[u8; 3]],
) {
    let values = m_d.iter().zip(m_c).zip(luma);
    for (dst, ((&m_d, &m_c), &luma)) in out.iter_mut().zip(values) {
        *dst = rgb_of(m_d, m_c, luma, scales);
    }
}

/// Pixels of one [`rgb_row`] batch on targets whose rows take vector lanes:
/// the bytes of each channel in lanes, then one interleaving loop.
pub const RGB_BATCH: usize = 32;

/// [`rgb`] of `N` pixels given as rows: each channel's bytes in one loop
/// (vector lanes where the target has them), then interleaved with `fⁿ`.
#[inline(always)]
pub fn rgb_batch<const N: usize>(
    [m_d, m_c]: [&[f32; N]; 2],
    luma: &[u8; N],
    [scale_d, scale_c]: [&ByteScale; 2],
    out: &mut [[u8; 3]; N],
) {
    let (mut r, mut g) = ([0u8; N], [0u8; N]);
    for i in 0..N {
        (r[i], g[i]) = (scale_d.byte(m_d[i]), scale_c.byte(m_c[i]));
    }
    let out = out.as_flattened_mut();
    for i in 0..N {
        out[3 * i] = r[i];
        out[3 * i + 1] = g[i];
        out[3 * i + 2] = luma[i];
    }
}

/// A sink that writes the RGB8 representation into a row-major plane of
/// `3 · width · height` bytes.
#[derive(Debug)]
pub struct RgbSink<'a> {
    rgb: &'a mut [u8],
    width: usize,
    scale_d: ByteScale,
    scale_c: ByteScale,
}

impl<'a> RgbSink<'a> {
    /// Check the plane's size; bytes are made with these two scales.
    pub fn new(
        config: &Config,
        rgb: &'a mut [u8],
        scale_d: ByteScale,
        scale_c: ByteScale,
    ) -> Result<Self, Error> {
        check_len(config, rgb.len(), 3)?;
        Ok(Self {
            rgb,
            width: config.width(),
            scale_d,
            scale_c,
        })
    }
}

impl Sink for RgbSink<'_> {
    fn reads_fields(&self) -> bool {
        false
    }

    #[inline(always)]
    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        let out = segment(self.rgb, self.width, 3, y, x, pixels.len());
        let out = out.as_chunks_mut::<3>().0;
        rgb_row(pixels, &self.scale_d, &self.scale_c, out);
    }
}

/// A sink that records the extremes of both magnitudes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ExtremesSink {
    /// Extremes of `|v_d|`.
    pub m_d: Extremes,
    /// Extremes of `|v_c|`.
    pub m_c: Extremes,
}

impl ExtremesSink {
    /// The extremes of the magnitudes of a row segment.
    pub(crate) fn of_rows(m_d: &[f32], m_c: &[f32]) -> Self {
        let mut extremes = Self::default();
        extremes.m_d.add_all(m_d);
        extremes.m_c.add_all(m_c);
        extremes
    }

    /// Merge the extremes of another part of the frame.
    pub fn merge(&mut self, other: ExtremesSink) {
        self.m_d.merge(other.m_d);
        self.m_c.merge(other.m_c);
    }

    /// The per-frame min–max byte maps of `|v_d|` and `|v_c|`.
    pub fn byte_scales(&self) -> (ByteScale, ByteScale) {
        (self.m_d.byte_scale(), self.m_c.byte_scale())
    }
}

impl Sink for ExtremesSink {
    fn reads_fields(&self) -> bool {
        false
    }

    #[inline(always)]
    fn row(&mut self, _y: usize, _x: usize, pixels: Pixels<'_>) {
        self.m_d.add_all(pixels.m_d);
        self.m_c.add_all(pixels.m_c);
    }
}

//! Where the engine's rows go for C: caller frame buffers (`rf_outputs`)
//! or a row callback (`rf_row`), plus the optional pieces around them.

use core::ffi::c_void;
use core::ptr;

use reynoldsflow_core::{ByteScale, Pixels, Sink, rgb_row};

use crate::config::Variant;

/// One output row segment, as a row callback sees it: pixels
/// `[x, x + width)` of frame row `y`. The pointers are valid only during
/// the callback.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[allow(non_camel_case_types)]
pub struct rf_row {
    /// Frame row.
    pub y: u32,
    /// First column.
    pub x: u32,
    /// Pixels in the segment.
    pub width: u32,
    /// `3 · width` bytes of RGB8.
    pub rgb: *const u8,
    /// `width` values of `|v_d|`, px.
    pub m_d: *const f32,
    /// `width` values of `|v_c|`, px.
    pub m_c: *const f32,
    /// `2 · width` values of `v_c` as (x, y) pairs, px, y down; NULL unless
    /// the configuration has `RF_FLAG_ROW_FIELDS`.
    pub v_c: *const f32,
    /// `v_d` as `v_c`.
    pub v_d: *const f32,
}

/// A row callback: `user` is the pointer given with it. It must not call
/// the library with the same engine.
#[allow(non_camel_case_types)]
pub type rf_row_fn = Option<unsafe extern "C" fn(user: *mut c_void, row: *const rf_row)>;

/// A sink that may be absent.
pub(crate) struct Maybe<S>(pub(crate) Option<S>);

impl<S: Sink> Sink for Maybe<S> {
    fn reads_fields(&self) -> bool {
        self.0.as_ref().is_some_and(Sink::reads_fields)
    }

    #[inline(always)]
    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        if let Some(sink) = &mut self.0 {
            sink.row(y, x, pixels);
        }
    }
}

/// `v_c` or `v_d` of a row segment as (x, y) pairs.
fn pairs(out: &mut [[f32; 2]], [xs, ys]: [&[f32]; 2]) {
    for (o, (&x, &y)) in out.iter_mut().zip(xs.iter().zip(ys)) {
        *o = [x, y];
    }
}

/// The first `n` elements of `s` (all of them if fewer).
fn first<T>(s: &mut [T], n: usize) -> &mut [T] {
    let n = n.min(s.len());
    &mut s[..n]
}

/// The segment `[x, x + n)` of row `y` of a plane `width` wide with `per`
/// values a pixel (empty if outside: never, once the lengths are checked).
fn segment<T>(
    plane: &mut [T],
    width: usize,
    per: usize,
    (y, x, n): (usize, usize, usize),
) -> &mut [T] {
    let start = (y * width + x) * per;
    plane.get_mut(start..start + n * per).unwrap_or(&mut [])
}

/// Fields and magnitudes into the caller's frame-sized buffers (each
/// checked to hold the frame before the sink exists).
pub(crate) struct FrameBuffers<'a> {
    pub(crate) width: usize,
    pub(crate) v_c: Option<&'a mut [[f32; 2]]>,
    pub(crate) v_d: Option<&'a mut [[f32; 2]]>,
    pub(crate) m_c: Option<&'a mut [f32]>,
    pub(crate) m_d: Option<&'a mut [f32]>,
}

impl Sink for FrameBuffers<'_> {
    fn reads_fields(&self) -> bool {
        self.v_c.is_some() || self.v_d.is_some()
    }

    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        let at = (y, x, pixels.len());
        if let Some(fields) = pixels.fields {
            if let Some(plane) = &mut self.v_c {
                pairs(segment(plane, self.width, 1, at), fields.v_c);
            }
            if let Some(plane) = &mut self.v_d {
                pairs(segment(plane, self.width, 1, at), fields.v_d);
            }
        }
        for (plane, row) in [(&mut self.m_c, pixels.m_c), (&mut self.m_d, pixels.m_d)] {
            if let Some(plane) = plane {
                for (o, &m) in segment(plane, self.width, 1, at).iter_mut().zip(row) {
                    *o = m;
                }
            }
        }
    }
}

/// Each row segment's bytes (and fields, if asked) made in row buffers of
/// the working memory, then handed to the caller's callback.
pub(crate) struct RowCallback<'a> {
    pub(crate) scales: (ByteScale, ByteScale),
    pub(crate) variant: Variant,
    /// At least the widest segment.
    pub(crate) rgb: &'a mut [[u8; 3]],
    /// Twice the widest segment (`v_c`, then `v_d`), or empty: no fields.
    pub(crate) fields: &'a mut [[f32; 2]],
    pub(crate) callback: unsafe extern "C" fn(*mut c_void, *const rf_row),
    pub(crate) user: *mut c_void,
}

impl Sink for RowCallback<'_> {
    fn reads_fields(&self) -> bool {
        !self.fields.is_empty()
    }

    // Out of line: the call through the caller's pointer stays in a function
    // of its own, the one indirect call `scripts/embedded-check`'s walk of
    // the call graph allows (inlined, it landed in `rf_represent_rows`).
    #[inline(never)]
    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        let rgb = first(self.rgb, pixels.len());
        let n = rgb.len();
        rgb_row(pixels, &self.scales.0, &self.scales.1, rgb);
        self.variant.apply(rgb);
        let (mut v_c, mut v_d) = (ptr::null(), ptr::null());
        if let (Some(f), false) = (pixels.fields, self.fields.is_empty()) {
            // `fields` holds twice the widest segment: `n` pairs each.
            let (c, d) = self.fields.split_at_mut(self.fields.len() / 2);
            let (c, d) = (first(c, n), first(d, n));
            pairs(c, f.v_c);
            pairs(d, f.v_d);
            (v_c, v_d) = (c.as_ptr().cast(), d.as_ptr().cast());
        }
        let row = rf_row {
            y: y as u32,
            x: x as u32,
            width: n as u32,
            rgb: rgb.as_ptr().cast(),
            m_d: pixels.m_d.as_ptr(),
            m_c: pixels.m_c.as_ptr(),
            v_c,
            v_d,
        };
        // SAFETY: a non-NULL function pointer the caller gave for this call
        // (checked when the sink was made); `row` and what it points to
        // live until it returns.
        unsafe { (self.callback)(self.user, &row) };
    }
}

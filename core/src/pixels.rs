//! What the engine hands a [`Sink`](crate::Sink): one output row segment
//! as rows, one per quantity ([`Pixels`]), and one pixel's values
//! ([`FlowPixel`]) for sinks that take them a pixel at a time.
//!
//! Rows, not an array of pixels: the tail writes each quantity where the
//! sink reads it, and a sink that wants one quantity reads only its row
//! (the bytes read the magnitudes, the extremes scan them, field planes
//! copy them), in vector lanes where the target has them. An array of
//! 40-byte pixels cost the x86-64 `run` path a store and a load of every
//! pixel between tail and sink, and the engine 40 bytes a window column.

/// Everything the representation knows about one pixel.
///
/// The fields are computed only for sinks that ask for them
/// ([`Sink::reads_fields`](crate::Sink::reads_fields)); for the others
/// they are zero.
///
/// Every value is in pixels, an IEEE binary32 (`f32`) with the same bits on
/// every target (`tail.rs`): finite, and the magnitudes non-negative.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlowPixel {
    /// Curl-free field `v_c` (x, y): the exact integer `V` times `s/768`,
    /// rounded once.
    pub v_c: [f32; 2],
    /// Divergence-free field `v_d` (x, y), from the `f32` solve.
    pub v_d: [f32; 2],
    /// `|v_c|`, from the exact `V` (relative error below 2⁻²²).
    pub m_c: f32,
    /// `|v_d|`, from the solve's numerators (never from a rounded field).
    pub m_d: f32,
    /// The pixel of `fⁿ` (the representation's B channel).
    pub luma: u8,
}

/// The fields of an output row segment, one row per component.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Fields<'a> {
    /// `v_c` x and y (see [`FlowPixel::v_c`]).
    pub v_c: [&'a [f32]; 2],
    /// `v_d` x and y (see [`FlowPixel::v_d`]).
    pub v_d: [&'a [f32]; 2],
}

/// One output row segment: pixels `[x, x + len)` of a frame row, each
/// quantity a row of `len` values (the engine makes them equally long).
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Pixels<'a> {
    /// `|v_d|` (see [`FlowPixel::m_d`]).
    pub m_d: &'a [f32],
    /// `|v_c|` (see [`FlowPixel::m_c`]).
    pub m_c: &'a [f32],
    /// `fⁿ`.
    pub luma: &'a [u8],
    /// The fields, for sinks that read them
    /// ([`Sink::reads_fields`](crate::Sink::reads_fields)); `None` for
    /// the others.
    pub fields: Option<Fields<'a>>,
}

impl<'a> Pixels<'a> {
    /// Pixels in the segment.
    pub fn len(&self) -> usize {
        self.m_d.len()
    }

    /// Whether the segment has no pixel.
    pub fn is_empty(&self) -> bool {
        self.m_d.is_empty()
    }

    /// The segment's pixels one at a time (fields zero where there are
    /// none): for sinks that want whole pixels rather than rows.
    pub fn iter(&self) -> impl Iterator<Item = FlowPixel> + 'a {
        let zero: &[f32] = &[];
        let Fields { v_c, v_d } = self.fields.unwrap_or(Fields {
            v_c: [zero; 2],
            v_d: [zero; 2],
        });
        let field = move |row: &'a [f32], i: usize| row.get(i).copied().unwrap_or_default();
        let magnitudes = self.m_d.iter().zip(self.m_c).zip(self.luma);
        magnitudes
            .enumerate()
            .map(move |(i, ((&m_d, &m_c), &luma))| FlowPixel {
                v_c: [field(v_c[0], i), field(v_c[1], i)],
                v_d: [field(v_d[0], i), field(v_d[1], i)],
                m_c,
                m_d,
                luma,
            })
    }
}

//! The structure sums, the tail and the bytes in NEON lanes, through intrinsics, for
//! aarch64 (companion boards: Raspberry Pi 4/5, Jetson Orin's CPU). NEON is
//! part of every aarch64 target this builds for (`target_feature = "neon"`),
//! so the set is fixed at compile time: the firmware's and the host's
//! [`Native`](super::Native).
//!
//! With it the engine keeps each sums ring (the three integer channels',
//! the two `f32` ones') in blocks of [`BLOCK`] output columns: a block holds
//! those columns of every channel of all five rows of the ring, row slot by
//! row slot. One loop then does an output row's work: the vertical `G` of
//! the five sums, the solve, both magnitudes and their extremes (or the
//! fields, for sinks that read them), four pixels a step, reading each ring
//! through one pointer at constant offsets (the loop is compiled once per
//! slot of the window's first row), where neighbouring vectors load in
//! pairs (`LDP`). The portable layout (a ring per channel) read 25 rows
//! through 25 pointers and took the sums to memory and back between the
//! vertical `G` and the tail.
//!
//! The representation's bytes take sixteen pixels a step: both
//! magnitudes' bytes in lanes and `fⁿ`'s, interleaved by one `ST3`, where
//! the portable batches went through the stack and an interleaving loop
//! the compiler kept scalar.
//!
//! Every operation is the portable one, in the same order, so the bytes
//! are the same (`kernel_check`, run under `qemu-aarch64`): exact integer
//! sums, and the `f32` steps of `stages` and `tail` each rounded once. The
//! one fused multiply-add is exact: in an `f32` binomial `((a + e) + (b +
//! d)·4) + c·6`, `(b + d)·4` is exact (a power of two, no overflow, no
//! subnormal: the products are 0 or at least 2⁻²⁰), so `fma(a + e, b + d,
//! 4)` rounds the same sum once, as the two steps do. `FMAX` takes the
//! determinant's clamp: it differs from the portable select only on NaNs
//! and signed zeros, and the determinant is neither (`tail`'s table).
//!
//! `unsafe` here: the calls of the `#[target_feature(enable = "neon")]`
//! functions, which the module's `cfg` (NEON in the build's features)
//! makes sound, and the loads and stores of four (bytes: sixteen) lanes,
//! each within a row whose length is checked once a row.
#![allow(unsafe_code)]

use core::arch::aarch64::{
    float32x4_t, int32x4_t, uint8x16_t, uint8x16x3_t, vaddq_f32, vaddq_s32, vcvtq_f32_s32,
    vcvtq_u32_f32, vdivq_f32, vdupq_n_f32, vdupq_n_s32, vdupq_n_u32, vfmaq_f32, vld1q_f32,
    vld1q_s32, vld1q_u8, vmaxq_f32, vmaxq_u32, vmaxvq_u32, vminq_u32, vminvq_u32, vmulq_f32,
    vqmovn_high_u16, vqmovn_high_u32, vqmovn_u16, vqmovn_u32, vreinterpretq_u32_f32, vshlq_n_s32,
    vsqrtq_f32, vst1q_f32, vst1q_s32, vst3q_u8, vsubq_f32,
};

use super::{KernelSet, OutputRow, Products, SumRings};
use crate::ring::take;
use crate::schedule::{HALO, SUM_DEPTH, SUM_RADIUS};
use crate::stages::{FLOAT_CHANNELS, INT_CHANNELS, Sample};
use crate::tail::{TailConstants, TailOut};
use crate::{ByteScale, Extremes, ExtremesSink};

/// The NEON set: the portable row kernels, the structure sums in blocks
/// ([`BlockedSums`]) and the tail in lanes.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Neon;

impl KernelSet for Neon {
    type Sums<'m> = BlockedSums<'m>;

    /// [`RGB_STEP`] pixels a step in lanes ([`rgb_steps`]), the rest one
    /// at a time.
    #[inline(always)]
    fn rgb_row(
        m_d: &[f32],
        m_c: &[f32],
        luma: &[u8],
        scales: [&ByteScale; 2],
        out: &mut [[u8; 3]],
    ) {
        let n = out.len().min(m_d.len()).min(m_c.len()).min(luma.len());
        let whole = n - n % RGB_STEP;
        let (Some((m_d, d_rest)), Some((m_c, c_rest)), Some((luma, l_rest)), Some((out, o_rest))) = (
            m_d.split_at_checked(whole),
            m_c.split_at_checked(whole),
            luma.split_at_checked(whole),
            out.split_at_mut_checked(whole),
        ) else {
            return;
        };
        // SAFETY: NEON is in the build's features (the module's `cfg`).
        unsafe { rgb_steps([m_d, m_c], luma, scales.map(ByteScale::parts), out) };
        Self::rgb_pixels(d_rest, c_rest, l_rest, scales, o_rest);
    }
}

/// Pixels a step of [`rgb_steps`]: sixteen bytes a channel, one `ST3`.
const RGB_STEP: usize = 16;

/// `ByteScale::byte` of sixteen magnitudes from `m`: `(m − offset) · gain
/// + ½`, each step rounded once as the portable one (no fused step), then
/// `FCVTZU` (toward zero, saturating to `u32`, NaN to 0) and two
/// saturating narrowings: Rust's saturating `t as u8`, lane by lane.
///
/// # Safety
/// `m` points to sixteen readable values.
#[inline]
#[target_feature(enable = "neon")]
unsafe fn bytes_at(m: *const f32, [offset, gain]: [float32x4_t; 2]) -> uint8x16_t {
    let word = |k: usize| {
        // SAFETY: the caller's (`k < 4`).
        let m = unsafe { vld1q_f32(m.add(4 * k)) };
        let t = vaddq_f32(vmulq_f32(vsubq_f32(m, offset), gain), vdupq_n_f32(0.5));
        vcvtq_u32_f32(t)
    };
    let low = vqmovn_high_u32(vqmovn_u32(word(0)), word(1));
    let high = vqmovn_high_u32(vqmovn_u32(word(2)), word(3));
    vqmovn_high_u16(vqmovn_u16(low), high)
}

/// The bytes of `out.len() / RGB_STEP` steps of [`RGB_STEP`] pixels: each
/// magnitude's bytes ([`bytes_at`]) and `fⁿ`, interleaved by one `ST3`.
/// `scales`: `ByteScale::parts` of `|v_d|`'s and `|v_c|`'s.
#[target_feature(enable = "neon")]
fn rgb_steps([m_d, m_c]: [&[f32]; 2], luma: &[u8], scales: [[f32; 2]; 2], out: &mut [[u8; 3]]) {
    let steps = out.len().min(m_d.len()).min(m_c.len()).min(luma.len()) / RGB_STEP;
    let [d, c] = scales.map(|[offset, gain]| [vdupq_n_f32(offset), vdupq_n_f32(gain)]);
    for s in 0..steps {
        let i = s * RGB_STEP;
        // SAFETY: `i + RGB_STEP` is within every row (`steps`).
        unsafe {
            let r = bytes_at(m_d.as_ptr().add(i), d);
            let g = bytes_at(m_c.as_ptr().add(i), c);
            let b = vld1q_u8(luma.as_ptr().add(i));
            vst3q_u8(out.as_mut_ptr().add(i).cast::<u8>(), uint8x16x3_t(r, g, b));
        }
    }
}

/// The sums' rings in blocks (module doc): the integer channels' ring and
/// the `f32` ones', each `SUM_DEPTH · K · cols` values for `K` channels
/// (the memory of the portable layout's rings).
pub(crate) struct BlockedSums<'m> {
    ints: &'m mut [i32],
    floats: &'m mut [f32],
}

impl<'m> SumRings<'m, Neon> for BlockedSums<'m> {
    #[inline(always)]
    fn carve(_: Neon, words: &mut &'m mut [i32], floats: &mut &'m mut [f32], cols: usize) -> Self {
        Self {
            ints: take(words, SUM_DEPTH * INTS * cols),
            floats: take(floats, SUM_DEPTH * FLOATS * cols),
        }
    }

    #[inline(always)]
    fn store_row(&mut self, t: usize, (ints, floats): Products<'_, 'm>, n: usize) {
        let ints = ints.each_ref().map(|row| &row[..]);
        let floats = floats.each_ref().map(|row| &row[..]);
        horizontal_sums(ints, floats, (self.ints, self.floats, t % SUM_DEPTH), n);
    }

    /// The vertical `G` is the tail's own, from the blocks.
    #[inline(always)]
    fn tail_row(&mut self, row: OutputRow<'_, 'm>, out: TailOut<'_>) -> Option<ExtremesSink> {
        let OutputRow {
            o, v, constants, ..
        } = row;
        let rows = BlockedRows {
            ints: self.ints,
            floats: self.floats,
            first_slot: (o - SUM_RADIUS) % SUM_DEPTH,
            v,
        };
        Some(tail_row(constants, &rows, out))
    }
}

/// Output columns a block: one NEON vector of each channel of each row.
const BLOCK: usize = 4;

/// Integer channels (`X², XY, Y²`) and `f32` channels (`X·Dn′`, `Y·Dn′`).
const INTS: usize = INT_CHANNELS;
const FLOATS: usize = FLOAT_CHANNELS;

/// Values a block of a ring of `K` channels: output column `4b + j` of
/// channel `ch` of the row in slot `s` (window row `t` is in slot
/// `t mod 5`) at `b · ring_block(K) + (s · K + ch) · 4 + j`. A ring of rows
/// `cols` long per channel holds `⌈w / 4⌉` blocks (`4 ⌈w / 4⌉ < w + 14`).
const fn ring_block(k: usize) -> usize {
    SUM_DEPTH * k * BLOCK
}

/// Where lane 0 of channel `ch` of slot `slot` of block `b` lies.
const fn at(k: usize, b: usize, slot: usize, ch: usize) -> usize {
    b * ring_block(k) + (slot * k + ch) * BLOCK
}

/// Blocks of a row of `w` output columns.
const fn blocks(w: usize) -> usize {
    w.div_ceil(BLOCK)
}

/// `a + 4b + 6c + 4d + e`, as `4(b + c + d) + 2c + a + e` (exact in `i32`:
/// every sum of the engine's is within `2²⁸`).
#[inline]
#[target_feature(enable = "neon")]
fn binomial(a: int32x4_t, b: int32x4_t, c: int32x4_t, d: int32x4_t, e: int32x4_t) -> int32x4_t {
    let inner = vshlq_n_s32::<2>(vaddq_s32(vaddq_s32(b, c), d));
    let outer = vaddq_s32(vaddq_s32(vaddq_s32(c, c), a), e);
    vaddq_s32(inner, outer)
}

/// `((a + e) + (b + d)·4) + c·6`, rounded as `Sample::binomial` for `f32`
/// (module doc: the one FMA is exact).
#[inline]
#[target_feature(enable = "neon")]
fn binomial_f(
    a: float32x4_t,
    b: float32x4_t,
    c: float32x4_t,
    d: float32x4_t,
    e: float32x4_t,
) -> float32x4_t {
    let sum = vfmaq_f32(vaddq_f32(a, e), vaddq_f32(b, d), vdupq_n_f32(4.0));
    vaddq_f32(sum, vmulq_f32(c, vdupq_n_f32(6.0)))
}

/// The two kinds of sums in lanes, four values a vector: exact `i32`s
/// ([`binomial`]) and `f32`s ([`binomial_f`]).
trait Lanes: Sample {
    type Vector: Copy;

    /// Four lanes from `p`.
    ///
    /// # Safety
    /// `p` points to four readable values.
    unsafe fn load(p: *const Self) -> Self::Vector;

    /// Four lanes to `p`.
    ///
    /// # Safety
    /// `p` points to four writable values nothing else borrows.
    unsafe fn store(p: *mut Self, v: Self::Vector);

    /// The binomial of the four-lane vectors at the five taps.
    ///
    /// # Safety
    /// Each tap points to four readable values.
    unsafe fn binomial_at(taps: [*const Self; 5]) -> Self::Vector;
}

impl Lanes for i32 {
    type Vector = int32x4_t;

    #[inline]
    #[target_feature(enable = "neon")]
    unsafe fn load(p: *const i32) -> int32x4_t {
        // SAFETY: the caller's; no alignment needed.
        unsafe { vld1q_s32(p) }
    }

    #[inline]
    #[target_feature(enable = "neon")]
    unsafe fn store(p: *mut i32, v: int32x4_t) {
        // SAFETY: the caller's.
        unsafe { vst1q_s32(p, v) }
    }

    #[inline]
    #[target_feature(enable = "neon")]
    unsafe fn binomial_at([a, b, c, d, e]: [*const i32; 5]) -> int32x4_t {
        // SAFETY: the caller's.
        unsafe {
            binomial(
                Self::load(a),
                Self::load(b),
                Self::load(c),
                Self::load(d),
                Self::load(e),
            )
        }
    }
}

impl Lanes for f32 {
    type Vector = float32x4_t;

    #[inline]
    #[target_feature(enable = "neon")]
    unsafe fn load(p: *const f32) -> float32x4_t {
        // SAFETY: the caller's; no alignment needed.
        unsafe { vld1q_f32(p) }
    }

    #[inline]
    #[target_feature(enable = "neon")]
    unsafe fn store(p: *mut f32, v: float32x4_t) {
        // SAFETY: the caller's.
        unsafe { vst1q_f32(p, v) }
    }

    #[inline]
    #[target_feature(enable = "neon")]
    unsafe fn binomial_at([a, b, c, d, e]: [*const f32; 5]) -> float32x4_t {
        // SAFETY: the caller's.
        unsafe {
            binomial_f(
                Self::load(a),
                Self::load(b),
                Self::load(c),
                Self::load(d),
                Self::load(e),
            )
        }
    }
}

/// The horizontal `G` of block `b` of `K` product rows (taps from window
/// column `first`) into their channels' lanes of slot `slot` of a ring.
///
/// # Safety
/// Every row holds `first + 8` values, and block `b` lies in the ring.
#[inline]
#[target_feature(enable = "neon")]
unsafe fn row_sums<T: Lanes, const K: usize>(
    rows: &[&[T]; K],
    first: usize,
    ring: *mut T,
    (b, slot): (usize, usize),
) {
    for (ch, row) in rows.iter().enumerate() {
        let p = row.as_ptr();
        // SAFETY: the caller's.
        unsafe {
            let sum = T::binomial_at(core::array::from_fn(|t| p.add(first + t)));
            T::store(ring.add(at(K, b, slot, ch)), sum);
        }
    }
}

/// The vertical `G` of block `b` of channel `ch` of a ring of `K`
/// channels, from the five rows from slot `first` on.
///
/// # Safety
/// Block `b` lies in the ring.
#[inline]
#[target_feature(enable = "neon")]
unsafe fn column_sum<T: Lanes, const K: usize>(
    ring: *const T,
    (b, first, ch): (usize, usize, usize),
) -> T::Vector {
    let tap = |k: usize| at(K, b, (first + k) % SUM_DEPTH, ch);
    // SAFETY: the caller's.
    unsafe { T::binomial_at(core::array::from_fn(|k| ring.add(tap(k)))) }
}

/// The horizontal `G` of the five products of a row (window columns,
/// valid on `[5, n − 5)`) into slot `slot` of both sums rings. The last
/// block's lanes past the row's last output column get sums of columns
/// past the window (bounded like any sum: the rows there hold earlier
/// products or zeros), unless those would lie past the rows' ends: then
/// those lanes keep what they held.
#[inline(always)]
fn horizontal_sums(
    ints: [&[i32]; INTS],
    floats: [&[f32]; FLOATS],
    rings: (&mut [i32], &mut [f32], usize),
    n: usize,
) {
    // SAFETY: NEON is enabled for the whole build (the module's `cfg`).
    unsafe { horizontal_sums_neon(ints, floats, rings, n) }
}

#[inline(never)]
#[target_feature(enable = "neon")]
fn horizontal_sums_neon(
    ints: [&[i32]; INTS],
    floats: [&[f32]; FLOATS],
    (int_ring, float_ring, slot): (&mut [i32], &mut [f32], usize),
    n: usize,
) {
    let nb = blocks(n.saturating_sub(2 * HALO));
    let slot = slot % SUM_DEPTH;
    let (Some(int_ring), Some(float_ring)) = (
        int_ring.get_mut(..nb * ring_block(INTS)),
        float_ring.get_mut(..nb * ring_block(FLOATS)),
    ) else {
        return;
    };
    // Tap `t` of lane `j` of block `b` is window column `HALO − 2 + 4b + j
    // + t`: the block reads `4b + 13` columns of every product row. The
    // blocks that fit in all of them run in lanes.
    let len = ints
        .iter()
        .map(|r| r.len())
        .chain(floats.iter().map(|r| r.len()))
        .min();
    let reach = HALO - 2 + BLOCK + 4;
    let whole = match len {
        Some(len) if len >= reach => ((len - reach) / BLOCK + 1).min(nb),
        _ => 0,
    };
    let (int_out, float_out) = (int_ring.as_mut_ptr(), float_ring.as_mut_ptr());
    for b in 0..whole {
        let first = HALO - 2 + BLOCK * b;
        // SAFETY: `first + 8 ≤ len` (`whole`), and block `b < nb` lies in
        // both rings.
        unsafe {
            row_sums(&ints, first, int_out, (b, slot));
            row_sums(&floats, first, float_out, (b, slot));
        }
    }
    // A last block whose taps would pass a row's end: its lanes one at a
    // time, those whose taps lie in the row.
    for b in whole..nb {
        let first = HALO - 2 + BLOCK * b;
        scalar_sums(&ints, first, int_ring, (b, slot));
        scalar_sums(&floats, first, float_ring, (b, slot));
    }
}

/// [`row_sums`] one lane at a time, the lanes whose five taps lie in the
/// row (`Sample::binomial`, the portable sum); the others keep what they
/// held.
#[inline(never)]
fn scalar_sums<T: Sample, const K: usize>(
    rows: &[&[T]; K],
    first: usize,
    ring: &mut [T],
    (b, slot): (usize, usize),
) {
    for (ch, row) in rows.iter().enumerate() {
        let out = ring
            .get_mut(at(K, b, slot, ch)..)
            .and_then(|r| r.first_chunk_mut::<BLOCK>());
        for (j, out) in out.into_iter().flatten().enumerate() {
            if let Some(&[a, b, c, d, e]) = row.get(first + j..).and_then(|t| t.first_chunk()) {
                *out = T::binomial(a, b, c, d, e);
            }
        }
    }
}

/// What one output row's tail reads: both sums rings, the slot of the
/// first of the five rows centred on it, and `V` (window columns).
struct BlockedRows<'a> {
    /// The integer sums' ring.
    ints: &'a [i32],
    /// The `f32` sums' ring.
    floats: &'a [f32],
    /// The slot of the row two above the output row (below `SUM_DEPTH`).
    first_slot: usize,
    /// `V` (x, y) of the row.
    v: [&'a [i32]; 2],
}

/// The vertical `G` of the blocked sums centred on an output row, the solve
/// and the magnitudes (and fields), four pixels a step, for the `w` output
/// columns of a window of `n` (the outputs' length; shorter rows write
/// nothing).
#[inline(always)]
fn tail_row(k: &TailConstants, rows: &BlockedRows<'_>, out: TailOut<'_>) -> ExtremesSink {
    let TailOut { m, fields } = out;
    match fields {
        None => by_slot::<false>(k, rows, m, [&mut [], &mut [], &mut [], &mut []]),
        Some(fields) => by_slot::<true>(k, rows, m, fields),
    }
}

/// [`tail_row_neon`] compiled for the slot of the output row's first sums
/// row, so that every load is at a constant offset from one pointer a ring.
#[inline(always)]
fn by_slot<const FIELDS: bool>(
    k: &TailConstants,
    rows: &BlockedRows<'_>,
    m: [&mut [f32]; 2],
    fields: [&mut [f32]; 4],
) -> ExtremesSink {
    // SAFETY: NEON is enabled for the whole build (the module's `cfg`).
    unsafe {
        match rows.first_slot {
            0 => tail_row_neon::<FIELDS, 0>(k, rows, m, fields),
            1 => tail_row_neon::<FIELDS, 1>(k, rows, m, fields),
            2 => tail_row_neon::<FIELDS, 2>(k, rows, m, fields),
            3 => tail_row_neon::<FIELDS, 3>(k, rows, m, fields),
            _ => tail_row_neon::<FIELDS, 4>(k, rows, m, fields),
        }
    }
}

/// The constants of the tail in lanes.
struct Constants {
    lambda4: int32x4_t,
    det_floor: float32x4_t,
    v_d: float32x4_t,
    v_c: float32x4_t,
}

#[inline(never)]
#[target_feature(enable = "neon")]
fn tail_row_neon<const FIELDS: bool, const FIRST: usize>(
    k: &TailConstants,
    rows: &BlockedRows<'_>,
    [m_d, m_c]: [&mut [f32]; 2],
    fields: [&mut [f32]; 4],
) -> ExtremesSink {
    let w = m_d.len();
    let (nb, whole) = (blocks(w), w / BLOCK);
    let BlockedRows {
        ints, floats, v, ..
    } = rows;
    let [vx, vy] = v.map(|row| row.get(HALO..HALO + w).unwrap_or(&[]));
    let fields_len = if FIELDS { w } else { 0 };
    if ints.len() < nb * ring_block(INTS)
        || floats.len() < nb * ring_block(FLOATS)
        || vx.len() < w
        || vy.len() < w
        || m_c.len() < w
        || fields.iter().any(|row| row.len() < fields_len)
    {
        return ExtremesSink::default();
    }
    let c = Constants {
        lambda4: vdupq_n_s32(k.lambda4),
        det_floor: vdupq_n_f32(k.units.det_floor),
        v_d: vdupq_n_f32(k.units.v_d),
        v_c: vdupq_n_f32(k.units.v_c),
    };
    let (ints, floats) = (ints.as_ptr(), floats.as_ptr());
    let [v_c_x, v_c_y, v_d_x, v_d_y] = fields;
    let out = [
        m_d.as_mut_ptr(),
        m_c.as_mut_ptr(),
        v_c_x.as_mut_ptr(),
        v_c_y.as_mut_ptr(),
        v_d_x.as_mut_ptr(),
        v_d_y.as_mut_ptr(),
    ];
    // The magnitudes' extremes as `Extremes::add_all` finds them: minima
    // and maxima of their bits (non-negative `f32`s order as their bits).
    let empty = Extremes::EMPTY;
    let mut min = [vdupq_n_u32(empty.min.to_bits()); 2];
    let mut max = [vdupq_n_u32(empty.max.to_bits()); 2];
    for b in 0..whole {
        let at = BLOCK * b;
        // SAFETY: block `b < nb` lies in both rings, and `at + 4 ≤ w`
        // in `V` and the outputs (the fields when `FIELDS`): the lengths
        // checked above.
        unsafe {
            let (abc, pq) = block_sums::<FIRST>(ints, floats, b);
            let v = [
                i32::load(vx.as_ptr().add(at)),
                i32::load(vy.as_ptr().add(at)),
            ];
            let px = pixels(&c, abc, pq, v);
            if !FIELDS {
                let bits = [vreinterpretq_u32_f32(px.m_d), vreinterpretq_u32_f32(px.m_c)];
                for k in 0..2 {
                    min[k] = vminq_u32(min[k], bits[k]);
                    max[k] = vmaxq_u32(max[k], bits[k]);
                }
            }
            for (row, lanes) in out.iter().zip(outputs::<FIELDS>(&c, &px)) {
                f32::store(row.add(at), lanes);
            }
        }
    }
    let mut extremes = [0, 1].map(|k| Extremes {
        min: f32::from_bits(vminvq_u32(min[k]).min(empty.min.to_bits())),
        max: f32::from_bits(vmaxvq_u32(max[k]).max(empty.max.to_bits())),
    });
    if whole < nb {
        // The last, partial block: `V` past the row's end reads as 0, and
        // only the row's columns are written.
        let at = BLOCK * whole;
        let padded = |row: &[i32]| {
            let mut lanes = [0; BLOCK];
            for (l, &x) in lanes.iter_mut().zip(row.get(at..).unwrap_or(&[])) {
                *l = x;
            }
            lanes
        };
        let (vx, vy) = (padded(vx), padded(vy));
        let mut local = [[0.0f32; BLOCK]; 6];
        // SAFETY: block `whole < nb` lies in both rings; `V` and the
        // results are local arrays of four lanes.
        unsafe {
            let (abc, pq) = block_sums::<FIRST>(ints, floats, whole);
            let v = [i32::load(vx.as_ptr()), i32::load(vy.as_ptr())];
            let px = pixels(&c, abc, pq, v);
            for (row, lanes) in local.iter_mut().zip(outputs::<FIELDS>(&c, &px)) {
                f32::store(row.as_mut_ptr(), lanes);
            }
        }
        let rows = [m_d, m_c, v_c_x, v_c_y, v_d_x, v_d_y];
        for (row, lanes) in rows.into_iter().zip(&local) {
            for (o, &x) in row.get_mut(at..).unwrap_or(&mut []).iter_mut().zip(lanes) {
                *o = x;
            }
        }
        for (extremes, lanes) in extremes.iter_mut().zip(&local) {
            extremes.add_all(lanes.get(..w - at).unwrap_or(&[]));
        }
    }
    let [m_d, m_c] = extremes;
    ExtremesSink { m_d, m_c }
}

/// The vertical `G` of block `b` of each channel: `a, b, c` and `p, q`,
/// from the five rows of the rings from slot `FIRST` on.
///
/// # Safety
/// Block `b` lies in both rings.
#[inline]
#[target_feature(enable = "neon")]
unsafe fn block_sums<const FIRST: usize>(
    ints: *const i32,
    floats: *const f32,
    b: usize,
) -> ([int32x4_t; INTS], [float32x4_t; FLOATS]) {
    // SAFETY: the caller's.
    let int = |ch| unsafe { column_sum::<i32, INTS>(ints, (b, FIRST, ch)) };
    // SAFETY: the caller's.
    let float = |ch| unsafe { column_sum::<f32, FLOATS>(floats, (b, FIRST, ch)) };
    ([int(0), int(1), int(2)], [float(0), float(1)])
}

/// One block's results: the magnitudes, and the fields' parts.
struct Pixels {
    m_d: float32x4_t,
    m_c: float32x4_t,
    /// `V` in `f32`, the numerators `N` and `1/det` (in `v_d`'s units).
    v: [float32x4_t; 2],
    n: [float32x4_t; 2],
    inv: float32x4_t,
}

/// The tail of four pixels: `tail::solve` and the magnitudes, operation
/// for operation.
#[inline]
#[target_feature(enable = "neon")]
fn pixels(
    c: &Constants,
    [a, b, cc]: [int32x4_t; 3],
    [p, q]: [float32x4_t; 2],
    v: [int32x4_t; 2],
) -> Pixels {
    let a4 = vcvtq_f32_s32(vaddq_s32(vshlq_n_s32::<2>(a), c.lambda4));
    let c4 = vcvtq_f32_s32(vaddq_s32(vshlq_n_s32::<2>(cc), c.lambda4));
    let b4 = vcvtq_f32_s32(vshlq_n_s32::<2>(b));
    let det = vsubq_f32(vmulq_f32(a4, c4), vmulq_f32(b4, b4));
    // `det > floor ? det : floor` (module doc: no NaN, no zero).
    let det = vmaxq_f32(det, c.det_floor);
    let n = [
        vsubq_f32(vmulq_f32(c4, p), vmulq_f32(b4, q)),
        vsubq_f32(vmulq_f32(a4, q), vmulq_f32(b4, p)),
    ];
    let inv = vdivq_f32(c.v_d, det);
    let norm = |[x, y]: [float32x4_t; 2]| vsqrtq_f32(vaddq_f32(vmulq_f32(x, x), vmulq_f32(y, y)));
    let v = [vcvtq_f32_s32(v[0]), vcvtq_f32_s32(v[1])];
    Pixels {
        m_d: vmulq_f32(norm(n), inv),
        m_c: vmulq_f32(norm(v), c.v_c),
        v,
        n,
        inv,
    }
}

/// A block's results in the order of the rows `[|v_d|, |v_c|, v_c x, v_c
/// y, v_d x, v_d y]`, as `tail::pixels_of` makes them: the magnitudes,
/// and the fields only when `FIELDS` (their lanes are the magnitudes'
/// otherwise, for rows that take nothing).
#[inline]
#[target_feature(enable = "neon")]
fn outputs<const FIELDS: bool>(c: &Constants, px: &Pixels) -> impl Iterator<Item = float32x4_t> {
    let fields = if FIELDS {
        [
            vmulq_f32(px.v[0], c.v_c),
            vmulq_f32(px.v[1], c.v_c),
            vmulq_f32(px.n[0], px.inv),
            vmulq_f32(px.n[1], px.inv),
        ]
    } else {
        [px.m_d; 4]
    };
    let count = if FIELDS { 6 } else { 2 };
    [px.m_d, px.m_c].into_iter().chain(fields).take(count)
}

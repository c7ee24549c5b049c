//! The structure sums and the tail in AVX2 lanes, through intrinsics, for
//! hosts that find AVX2 and FMA at run time (x86-64): a host compiles its
//! pass for them and hands the job an [`Avx2`], which only code compiled
//! with those features can make without `unsafe`.
//!
//! With it the engine keeps each sums ring (the three integer channels',
//! the two `f32` ones') in blocks of [`BLOCK`] output columns: a block holds
//! those columns of every channel of all five rows of the ring, row slot by
//! row slot. One loop then does an output row's work: the vertical `G` of
//! the five sums, the solve, both magnitudes and their extremes (or the
//! fields, for sinks that read them), eight pixels a step, reading each
//! ring through one pointer at constant offsets (the loop is compiled once
//! per slot of the window's first row). Rows a channel each took 25 row
//! pointers into that loop, more than x86-64 has registers, and the sums
//! went to memory and back between the vertical `G` and the tail. The
//! compiler's own vectorisation cannot be led there: it vectorises an
//! eight-column block loop across blocks, by gathers.
//!
//! Every operation is the portable one, in the same order, so the bytes
//! are the same (`tests/tests/simd.rs`): exact integer sums, and the `f32`
//! steps of `stages` and `tail` each rounded once. The one fused
//! multiply-add is exact: in an `f32` binomial `((a + e) + (b + d)·4) +
//! c·6`, `(b + d)·4` is exact (a power of two, no overflow, no subnormal:
//! the products are 0 or at least 2⁻²⁰), so `fma(b + d, 4, a + e)` rounds
//! the same sum once, as the two steps do.
//!
//! `unsafe` here: the calls of the `#[target_feature]` functions, which the
//! token's existence makes sound, and the loads and stores of eight lanes,
//! each within a row whose length is checked once a row.
#![allow(unsafe_code)]

use core::arch::x86_64::{
    __m256, __m256i, _mm256_add_epi32, _mm256_add_ps, _mm256_castps_si256, _mm256_cvtepi32_ps,
    _mm256_div_ps, _mm256_fmadd_ps, _mm256_loadu_ps, _mm256_loadu_si256, _mm256_max_epu32,
    _mm256_max_ps, _mm256_min_epu32, _mm256_mul_ps, _mm256_set1_epi32, _mm256_set1_ps,
    _mm256_slli_epi32, _mm256_sqrt_ps, _mm256_storeu_ps, _mm256_storeu_si256, _mm256_sub_ps,
};

use super::{KernelSet, OutputRow, Products, SumRings};
use crate::ring::take;
use crate::schedule::{HALO, SUM_DEPTH, SUM_RADIUS};
use crate::stages::{FLOAT_CHANNELS, INT_CHANNELS, Sample};
use crate::tail::{TailConstants, TailOut};
use crate::{Extremes, ExtremesSink, Job};

/// Proof that the CPU runs AVX2 and FMA. Give it to a job
/// ([`Job::with_avx2`](crate::Job::with_avx2)) and the engine runs the
/// job's structure sums and tail in AVX2 lanes (same bytes).
#[derive(Clone, Copy, Debug)]
pub struct Avx2(());

impl Avx2 {
    /// The token, made where AVX2 and FMA are enabled: safe to call from a
    /// function compiled for them (a runtime-dispatched clone, e.g.
    /// `multiversion`'s), `unsafe` elsewhere.
    ///
    /// # Safety
    /// Called from code not compiled for AVX2 and FMA, the CPU must have
    /// them.
    #[target_feature(enable = "avx2,fma")]
    pub fn new() -> Self {
        Self(())
    }
}

impl Job<'_> {
    /// The same job, its structure sums and tail run in AVX2 lanes (the
    /// same bytes): for hosts that found AVX2 and FMA at run time.
    pub fn with_avx2(self, avx2: Avx2) -> Self {
        self.with_kernels(super::Choice { avx2: Some(avx2) })
    }
}

/// The AVX2 set: the portable row kernels, the structure sums in blocks
/// ([`BlockedSums`]) and the tail in lanes.
impl KernelSet for Avx2 {
    type Sums<'m> = BlockedSums<'m>;
}

/// The sums' rings in blocks (module doc): the integer channels' ring and
/// the `f32` ones', each `SUM_DEPTH · K · cols` values for `K` channels
/// (the memory of the portable layout's rings), and the token.
pub(crate) struct BlockedSums<'m> {
    avx2: Avx2,
    ints: &'m mut [i32],
    floats: &'m mut [f32],
}

impl<'m> SumRings<'m, Avx2> for BlockedSums<'m> {
    #[inline(always)]
    fn carve(
        avx2: Avx2,
        words: &mut &'m mut [i32],
        floats: &mut &'m mut [f32],
        cols: usize,
    ) -> Self {
        Self {
            avx2,
            ints: take(words, SUM_DEPTH * INTS * cols),
            floats: take(floats, SUM_DEPTH * FLOATS * cols),
        }
    }

    #[inline(always)]
    fn store_row(&mut self, t: usize, (ints, floats): Products<'_, 'm>, n: usize) {
        let ints = ints.each_ref().map(|row| &row[..]);
        let floats = floats.each_ref().map(|row| &row[..]);
        let rings = (&mut *self.ints, &mut *self.floats, t % SUM_DEPTH);
        horizontal_sums(self.avx2, ints, floats, rings, n);
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
        Some(tail_row(self.avx2, constants, &rows, out))
    }
}

/// Output columns a block: one AVX2 vector of each channel of each row.
const BLOCK: usize = 8;

/// Integer channels (`X², XY, Y²`) and `f32` channels (`X·Dn′`, `Y·Dn′`).
const INTS: usize = INT_CHANNELS;
const FLOATS: usize = FLOAT_CHANNELS;

/// Values a block of a ring of `K` channels: output column `8b + j` of
/// channel `ch` of the row in slot `s` (window row `t` is in slot
/// `t mod 5`) at `b · ring_block(K) + (s · K + ch) · 8 + j`. A ring of rows
/// `cols` long per channel holds `⌈w / 8⌉` blocks (`8 ⌈w / 8⌉ < w + 14`).
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

/// Eight `i32` lanes from `p`.
///
/// # Safety
/// `p` points to eight readable `i32`s.
#[inline(always)]
unsafe fn load(p: *const i32) -> __m256i {
    // SAFETY: the caller's; no alignment needed.
    unsafe { _mm256_loadu_si256(p.cast()) }
}

/// Eight `f32` lanes from `p`.
///
/// # Safety
/// `p` points to eight readable `f32`s.
#[inline(always)]
unsafe fn load_f(p: *const f32) -> __m256 {
    // SAFETY: the caller's; no alignment needed.
    unsafe { _mm256_loadu_ps(p) }
}

/// Eight `i32` lanes to `p`.
///
/// # Safety
/// `p` points to eight writable `i32`s nothing else borrows.
#[inline(always)]
unsafe fn store(p: *mut i32, v: __m256i) {
    // SAFETY: the caller's.
    unsafe { _mm256_storeu_si256(p.cast(), v) }
}

/// Eight `f32` lanes to `p`.
///
/// # Safety
/// `p` points to eight writable `f32`s nothing else borrows.
#[inline(always)]
unsafe fn store_f(p: *mut f32, v: __m256) {
    // SAFETY: the caller's.
    unsafe { _mm256_storeu_ps(p, v) }
}

/// `a + 4b + 6c + 4d + e`, as `4(b + c + d) + 2c + a + e` (exact in `i32`:
/// every sum of the engine's is within `2²⁸`).
#[inline]
#[target_feature(enable = "avx2")]
fn binomial(a: __m256i, b: __m256i, c: __m256i, d: __m256i, e: __m256i) -> __m256i {
    let inner = _mm256_slli_epi32::<2>(_mm256_add_epi32(_mm256_add_epi32(b, c), d));
    let outer = _mm256_add_epi32(_mm256_add_epi32(_mm256_add_epi32(c, c), a), e);
    _mm256_add_epi32(inner, outer)
}

/// `((a + e) + (b + d)·4) + c·6`, rounded as `Sample::binomial` for `f32`
/// (module doc: the one FMA is exact).
#[inline]
#[target_feature(enable = "avx2,fma")]
fn binomial_f(a: __m256, b: __m256, c: __m256, d: __m256, e: __m256) -> __m256 {
    let sum = _mm256_fmadd_ps(
        _mm256_add_ps(b, d),
        _mm256_set1_ps(4.0),
        _mm256_add_ps(a, e),
    );
    _mm256_add_ps(sum, _mm256_mul_ps(c, _mm256_set1_ps(6.0)))
}

/// The two kinds of sums in lanes, eight values a vector: exact `i32`s
/// ([`binomial`]) and `f32`s ([`binomial_f`]).
trait Lanes: Sized {
    type Vector;

    /// The binomial of the eight-lane vectors at the five taps.
    ///
    /// # Safety
    /// Each tap points to eight readable values.
    unsafe fn binomial_at(taps: [*const Self; 5]) -> Self::Vector;

    /// Eight lanes to `p`.
    ///
    /// # Safety
    /// `p` points to eight writable values nothing else borrows.
    unsafe fn store_at(p: *mut Self, v: Self::Vector);
}

impl Lanes for i32 {
    type Vector = __m256i;

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn binomial_at([a, b, c, d, e]: [*const i32; 5]) -> __m256i {
        // SAFETY: the caller's.
        unsafe { binomial(load(a), load(b), load(c), load(d), load(e)) }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn store_at(p: *mut i32, v: __m256i) {
        // SAFETY: the caller's.
        unsafe { store(p, v) }
    }
}

impl Lanes for f32 {
    type Vector = __m256;

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn binomial_at([a, b, c, d, e]: [*const f32; 5]) -> __m256 {
        // SAFETY: the caller's.
        unsafe { binomial_f(load_f(a), load_f(b), load_f(c), load_f(d), load_f(e)) }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn store_at(p: *mut f32, v: __m256) {
        // SAFETY: the caller's.
        unsafe { store_f(p, v) }
    }
}

/// The horizontal `G` of block `b` of `K` product rows (taps from window
/// column `first`) into their channels' lanes of slot `slot` of a ring.
///
/// # Safety
/// Every row holds `first + 12` values, and block `b` lies in the ring.
#[inline]
#[target_feature(enable = "avx2,fma")]
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
            T::store_at(ring.add(at(K, b, slot, ch)), sum);
        }
    }
}

/// The vertical `G` of block `b` of channel `ch` of a ring of `K`
/// channels, from the five rows from slot `first` on.
///
/// # Safety
/// Block `b` lies in the ring.
#[inline]
#[target_feature(enable = "avx2,fma")]
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
    _: Avx2,
    ints: [&[i32]; INTS],
    floats: [&[f32]; FLOATS],
    rings: (&mut [i32], &mut [f32], usize),
    n: usize,
) {
    // SAFETY: the token proves AVX2 and FMA.
    unsafe { horizontal_sums_avx2(ints, floats, rings, n) }
}

#[target_feature(enable = "avx2,fma")]
fn horizontal_sums_avx2(
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
    // Tap `t` of lane `j` of block `b` is window column `HALO − 2 + 8b + j
    // + t`: the block reads `8b + 17` columns of every product row. The
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
        // SAFETY: `first + 12 ≤ len` (`whole`), and block `b < nb` lies in
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
/// and the magnitudes (and fields), eight pixels a step, for the `w` output
/// columns of a window of `n` (the outputs' length; shorter rows write
/// nothing).
#[inline(always)]
fn tail_row(_: Avx2, k: &TailConstants, rows: &BlockedRows<'_>, out: TailOut<'_>) -> ExtremesSink {
    let TailOut { m, fields } = out;
    match fields {
        None => by_slot::<false>(k, rows, m, [&mut [], &mut [], &mut [], &mut []]),
        Some(fields) => by_slot::<true>(k, rows, m, fields),
    }
}

/// [`tail_row_avx2`] compiled for the slot of the output row's first sums
/// row, so that every load is at a constant offset from one pointer a ring.
#[inline(always)]
fn by_slot<const FIELDS: bool>(
    k: &TailConstants,
    rows: &BlockedRows<'_>,
    m: [&mut [f32]; 2],
    fields: [&mut [f32]; 4],
) -> ExtremesSink {
    // SAFETY: the token (the caller's) proves AVX2 and FMA.
    unsafe {
        match rows.first_slot {
            0 => tail_row_avx2::<FIELDS, 0>(k, rows, m, fields),
            1 => tail_row_avx2::<FIELDS, 1>(k, rows, m, fields),
            2 => tail_row_avx2::<FIELDS, 2>(k, rows, m, fields),
            3 => tail_row_avx2::<FIELDS, 3>(k, rows, m, fields),
            _ => tail_row_avx2::<FIELDS, 4>(k, rows, m, fields),
        }
    }
}

/// The constants of the tail in lanes.
struct Constants {
    lambda4: __m256i,
    det_floor: __m256,
    v_d: __m256,
    v_c: __m256,
}

#[target_feature(enable = "avx2,fma")]
fn tail_row_avx2<const FIELDS: bool, const FIRST: usize>(
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
        lambda4: _mm256_set1_epi32(k.lambda4),
        det_floor: _mm256_set1_ps(k.units.det_floor),
        v_d: _mm256_set1_ps(k.units.v_d),
        v_c: _mm256_set1_ps(k.units.v_c),
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
    let mut min = [_mm256_set1_epi32(empty.min.to_bits() as i32); 2];
    let mut max = [_mm256_set1_epi32(empty.max.to_bits() as i32); 2];
    for b in 0..whole {
        let at = BLOCK * b;
        // SAFETY: block `b < nb` lies in both rings, and `at + 8 ≤ w`
        // in `V` and the outputs (the fields when `FIELDS`): the lengths
        // checked above.
        unsafe {
            let (abc, pq) = block_sums::<FIRST>(ints, floats, b);
            let v = [load(vx.as_ptr().add(at)), load(vy.as_ptr().add(at))];
            let px = pixels(&c, abc, pq, v);
            if !FIELDS {
                let bits = [_mm256_castps_si256(px.m_d), _mm256_castps_si256(px.m_c)];
                for k in 0..2 {
                    min[k] = _mm256_min_epu32(min[k], bits[k]);
                    max[k] = _mm256_max_epu32(max[k], bits[k]);
                }
            }
            for (row, lanes) in out.iter().zip(outputs::<FIELDS>(&c, &px)) {
                store_f(row.add(at), lanes);
            }
        }
    }
    let mut extremes = [0, 1].map(|k| {
        let (mut lo, mut hi) = ([0u32; BLOCK], [0u32; BLOCK]);
        // SAFETY: eight lanes into local arrays of eight.
        unsafe {
            store(lo.as_mut_ptr().cast(), min[k]);
            store(hi.as_mut_ptr().cast(), max[k]);
        }
        let fold = |lanes: [u32; BLOCK], pick: fn(u32, u32) -> u32, from: u32| {
            f32::from_bits(lanes.into_iter().fold(from, pick))
        };
        Extremes {
            min: fold(lo, u32::min, empty.min.to_bits()),
            max: fold(hi, u32::max, empty.max.to_bits()),
        }
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
        // results are local arrays of eight lanes.
        unsafe {
            let (abc, pq) = block_sums::<FIRST>(ints, floats, whole);
            let px = pixels(&c, abc, pq, [load(vx.as_ptr()), load(vy.as_ptr())]);
            for (row, lanes) in local.iter_mut().zip(outputs::<FIELDS>(&c, &px)) {
                store_f(row.as_mut_ptr(), lanes);
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
#[target_feature(enable = "avx2,fma")]
unsafe fn block_sums<const FIRST: usize>(
    ints: *const i32,
    floats: *const f32,
    b: usize,
) -> ([__m256i; INTS], [__m256; FLOATS]) {
    // SAFETY: the caller's.
    let int = |ch| unsafe { column_sum::<i32, INTS>(ints, (b, FIRST, ch)) };
    // SAFETY: the caller's.
    let float = |ch| unsafe { column_sum::<f32, FLOATS>(floats, (b, FIRST, ch)) };
    ([int(0), int(1), int(2)], [float(0), float(1)])
}

/// One block's results: the magnitudes, and the fields' parts.
struct Pixels {
    m_d: __m256,
    m_c: __m256,
    /// `V` in `f32`, the numerators `N` and `1/det` (in `v_d`'s units).
    v: [__m256; 2],
    n: [__m256; 2],
    inv: __m256,
}

/// The tail of eight pixels: `tail::solve` and the magnitudes, operation
/// for operation.
#[inline]
#[target_feature(enable = "avx2")]
fn pixels(c: &Constants, [a, b, cc]: [__m256i; 3], [p, q]: [__m256; 2], v: [__m256i; 2]) -> Pixels {
    let a4 = _mm256_cvtepi32_ps(_mm256_add_epi32(_mm256_slli_epi32::<2>(a), c.lambda4));
    let c4 = _mm256_cvtepi32_ps(_mm256_add_epi32(_mm256_slli_epi32::<2>(cc), c.lambda4));
    let b4 = _mm256_cvtepi32_ps(_mm256_slli_epi32::<2>(b));
    let det = _mm256_sub_ps(_mm256_mul_ps(a4, c4), _mm256_mul_ps(b4, b4));
    // `det > floor ? det : floor`: what `maxps` takes.
    let det = _mm256_max_ps(det, c.det_floor);
    let n = [
        _mm256_sub_ps(_mm256_mul_ps(c4, p), _mm256_mul_ps(b4, q)),
        _mm256_sub_ps(_mm256_mul_ps(a4, q), _mm256_mul_ps(b4, p)),
    ];
    let inv = _mm256_div_ps(c.v_d, det);
    let norm = |[x, y]: [__m256; 2]| {
        _mm256_sqrt_ps(_mm256_add_ps(_mm256_mul_ps(x, x), _mm256_mul_ps(y, y)))
    };
    let v = [_mm256_cvtepi32_ps(v[0]), _mm256_cvtepi32_ps(v[1])];
    Pixels {
        m_d: _mm256_mul_ps(norm(n), inv),
        m_c: _mm256_mul_ps(norm(v), c.v_c),
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
#[target_feature(enable = "avx2")]
fn outputs<const FIELDS: bool>(c: &Constants, px: &Pixels) -> impl Iterator<Item = __m256> {
    let fields = if FIELDS {
        [
            _mm256_mul_ps(px.v[0], c.v_c),
            _mm256_mul_ps(px.v[1], c.v_c),
            _mm256_mul_ps(px.n[0], px.inv),
            _mm256_mul_ps(px.n[1], px.inv),
        ]
    } else {
        [px.m_d; 4]
    };
    let count = if FIELDS { 6 } else { 2 };
    [px.m_d, px.m_c].into_iter().chain(fields).take(count)
}

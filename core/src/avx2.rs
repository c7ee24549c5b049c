//! The structure sums and the tail in AVX2 lanes, through intrinsics, for
//! hosts that find AVX2 and FMA at run time (x86-64): a host compiles its
//! pass for them and hands the job an [`Avx2`], which only code compiled
//! with those features can make without `unsafe`.
//!
//! With it the engine keeps the sums' rings in blocks ([`BLOCK`] output
//! columns, the channels of a block side by side) instead of a row per
//! channel, and one loop does an output row's work: the vertical `G` of the
//! five sums, the solve, both magnitudes (and the fields, for sinks that
//! read them), eight pixels a step. Rows a channel each would take 25 row
//! pointers into that loop, more than x86-64 has registers; in blocks the
//! ten rows of the window are ten pointers, and the sums never go back to
//! memory. The compiler's own vectorisation cannot be led there: it
//! vectorises an eight-column block loop across blocks, by gathers.
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
//! token's existence makes sound, and the loads and stores, each of one
//! whole array of eight lanes (`lanes`, `store`).
#![allow(unsafe_code)]

use core::arch::x86_64::{
    __m256, __m256i, _mm256_add_epi32, _mm256_add_ps, _mm256_cvtepi32_ps, _mm256_div_ps,
    _mm256_fmadd_ps, _mm256_loadu_ps, _mm256_loadu_si256, _mm256_max_ps, _mm256_mul_ps,
    _mm256_set1_epi32, _mm256_set1_ps, _mm256_slli_epi32, _mm256_sqrt_ps, _mm256_storeu_ps,
    _mm256_storeu_si256, _mm256_sub_ps,
};

use crate::schedule::HALO;
use crate::tail::{TailConstants, TailOut};

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

/// Output columns a block of the sums' rings: one AVX2 vector of each
/// channel.
pub(crate) const BLOCK: usize = 8;

/// Integer channels a block (`X², XY, Y²`), `f32` channels (`X·Dn′`,
/// `Y·Dn′`), and the elements of a block of each.
const INTS: usize = 3;
const FLOATS: usize = 2;
const INT_BLOCK: usize = INTS * BLOCK;
const FLOAT_BLOCK: usize = FLOATS * BLOCK;

/// Blocks of a row of `w` output columns.
#[inline(always)]
pub(crate) const fn blocks(w: usize) -> usize {
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

/// The horizontal `G` of the five products of a row (window columns,
/// valid on `[5, n − 5)`) into one row of each sums ring, in blocks: the
/// sums of output column `k` (window column `HALO + k`) at
/// `(k / 8)·24 + channel·8 + k mod 8` of `int_sums` and
/// `(k / 8)·16 + channel·8 + k mod 8` of `float_sums`. The last block's
/// lanes past the row's last output column get sums of columns past the
/// window (bounded like any sum: the rows past it hold earlier products or
/// zeros), unless those would lie past the rows' ends: then those lanes
/// keep what they held.
#[inline(always)]
pub(crate) fn horizontal_sums(
    _: Avx2,
    ints: [&[i32]; INTS],
    floats: [&[f32]; FLOATS],
    int_sums: &mut [i32],
    float_sums: &mut [f32],
    n: usize,
) {
    // SAFETY: the token proves AVX2 and FMA.
    unsafe { horizontal_sums_avx2(ints, floats, int_sums, float_sums, n) }
}

#[target_feature(enable = "avx2,fma")]
fn horizontal_sums_avx2(
    ints: [&[i32]; INTS],
    floats: [&[f32]; FLOATS],
    int_sums: &mut [i32],
    float_sums: &mut [f32],
    n: usize,
) {
    let nb = blocks(n.saturating_sub(2 * HALO));
    let (Some(int_sums), Some(float_sums)) = (
        int_sums.get_mut(..nb * INT_BLOCK),
        float_sums.get_mut(..nb * FLOAT_BLOCK),
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
    let (int_out, float_out) = (int_sums.as_mut_ptr(), float_sums.as_mut_ptr());
    for b in 0..whole {
        let first = HALO - 2 + BLOCK * b;
        for (ch, row) in ints.iter().enumerate() {
            let p = row.as_ptr();
            // SAFETY: `first + 12 ≤ len` (`whole`), and block `b < nb`
            // lies in `int_sums`.
            unsafe {
                let sum = binomial(
                    load(p.add(first)),
                    load(p.add(first + 1)),
                    load(p.add(first + 2)),
                    load(p.add(first + 3)),
                    load(p.add(first + 4)),
                );
                store(int_out.add(b * INT_BLOCK + ch * BLOCK), sum);
            }
        }
        for (ch, row) in floats.iter().enumerate() {
            let p = row.as_ptr();
            // SAFETY: as above.
            unsafe {
                let sum = binomial_f(
                    load_f(p.add(first)),
                    load_f(p.add(first + 1)),
                    load_f(p.add(first + 2)),
                    load_f(p.add(first + 3)),
                    load_f(p.add(first + 4)),
                );
                store_f(float_out.add(b * FLOAT_BLOCK + ch * BLOCK), sum);
            }
        }
    }
    // A last block whose taps would pass a row's end: its lanes one at a
    // time, those whose taps lie in the row.
    let (int_blocks, float_blocks) = (
        int_sums.as_chunks_mut::<INT_BLOCK>().0,
        float_sums.as_chunks_mut::<FLOAT_BLOCK>().0,
    );
    for b in whole..nb {
        let first = HALO - 2 + BLOCK * b;
        let (Some(int_out), Some(float_out)) = (int_blocks.get_mut(b), float_blocks.get_mut(b))
        else {
            return;
        };
        for (row, out) in ints.iter().zip(int_out.as_chunks_mut::<BLOCK>().0) {
            scalar_taps(row, first, out, |a, b, c, d, e| {
                (a + e) + ((b + d) << 2) + (c << 2) + (c << 1)
            });
        }
        for (row, out) in floats.iter().zip(float_out.as_chunks_mut::<BLOCK>().0) {
            scalar_taps(row, first, out, |a, b, c, d, e| {
                ((a + e) + (b + d) * 4.0) + c * 6.0
            });
        }
    }
}

/// The lanes of a block whose five taps all lie in `row`, one at a time.
#[inline(never)]
fn scalar_taps<T: Copy>(
    row: &[T],
    first: usize,
    out: &mut [T; BLOCK],
    binomial: impl Fn(T, T, T, T, T) -> T,
) {
    for (j, out) in out.iter_mut().enumerate() {
        if let Some(&[a, b, c, d, e]) = row.get(first + j..).and_then(|t| t.first_chunk()) {
            *out = binomial(a, b, c, d, e);
        }
    }
}

/// The rows one output row's tail reads in blocks: the five rows of each
/// sums ring centred on it, and `V` (window columns).
pub(crate) struct BlockedRows<'a> {
    /// The integer sums' ring rows, oldest first.
    pub ints: [&'a [i32]; 5],
    /// The `f32` sums' ring rows.
    pub floats: [&'a [f32]; 5],
    /// `V` (x, y) of the row.
    pub v: [&'a [i32]; 2],
}

/// The vertical `G` of the blocked sums centred on an output row, the solve
/// and the magnitudes (and fields), eight pixels a step, for the `w` output
/// columns of a window of `n` (the outputs' length; shorter rows write
/// nothing).
#[inline(always)]
pub(crate) fn tail_row(_: Avx2, k: &TailConstants, rows: &BlockedRows<'_>, out: TailOut<'_>) {
    // SAFETY: the token proves AVX2 and FMA.
    unsafe {
        match out.fields {
            None => tail_row_avx2::<false>(k, rows, out.m, [&mut [], &mut [], &mut [], &mut []]),
            Some(fields) => tail_row_avx2::<true>(k, rows, out.m, fields),
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
fn tail_row_avx2<const FIELDS: bool>(
    k: &TailConstants,
    rows: &BlockedRows<'_>,
    [m_d, m_c]: [&mut [f32]; 2],
    fields: [&mut [f32]; 4],
) {
    let w = m_d.len();
    let (nb, whole) = (blocks(w), w / BLOCK);
    let BlockedRows { ints, floats, v } = rows;
    let [vx, vy] = v.map(|row| row.get(HALO..HALO + w).unwrap_or(&[]));
    let fields_len = if FIELDS { w } else { 0 };
    if ints.iter().any(|row| row.len() < nb * INT_BLOCK)
        || floats.iter().any(|row| row.len() < nb * FLOAT_BLOCK)
        || vx.len() < w
        || vy.len() < w
        || m_c.len() < w
        || fields.iter().any(|row| row.len() < fields_len)
    {
        return;
    }
    let c = Constants {
        lambda4: _mm256_set1_epi32(k.lambda4),
        det_floor: _mm256_set1_ps(k.units.det_floor),
        v_d: _mm256_set1_ps(k.units.v_d),
        v_c: _mm256_set1_ps(k.units.v_c),
    };
    let [i0, i1, i2, i3, i4] = *ints;
    let ints = [
        i0.as_ptr(),
        i1.as_ptr(),
        i2.as_ptr(),
        i3.as_ptr(),
        i4.as_ptr(),
    ];
    let [f0, f1, f2, f3, f4] = *floats;
    let floats = [
        f0.as_ptr(),
        f1.as_ptr(),
        f2.as_ptr(),
        f3.as_ptr(),
        f4.as_ptr(),
    ];
    let [v_c_x, v_c_y, v_d_x, v_d_y] = fields;
    let out = [
        m_d.as_mut_ptr(),
        m_c.as_mut_ptr(),
        v_c_x.as_mut_ptr(),
        v_c_y.as_mut_ptr(),
        v_d_x.as_mut_ptr(),
        v_d_y.as_mut_ptr(),
    ];
    for b in 0..whole {
        let at = BLOCK * b;
        // SAFETY: block `b < nb` lies in every sums row, and `at + 8 ≤ w`
        // in `V` and the outputs (the fields when `FIELDS`): the lengths
        // checked above.
        unsafe {
            let (abc, pq) = block_sums(ints, floats, b);
            let v = [load(vx.as_ptr().add(at)), load(vy.as_ptr().add(at))];
            let px = pixels(&c, abc, pq, v);
            for (row, lanes) in out.iter().zip(outputs::<FIELDS>(&c, &px)) {
                store_f(row.add(at), lanes);
            }
        }
    }
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
        // SAFETY: block `whole < nb` lies in every sums row; `V` and the
        // results are local arrays of eight lanes.
        unsafe {
            let (abc, pq) = block_sums(ints, floats, whole);
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
    }
}

/// The vertical `G` of block `b` of each channel: `a, b, c` and `p, q`.
///
/// # Safety
/// Block `b` lies in each of the rows.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn block_sums(
    ints: [*const i32; 5],
    floats: [*const f32; 5],
    b: usize,
) -> ([__m256i; INTS], [__m256; FLOATS]) {
    let [i0, i1, i2, i3, i4] = ints;
    let [f0, f1, f2, f3, f4] = floats;
    let int = |ch: usize| {
        let at = b * INT_BLOCK + ch * BLOCK;
        // SAFETY: the caller's.
        unsafe {
            binomial(
                load(i0.add(at)),
                load(i1.add(at)),
                load(i2.add(at)),
                load(i3.add(at)),
                load(i4.add(at)),
            )
        }
    };
    let float = |ch: usize| {
        let at = b * FLOAT_BLOCK + ch * BLOCK;
        // SAFETY: the caller's.
        unsafe {
            binomial_f(
                load_f(f0.add(at)),
                load_f(f1.add(at)),
                load_f(f2.add(at)),
                load_f(f3.add(at)),
                load_f(f4.add(at)),
            )
        }
    };
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

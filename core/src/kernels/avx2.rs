//! The structure sums and the tail in AVX2 lanes, through intrinsics, for
//! hosts that find AVX2 and FMA at run time (x86-64): a host compiles its
//! pass for them and hands the job an [`Avx2`], which only code compiled
//! with those features can make without `unsafe`.
//!
//! With it the engine keeps the structure sums in blocks of [`BLOCK`]
//! output columns (`blocked`: the layout, the horizontal and vertical
//! `G`), and one loop does an output row's tail, eight pixels a step.
//! Rows a channel each took 25 row pointers into that loop, more than
//! x86-64 has registers, and the sums went to memory and back between the
//! vertical `G` and the tail. The compiler's own vectorisation cannot be
//! led there: it vectorises an eight-column block loop across blocks, by
//! gathers.
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
//! each within a row (or ring) whose length is checked once a row.
#![allow(unsafe_code)]

use core::arch::x86_64::{
    __m256, __m256i, _mm256_add_epi32, _mm256_add_ps, _mm256_castps_si256, _mm256_cvtepi32_ps,
    _mm256_div_ps, _mm256_fmadd_ps, _mm256_loadu_ps, _mm256_loadu_si256, _mm256_max_epu32,
    _mm256_max_ps, _mm256_min_epu32, _mm256_mul_ps, _mm256_set1_epi32, _mm256_set1_ps,
    _mm256_slli_epi32, _mm256_sqrt_ps, _mm256_storeu_ps, _mm256_storeu_si256, _mm256_sub_ps,
};

use super::KernelSet;
use super::blocked::{
    self, Blocked, BlockedRows, BlockedSums, FLOATS, FloatLanes, INTS, IntLanes, Lanes, blocks,
};
use crate::tail::TailConstants;
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
        let mut job = self;
        job.kernels = super::Choice { avx2: Some(avx2) };
        job
    }
}

/// The AVX2 set: the portable row kernels, the structure sums in blocks
/// ([`BlockedSums`]) and the tail in lanes.
impl KernelSet for Avx2 {
    type Sums<'m> = BlockedSums<'m, Avx2>;
}

/// Output columns a block: one AVX2 vector of each channel of each row.
const BLOCK: usize = 8;

impl Blocked for Avx2 {
    #[inline(always)]
    fn horizontal_sums(
        self,
        ints: [&[i32]; INTS],
        floats: [&[f32]; FLOATS],
        rings: (&mut [i32], &mut [f32], usize),
        n: usize,
    ) {
        // SAFETY: the token proves AVX2 and FMA.
        unsafe { horizontal_sums_avx2(ints, floats, rings, n) }
    }

    #[inline(always)]
    fn tail_row<const FIELDS: bool, const EXTREMES: bool, const FIRST: usize>(
        self,
        k: &TailConstants,
        rows: &BlockedRows<'_>,
        m: [&mut [f32]; 2],
        fields: [&mut [f32]; 4],
    ) -> ExtremesSink {
        // SAFETY: the token proves AVX2 and FMA.
        unsafe { tail_row_avx2::<FIELDS, EXTREMES, FIRST>(k, rows, m, fields) }
    }
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

/// Exact `i32` sums, eight a vector ([`binomial`]).
impl Lanes<BLOCK> for i32 {
    type Vector = __m256i;

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn load(p: *const i32) -> __m256i {
        // SAFETY: the caller's; no alignment needed.
        unsafe { _mm256_loadu_si256(p.cast()) }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn store(p: *mut i32, v: __m256i) {
        // SAFETY: the caller's.
        unsafe { _mm256_storeu_si256(p.cast(), v) }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn binomial_lanes([a, b, c, d, e]: [__m256i; 5]) -> __m256i {
        binomial(a, b, c, d, e)
    }
}

/// `f32` sums, eight a vector ([`binomial_f`]).
impl Lanes<BLOCK> for f32 {
    type Vector = __m256;

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn load(p: *const f32) -> __m256 {
        // SAFETY: the caller's; no alignment needed.
        unsafe { _mm256_loadu_ps(p) }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn store(p: *mut f32, v: __m256) {
        // SAFETY: the caller's.
        unsafe { _mm256_storeu_ps(p, v) }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn binomial_lanes([a, b, c, d, e]: [__m256; 5]) -> __m256 {
        binomial_f(a, b, c, d, e)
    }
}

/// [`blocked::horizontal_sums`] in AVX2 lanes.
#[target_feature(enable = "avx2,fma")]
fn horizontal_sums_avx2(
    ints: [&[i32]; INTS],
    floats: [&[f32]; FLOATS],
    rings: (&mut [i32], &mut [f32], usize),
    n: usize,
) {
    // SAFETY: AVX2 and FMA are enabled here.
    unsafe { blocked::horizontal_sums::<BLOCK>(ints, floats, rings, n) }
}

/// The constants of the tail in lanes.
struct Constants {
    lambda4: __m256i,
    det_floor: __m256,
    v_d: __m256,
    v_c: __m256,
}

/// [`Blocked::tail_row`] in AVX2 lanes.
#[target_feature(enable = "avx2,fma")]
fn tail_row_avx2<const FIELDS: bool, const EXTREMES: bool, const FIRST: usize>(
    k: &TailConstants,
    rows: &BlockedRows<'_>,
    [m_d, m_c]: [&mut [f32]; 2],
    fields: [&mut [f32]; 4],
) -> ExtremesSink {
    let w = m_d.len();
    let (nb, whole) = (blocks::<BLOCK>(w), w / BLOCK);
    let Some([vx, vy]) = blocked::tail_v::<FIELDS, BLOCK>(rows, w, m_c, &fields) else {
        return ExtremesSink::default();
    };
    let c = Constants {
        lambda4: _mm256_set1_epi32(k.lambda4),
        det_floor: _mm256_set1_ps(k.units.det_floor),
        v_d: _mm256_set1_ps(k.units.v_d),
        v_c: _mm256_set1_ps(k.units.v_c),
    };
    let (ints, floats) = (rows.ints.as_ptr(), rows.floats.as_ptr());
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
        // `tail_v` checked; AVX2 and FMA are enabled here.
        unsafe {
            let (abc, pq) = blocked::block_sums::<FIRST, BLOCK>(ints, floats, b);
            let v = [
                i32::load(vx.as_ptr().add(at)),
                i32::load(vy.as_ptr().add(at)),
            ];
            let px = pixels(&c, abc, pq, v);
            if EXTREMES {
                let bits = [_mm256_castps_si256(px.m_d), _mm256_castps_si256(px.m_c)];
                for k in 0..2 {
                    min[k] = _mm256_min_epu32(min[k], bits[k]);
                    max[k] = _mm256_max_epu32(max[k], bits[k]);
                }
            }
            for (row, lanes) in out.iter().zip(outputs::<FIELDS>(&c, &px)) {
                f32::store(row.add(at), lanes);
            }
        }
    }
    let mut extremes = [0, 1].map(|k| {
        let (mut lo, mut hi) = ([0u32; BLOCK], [0u32; BLOCK]);
        // SAFETY: eight lanes into local arrays of eight; AVX2 and FMA are
        // enabled here.
        unsafe {
            i32::store(lo.as_mut_ptr().cast(), min[k]);
            i32::store(hi.as_mut_ptr().cast(), max[k]);
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
        let (vx, vy) = (
            blocked::padded::<BLOCK>(vx, at),
            blocked::padded::<BLOCK>(vy, at),
        );
        let mut local = [[0.0f32; BLOCK]; 6];
        // SAFETY: block `whole < nb` lies in both rings; `V` and the
        // results are local arrays of eight lanes; AVX2 and FMA are
        // enabled here.
        unsafe {
            let (abc, pq) = blocked::block_sums::<FIRST, BLOCK>(ints, floats, whole);
            let px = pixels(
                &c,
                abc,
                pq,
                [i32::load(vx.as_ptr()), i32::load(vy.as_ptr())],
            );
            for (row, lanes) in local.iter_mut().zip(outputs::<FIELDS>(&c, &px)) {
                f32::store(row.as_mut_ptr(), lanes);
            }
        }
        let rows = [m_d, m_c, v_c_x, v_c_y, v_d_x, v_d_y];
        blocked::finish_partial(rows, &local, (at, w), &mut extremes);
    }
    let [m_d, m_c] = extremes;
    ExtremesSink { m_d, m_c }
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
fn pixels(
    c: &Constants,
    [a, b, cc]: [IntLanes<BLOCK>; INTS],
    [p, q]: [FloatLanes<BLOCK>; FLOATS],
    v: [__m256i; 2],
) -> Pixels {
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

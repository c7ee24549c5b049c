//! The row kernels of SPEC §3, in exact integers at `p ∈ [0, 255]`.
//!
//! Each kernel fills one row of a stage from rows of the stage before, one
//! plane per channel so the loops vectorise. Rows are indexed by window
//! column `i ∈ [0, n)`; a kernel of radius `r` writes columns
//! `[lo + r, n − lo − r)` from inputs valid on `[lo, n − lo)`, so the valid
//! part shrinks by the radii of SPEC §6 (2, 2, 1, 2: seven in all).
//!
//! | stage | format | bound (tight) |
//! |---|---|---|
//! | `d = p1 − p0` | i16 | 255 |
//! | vertical parts of `Kb3 ⋆ d`, `Box⋆Sob ⋆ d` | i16 | `12 · 255 = 3060` |
//! | their horizontal parts (vector rows; `Kb3 ⋆ d`, `Box⋆Sob ⋆ d`) | i16 | `48 · 255 = 12 240` |
//! | `E = Kb3 ⋆ d − 3 · Box⋆Sob ⋆ d` (`= 3·255·(B − S)`) | i32 | `132 · 255 = 33 660` |
//! | vertical `G` of `E` | i32 | `16 · 33 660 = 538 560` |
//! | `V = G256 ⋆ E` (`v_c = V · s/768`) | i32 | `26 880 · 255 = 6 854 400 < 2²³` |
//! | `Q = 1536 · div / s` (central differences) | i32 | `63 312 · 255 = 16 144 560 < 2²⁴` |
//! | `X, Y = Sobel ⋆ p0` (`fx = X · s/8`) | i32 | 1020 |
//! | `Dn = −κ·d − (X·Vx + Y·Vy) − 4·p0·Q` (`D = Dn · s²/6144`) | i64 | `255·κ + 1020 · 29 853 360 < 2^(27+σ)` |
//! | `Dn′ = round(Dn / 2^σ)` | i32 | `|Dn′| ≤ 2²⁷` |
//! | `X², XY, Y²`, then horizontal `G` | i32 | `16 · 1020² < 2²⁴` |
//! | `a, b, c` (vertical `G`) | i32 | `256 · 1020² < 2²⁸` |
//! | `X · Dn′ · 2⁻²⁰`, `Y · …`, then both `G`s: `p, q` | f32 | `256 · 1020 · 2⁷ < 2²⁵` |
//!
//! `V`'s and `Q`'s bounds are the L1 norms of their kernels on `d` times 255.
//! Everything up to `Dn′` and the sums `a, b, c` are exact integers. `Dn′`
//! is the first rounding (at most `2^(σ−1)` against `|κ·d| ≥ 2^(σ+12)` for
//! any temporal change); `p` and `q` are summed in `f32` (each product and
//! sum correctly rounded, in one fixed order on every target: the binomial
//! below), which, like the tail's `f32` solve, stays far inside the SPEC's
//! tolerances (`tests/tests/accuracy.rs`). The scaling by 2⁻²⁰ (exact)
//! keeps the tail's squares of `N` in range; every product is then 0 or
//! a multiple of 2⁻²⁰, so no value is subnormal.
//!
//! The bounds are worst cases over all inputs (`Dn`'s first term at the
//! largest admissible `κ`); the tests run with overflow checks on.
//!
//! Each loop first cuts every row it reads or writes to exactly the columns
//! it covers (`cut`: a length the compiler knows), then counts over them:
//! no bounds check (and no panic path) is left for the compiler to keep, the
//! loops vectorise without telling the rows apart by address, and a row the
//! memory cannot serve (never, once an engine has validated its memory)
//! makes the kernel do nothing.

use core::ops::Add;

use crate::kernels::KernelSet;

/// What the binomial sums add: exact integers, or `f32` (the sums of `p`
/// and `q`).
pub trait Sample: Copy + Default + Add<Output = Self> {
    /// `a + 4b + 6c + 4d + e`, the binomial `[1 4 6 4 1]` (SPEC's `G`, ×16).
    fn binomial(a: Self, b: Self, c: Self, d: Self, e: Self) -> Self;

    /// The set's kernel for this kind of sum (on the scalar boards).
    fn binomial_kernel<K: KernelSet>(binomial: Binomial<'_, Self>);
}

/// A binomial a kernel set computes, on the scalar boards (shorter rows
/// leave `out` untouched).
pub enum Binomial<'a, T> {
    /// [`Sample::binomial`] of every column of five rows, `out.len()`
    /// columns (the vertical one).
    Rows([&'a [T]; 5], &'a mut [T]),
    /// The horizontal one of `out.len() + 4` taps.
    Taps(&'a [T], &'a mut [T]),
}

impl Sample for i32 {
    #[inline(always)]
    fn binomial(a: i32, b: i32, c: i32, d: i32, e: i32) -> i32 {
        (a + e) + ((b + d) << 2) + (c << 2) + (c << 1)
    }

    #[inline(always)]
    fn binomial_kernel<K: KernelSet>(binomial: Binomial<'_, i32>) {
        K::binomial_exact(binomial);
    }
}

impl Sample for f32 {
    /// In this order on every target (`×4` is exact; `×6` and each sum
    /// round once).
    #[inline(always)]
    fn binomial(a: f32, b: f32, c: f32, d: f32, e: f32) -> f32 {
        ((a + e) + (b + d) * 4.0) + c * 6.0
    }

    #[inline(always)]
    fn binomial_kernel<K: KernelSet>(binomial: Binomial<'_, f32>) {
        K::binomial_float(binomial);
    }
}

/// Columns `[r, n − r)` of a window of `n` columns. Rows are at least `n`
/// long (the engine carves them so); a shorter one reads as empty.
#[inline(always)]
fn span(n: usize, r: usize) -> core::ops::Range<usize> {
    r..n.saturating_sub(r)
}

/// The vertical binomial of five rows on `[r, n − r)`.
#[inline(always)]
pub(crate) fn vertical_binomial<K: KernelSet, T: Sample>(
    rows: [&[T]; 5],
    out: &mut [T],
    n: usize,
    r: usize,
) {
    let cols = span(n, r);
    let len = cols.len();
    let [a, b, c, d, e] = rows.map(|row| cut(row, cols.start, len));
    let (Some(a), Some(b), Some(c), Some(d), Some(e), Some(out)) =
        (a, b, c, d, e, cut_mut(out, cols.start, len))
    else {
        return;
    };
    if crate::VECTOR_ROWS {
        binomial_of(a, b, c, d, e, opaque(out));
    } else {
        T::binomial_kernel::<K>(Binomial::Rows([a, b, c, d, e], out));
    }
}

/// `out[i] = G` of the five rows' `i`-th values. Every row a parameter of
/// its own (the hot loops' pattern, here and in `tail`): Rust tells the
/// compiler that references passed so do not alias. Rows reached through
/// arrays or structures carry no such promise, and where the engine's rows
/// come from one memory the compiler must then prove them apart itself,
/// which it did for some loops and not for others (the x86-64 pass ran its
/// vertical sums scalar). Inlined, the promise did not survive for every
/// loop either when the rows' width is known only at run time (a
/// `SliceEngine`: on aarch64 130 instructions per pixel at 640×480, against
/// 100 with the loops out of line, `scripts/embedded-check`). So where the
/// pass is not compiled twice (`dispatched_pass`, `build.rs`) each such
/// loop is a function of its own.
#[cfg_attr(dispatched_pass, inline(always))]
#[cfg_attr(not(dispatched_pass), inline(never))]
pub(crate) fn binomial_of<T: Sample>(a: &[T], b: &[T], c: &[T], d: &[T], e: &[T], out: &mut [T]) {
    let len = out.len();
    cut_rows!(len => a, b, c, d, e);
    for i in 0..len {
        out[i] = T::binomial(a[i], b[i], c[i], d[i], e[i]);
    }
}

/// The horizontal binomial of a row valid on `[r − 2, n − r + 2)`, on `[r, n − r)`.
#[inline(always)]
pub(crate) fn horizontal_binomial<K: KernelSet, T: Sample>(
    row: &[T],
    out: &mut [T],
    n: usize,
    r: usize,
) {
    let cols = span(n, r.max(2));
    let len = cols.len();
    let Some(out) = cut_mut(out, cols.start, len) else {
        return;
    };
    let first = cols.start.wrapping_sub(2);
    // Running sums on the scalar boards (one load and four adds a column,
    // where the loads are the cost); taps where they vectorise (a running
    // sum would serialise them), and for `f32`, whose sums must keep one
    // order on every target.
    if crate::VECTOR_ROWS {
        tapped_binomial(row, first, out);
    } else if let Some(taps) = cut(row, first, len + 4) {
        T::binomial_kernel::<K>(Binomial::Taps(taps, out));
    }
}

/// [`tapped_binomial`] on the scalar boards: the last four taps carried
/// from column to column, one load a column, the sum in the same order.
#[cfg_attr(dispatched_pass, inline(always))]
#[cfg_attr(not(dispatched_pass), inline(never))]
pub(crate) fn sliding_binomial<T: Sample>(taps: &[T], out: &mut [T]) {
    let (Some(&[x0, x1, x2, x3]), Some(rest)) = (taps.get(..4), taps.get(4..)) else {
        return;
    };
    let (mut a, mut b, mut c, mut d) = (x0, x1, x2, x3);
    for (o, &e) in out.iter_mut().zip(rest) {
        *o = T::binomial(a, b, c, d, e);
        (a, b, c, d) = (b, c, d, e);
    }
}

/// `out[i] = G ⋆ row[first + i .. first + i + 5]`, five taps a column.
#[inline(always)]
fn tapped_binomial<T: Sample>(row: &[T], first: usize, out: &mut [T]) {
    let len = out.len();
    // Each tap cut from the row itself: independent lanes to vectorise.
    let at = |shift: usize| cut(row, first.wrapping_add(shift), len);
    let (Some(a), Some(b), Some(c), Some(d), Some(e)) = (at(0), at(1), at(2), at(3), at(4)) else {
        return;
    };
    binomial_of(a, b, c, d, e, out);
}

/// [`tapped_binomial`] as four running pair sums, `[1 4 6 4 1] = [1 1]⁴`:
/// with `sₖ` the `k`-fold pair sum, each new tap `x` gives `s₁ = x′ + x`,
/// `s₂ = s₁′ + s₁`, `s₃ = s₂′ + s₂` and the output `s₃′ + s₃` (primes: the
/// previous column's). Every partial sum has nonnegative weights summing to
/// at most 16, so it stays within the output's bound.
#[cfg_attr(dispatched_pass, inline(always))]
#[cfg_attr(not(dispatched_pass), inline(never))]
pub(crate) fn running_binomial<T>(taps: &[T], out: &mut [T])
where
    T: Copy + Add<Output = T>,
{
    let (Some(&[x0, x1, x2, x3]), Some(rest)) = (taps.get(..4), taps.get(4..)) else {
        return;
    };
    let (s1_a, s1_b, s1_c) = (x0 + x1, x1 + x2, x2 + x3);
    let (s2_a, s2_b) = (s1_a + s1_b, s1_b + s1_c);
    let (mut x, mut s1, mut s2, mut s3) = (x3, s1_c, s2_b, s2_a + s2_b);
    for (o, &next) in out.iter_mut().zip(rest) {
        let t1 = x + next;
        let t2 = s1 + t1;
        let t3 = s2 + t2;
        *o = s3 + t3;
        (x, s1, s2, s3) = (next, t1, t2, t3);
    }
}

/// Rows of one channel pair (x, y).
pub type Pair<'a, T> = (&'a mut [T], &'a mut [T]);

/// `p0` and `d = p1 − p0` (SPEC §2) of a row's pixels inside the frame,
/// as far as the shortest of the four rows goes (`KernelSet::load_pixels`).
#[inline(always)]
pub(crate) fn load_pixels_of([prev, next]: [&[u8]; 2], p: &mut [u8], d: &mut [i16]) {
    for (((p, dd), &a), &b) in p.iter_mut().zip(d.iter_mut()).zip(prev).zip(next) {
        *p = a;
        *dd = i16::from(b) - i16::from(a);
    }
}

/// `E` (x, y) on `[2, n−2)` from the five `d` rows centred on it, and `E`
/// smoothed along the row on `[4, n−4)` (`KernelSet::smoothed_e`: a set
/// may keep `E` itself in registers and leave `e` as it was).
///
/// Separable forms (rows ⊗ columns, correlation):
/// `Kbx3 = [1 4 1]ᵀ⊗[−1 0 1]`, `Box⋆Sobx = [1 3 4 3 1]ᵀ⊗[−1 −1 0 1 1]`,
/// `Kby3 = [−1 0 1]ᵀ⊗[1 4 1]`, `Box⋆Soby = [−1 −1 0 1 1]ᵀ⊗[1 3 4 3 1]`:
/// the vertical parts first (`[1 4 1]`, `[1 3 4 3 1]`, `[−1 0 1]`,
/// `[−1 −1 0 1 1]`, all within ±3060 in i16), then the horizontal ones.
/// A set may take it in one loop (`KernelSet::boundary_minus_domain`,
/// keeping the vertical parts in registers).
#[inline(always)]
pub fn boundary_minus_domain<K: KernelSet>(
    d: [&[i16]; 5],
    vert: &mut [&mut [i16]; 4],
    e: Pair<'_, i32>,
    e_smoothed: Pair<'_, i32>,
    n: usize,
) {
    K::boundary_minus_domain(d, vert, e, e_smoothed, n);
}

/// The portable `KernelSet::boundary_minus_domain`: the vertical parts
/// into `vert` (`KernelSet::vertical_parts`), then `E` and its horizontal
/// binomial from them (`KernelSet::smoothed_e`).
#[inline(always)]
pub(crate) fn portable_boundary_minus_domain<K: KernelSet>(
    d: [&[i16]; 5],
    vert: &mut [&mut [i16]; 4],
    e: Pair<'_, i32>,
    e_smoothed: Pair<'_, i32>,
    n: usize,
) {
    let [v1, v2, v3, v4] = vert;
    vertical_parts::<K>(d, v1, v2, v3, v4, span(n, 0));
    K::smoothed_e([v1, v2, v3, v4], e, e_smoothed, n);
}

/// `E` on `[2, n−2)` (into `e`) from its four vertical parts, and the
/// horizontal half of `V = G256 ⋆ E` right away (`smooth` takes the
/// vertical one) on `[4, n−4)`: the ring keeps `E` smoothed along its row.
/// The portable `KernelSet::smoothed_e`.
#[inline(always)]
pub(crate) fn portable_smoothed_e<K: KernelSet>(
    [v1, v2, v3, v4]: [&[i16]; 4],
    (ex, ey): Pair<'_, i32>,
    e_smoothed: Pair<'_, i32>,
    n: usize,
) {
    horizontal_parts([v1, v2, v3, v4], ex, ey, span(n, 2));
    horizontal_binomial::<K, _>(ex, e_smoothed.0, n, 4);
    horizontal_binomial::<K, _>(ey, e_smoothed.1, n, 4);
}

/// The four vertical parts of `E` on columns `cols`.
#[inline(always)]
fn vertical_parts<K: KernelSet>(
    d: [&[i16]; 5],
    v1: &mut [i16],
    v2: &mut [i16],
    v3: &mut [i16],
    v4: &mut [i16],
    cols: core::ops::Range<usize>,
) {
    let [d0, d1, d2, d3, d4] = d;
    cut_rows!(cols.start, cols.len() => d0, d1, d2, d3, d4);
    cut_rows!(cols.start, cols.len() => ; mut v1, v2, v3, v4);
    K::vertical_parts([d0, d1, d2, d3, d4], [v1, v2, v3, v4]);
}

/// [`vertical_parts`]' loop, every output row a parameter of its own (see
/// [`binomial_of`]); the inputs are only read.
#[cfg_attr(dispatched_pass, inline(always))]
#[cfg_attr(not(dispatched_pass), inline(never))]
pub(crate) fn vertical_parts_of(
    [d0, d1, d2, d3, d4]: [&[i16]; 5],
    v1: &mut [i16],
    v2: &mut [i16],
    v3: &mut [i16],
    v4: &mut [i16],
) {
    let len = d0.len();
    cut_rows!(len => d1, d2, d3, d4);
    cut_rows!(len => ; mut v1, v2, v3, v4);
    for i in 0..len {
        let (a, b, c, dd, ee) = (d0[i], d1[i], d2[i], d3[i], d4[i]);
        v1[i] = b + 4 * c + dd;
        v2[i] = (a + ee) + 3 * (b + dd) + 4 * c;
        v3[i] = dd - b;
        v4[i] = (dd + ee) - (a + b);
    }
}

/// `E` (x, y) on columns `cols` from its four vertical parts.
#[inline(always)]
fn horizontal_parts(
    vert: [&[i16]; 4],
    ex: &mut [i32],
    ey: &mut [i32],
    cols: core::ops::Range<usize>,
) {
    let (start, len) = (cols.start, cols.len());
    let (Some(ex), Some(ey)) = (cut_mut(ex, start, len), cut_mut(ey, start, len)) else {
        return;
    };
    let (ex, ey) = (opaque(ex), opaque(ey));
    if !crate::VECTOR_ROWS {
        // Each part from two columns left of the first output to two right
        // of the last.
        let window = |row| cut(row, start.wrapping_sub(2), len + 4);
        let [v1, v2, v3, v4] = vert.map(window);
        if let (Some(v1), Some(v2), Some(v3), Some(v4)) = (v1, v2, v3, v4) {
            boundary_minus_domain_x_row(v1, v2, ex);
            boundary_minus_domain_y_row(v3, v4, ey);
        }
        return;
    }
    // Each tap its own shifted slice: independent lanes to vectorise.
    let [v1, v2, v3, v4] = vert.map(|row| taps5(row, start, len));
    let (Some(v1), Some(v2), Some(v3), Some(v4)) = (v1, v2, v3, v4) else {
        return;
    };
    // One loop per component: one for both kept 20 row pointers live,
    // which the Cortex-M4F spilled (61 instructions per pixel against 45,
    // `scripts/embedded-check`; its kernels: `kernels/m4.rs`).
    let ([a, b, c, d, e], [f, g, h, i, j]) = (v1, v2);
    component_of(boundary_minus_domain_x, a, b, c, d, e, f, g, h, i, j, ex);
    let ([a, b, c, d, e], [f, g, h, i, j]) = (v3, v4);
    component_of(boundary_minus_domain_y, a, b, c, d, e, f, g, h, i, j, ey);
}

/// One component of `E` from the five taps of two vertical parts, every
/// tap and the output a parameter of its own (see [`binomial_of`]).
/// Counted, not enumerated: `iter_mut().enumerate()` left a bounds check
/// (a panic path) on the taps.
#[cfg_attr(dispatched_pass, inline(always))]
#[cfg_attr(not(dispatched_pass), inline(never))]
#[allow(clippy::too_many_arguments)]
fn component_of(
    formula: impl Fn([i16; 5], [i16; 5]) -> i32,
    a: &[i16],
    b: &[i16],
    c: &[i16],
    d: &[i16],
    e: &[i16],
    f: &[i16],
    g: &[i16],
    h: &[i16],
    i: &[i16],
    j: &[i16],
    out: &mut [i32],
) {
    let len = out.len();
    cut_rows!(len => a, b, c, d, e);
    cut_rows!(len => f, g, h, i, j);
    for k in 0..len {
        out[k] = formula(
            [a[k], b[k], c[k], d[k], e[k]],
            [f[k], g[k], h[k], i[k], j[k]],
        );
    }
}

/// `E` x of one column from the taps `k ∈ [0, 5)` (column offsets `k − 2`)
/// of its vertical parts `[1 4 1]ᵀ ⋆ d` (within ±1530) and
/// `[1 3 4 3 1]ᵀ ⋆ d` (±3060). Both horizontal parts fit in i16 (`Kbx3`
/// ±3060, `Box⋆Sobx` ±12 240), so vector lanes take them sixteen a step and
/// widen two values, not six taps; `E` itself (±33 660) is i32.
#[inline(always)]
fn boundary_minus_domain_x(v1: [i16; 5], v2: [i16; 5]) -> i32 {
    let kb_x = v1[3] - v1[1];
    let bs_x = (v2[3] + v2[4]) - (v2[1] + v2[0]);
    let e = i32::from(kb_x) - 3 * i32::from(bs_x);
    debug_assert!(e.abs() <= E_MAX, "E x = {e}");
    e
}

/// `E` y of one column from the taps of its vertical parts `[−1 0 1]ᵀ ⋆ d`
/// (±510) and `[−1 −1 0 1 1]ᵀ ⋆ d` (±1020): the horizontal parts in i16
/// (`Kby3` ±3060, `Box⋆Soby` ±12 240), `E` in i32, as for x.
#[inline(always)]
fn boundary_minus_domain_y(v3: [i16; 5], v4: [i16; 5]) -> i32 {
    let kb_y = v3[1] + 4 * v3[2] + v3[3];
    let bs_y = (v4[0] + v4[4]) + 3 * (v4[1] + v4[3]) + 4 * v4[2];
    let e = i32::from(kb_y) - 3 * i32::from(bs_y);
    debug_assert!(e.abs() <= E_MAX, "E y = {e}");
    e
}

/// [`e_row_taps`]: the first part's two taps, its rest, the second part's
/// four taps, its rest.
type ERowTaps<'a> = ([i32; 2], &'a [i16], [i32; 4], &'a [i16]);

/// What the scalar rows of `E` read for `len` outputs, from vertical parts
/// two columns wider either side: the first part's taps left of the first
/// output and its taps from the first right of it on, the second part's
/// first four taps and the rest (`None` if a part is short). Iterated by
/// the rows, not indexed: no bounds check (and no panic path) in any build,
/// however little it knows of the lengths.
#[inline(always)]
fn e_row_taps<'a>(first: &'a [i16], second: &'a [i16], len: usize) -> Option<ERowTaps<'a>> {
    let (&[l0, l1], rest) = (first.get(1..3)?, first.get(3..len + 3)?) else {
        return None;
    };
    let (&[w0, w1, w2, w3], tail) = (second.get(..4)?, second.get(4..len + 4)?) else {
        return None;
    };
    Some((
        [l0, l1].map(i32::from),
        rest,
        [w0, w1, w2, w3].map(i32::from),
        tail,
    ))
}

/// `E` x of a row on the scalar boards, from its vertical parts two
/// columns wider either side, as [`boundary_minus_domain_x`] with the taps
/// carried from column to column: with the pair sums `u[k] = v2[k] +
/// v2[k+1]`, `Box⋆Sobx = u[i+1] − u[i−2]`. Two loads a column.
#[inline(never)]
fn boundary_minus_domain_x_row(v1: &[i16], v2: &[i16], out: &mut [i32]) {
    let Some(([l0, l1], v1, [w0, w1, w2, w3], v2)) = e_row_taps(v1, v2, out.len()) else {
        return;
    };
    // `v1` from the column left of the first output; the pair sums left of
    // it (u[i−2], u[i−1], u[i]) and the last tap of `v2` (v2[i+1]).
    let (mut left, mut mid) = (l0, l1);
    let (mut u0, mut u1, mut u2, mut last) = (w0 + w1, w1 + w2, w2 + w3, w3);
    for ((o, &right), &next) in out.iter_mut().zip(v1).zip(v2) {
        let (right, next) = (i32::from(right), i32::from(next));
        let u3 = last + next;
        let e = (right - left) - 3 * (u3 - u0);
        debug_assert!(e.abs() <= E_MAX, "E x = {e}");
        *o = e;
        (left, mid, u0, u1, u2, last) = (mid, right, u1, u2, u3, next);
    }
}

/// `E` y of a row on the scalar boards (see [`boundary_minus_domain_x_row`]):
/// `[1 3 4 3 1] = [1 1] ⋆ [1 1] ⋆ [1 1 1]`, so with `a[k] = v4[k] + v4[k+1]`
/// and `b[k] = a[k−1] + a[k]`, `Box⋆Soby = b[i−1] + b[i] + b[i+1]`.
#[inline(never)]
fn boundary_minus_domain_y_row(v3: &[i16], v4: &[i16], out: &mut [i32]) {
    let Some(([l0, l1], v3, [w0, w1, w2, w3], v4)) = e_row_taps(v3, v4, out.len()) else {
        return;
    };
    let (mut left, mut mid) = (l0, l1);
    // a[i−1] .. a[i+1] need v4 up to i+2; before the first column:
    // b[i−1] = a[i−2] + a[i−1], b[i] = a[i−1] + a[i], and a[i].
    let (a0, a1, a2) = (w0 + w1, w1 + w2, w2 + w3);
    let (mut b0, mut b1, mut a, mut last) = (a0 + a1, a1 + a2, a2, w3);
    for ((o, &right), &next) in out.iter_mut().zip(v3).zip(v4) {
        let (right, next) = (i32::from(right), i32::from(next));
        let a_next = last + next;
        let b2 = a + a_next;
        let kb = left + 4 * mid + right;
        let e = kb - 3 * (b0 + b1 + b2);
        debug_assert!(e.abs() <= E_MAX, "E y = {e}");
        *o = e;
        (left, mid, b0, b1, a, last) = (mid, right, b1, b2, a_next, next);
    }
}

/// `V = G256 ⋆ E` on `[4, n−4)` from the five rows of `E` centred on it,
/// each already smoothed along the row (`boundary_minus_domain`): the
/// vertical half. Integer sums are exact, so the order of the halves does
/// not matter; this one keeps both halves in loops the compiler takes in
/// vector lanes (with the horizontal half last, from a scratch row into
/// the ring of `V`, the x86-64 pass ran it scalar).
#[inline(always)]
pub fn smooth<K: KernelSet>(e_smoothed: [[&[i32]; 5]; 2], v: Pair<'_, i32>, n: usize) {
    K::smooth(e_smoothed, (&mut *v.0, &mut *v.1), n);
    debug_assert!(
        v.0.iter().chain(v.1.iter()).all(|v| v.abs() <= V_MAX),
        "V beyond its bound"
    );
}

/// [`smooth`]'s vertical binomials, one component after the other: the
/// portable kernel of `KernelSet::smooth`.
#[inline(always)]
pub(crate) fn portable_smooth<K: KernelSet>(
    e_smoothed: [[&[i32]; 5]; 2],
    v: Pair<'_, i32>,
    n: usize,
) {
    let [ex, ey] = e_smoothed;
    vertical_binomial::<K, _>(ex, v.0, n, 4);
    vertical_binomial::<K, _>(ey, v.1, n, 4);
}

/// `|E| ≤ 132 · 255` (module table).
const E_MAX: i32 = 132 * 255;
/// `|V| ≤ 26 880 · 255` (module table).
const V_MAX: i32 = 26_880 * 255;

/// The rows one residual row reads: `V` above, at and below it, `p0` likewise,
/// and `d` at it.
pub struct ResidualInputs<'a> {
    /// `V` x at the row.
    pub vx: &'a [i32],
    /// `V` y above, at and below the row.
    pub vy: [&'a [i32]; 3],
    /// `p0` above, at and below the row.
    pub p0: [&'a [u8]; 3],
    /// `d = p1 − p0` at the row.
    pub d: &'a [i16],
    /// `κ = 6144 / s` (see `params`) as `κh·2^σ + κl`: `[κh, κl]`.
    pub kappa: [i32; 2],
    /// `σ`: the residual is summed as `round(Dn / 2^σ)` (see `params`).
    pub shift: u32,
}

/// The integer structure channels, in the order of the product rows and
/// the engine's sum rings: `X², XY, Y²`.
pub const INT_CHANNELS: usize = 3;

/// The `f32` structure channels: `X·Dn′·2⁻²⁰`, `Y·Dn′·2⁻²⁰`.
pub const FLOAT_CHANNELS: usize = 2;

/// 2⁻²⁰, the scaling of `Dn′` in the `f32` products (module doc).
pub(crate) const DN_SCALE: f32 = 1.0 / 1_048_576.0;

/// `Dn′ = round(Dn / 2^σ)` (half up) of
/// `Dn = −κ·d − (X·Vx + Y·Vy) − 4·p0·Q`, exactly, in 32-bit lanes: with
/// `κ = κh·2^σ + κl`, `V = Vh·2^σ + Vl`, `Q = Qh·2^σ + Ql` (low parts in
/// `[0, 2^σ)`), `Dn = H·2^σ + L` and `Dn′ = H + ⌊(L + 2^(σ−1)) / 2^σ⌋`.
/// Bounds (σ ∈ [8, 14], `255·κ < 2^(27+σ)`): `|κh·d| < 2²⁷`, `|X·Vh| ≤
/// 1020 · 2¹⁵`, `|4·p0·Qh| ≤ 1020 · 2¹⁶`, so `|H| < 2²⁹`; `|L| ≤ 255 · 2¹⁴ +
/// 3 · 1020 · 2¹⁴ < 2²⁶`. The result is within `2²⁷` (see `params`).
#[inline(always)]
pub fn rounded_residual(
    kappa: [i32; 2],
    shift: u32,
    d: i32,
    gradient: [i32; 2],
    v: [i32; 2],
    p0: i32,
    q: i32,
) -> i32 {
    let low = (1 << shift) - 1;
    let [x, y] = gradient;
    let [vx, vy] = v;
    let high = -kappa[0] * d - x * (vx >> shift) - y * (vy >> shift) - 4 * p0 * (q >> shift);
    let rest = -kappa[1] * d - x * (vx & low) - y * (vy & low) - 4 * p0 * (q & low);
    let dn = high + ((rest + (1 << (shift - 1))) >> shift);
    debug_assert!(dn.unsigned_abs() <= 1 << 27, "Dn′ = {dn} beyond 2²⁷");
    dn
}

/// `row`, its address hidden from the compiler where the pass is compiled
/// twice (`dispatched_pass`): derived from the engine's carving of its
/// memory, the address told the compiler where a row stood against 16-byte
/// boundaries, and it split each 32-byte store of `E` into four and built
/// `V`'s loads in the tail from shuffles (x86-64: 54.5 → 51.2 instructions
/// a pixel with this on `E`, the vertical sums and the tail's `V`,
/// `scripts/profile-stages`). A row's address passes through memory once
/// a call.
#[inline(always)]
pub(crate) fn opaque<T>(row: T) -> T {
    if cfg!(dispatched_pass) {
        core::hint::black_box(row)
    } else {
        row
    }
}

/// `len` elements of `row` from `start` (`None` if it is shorter): a slice
/// whose length the compiler knows is `len`, so indexing it below `len`
/// keeps no bounds check.
#[inline(always)]
pub(crate) fn cut<T>(row: &[T], start: usize, len: usize) -> Option<&[T]> {
    row.get(start..)?.get(..len)
}

/// [`cut`], to be written.
#[inline(always)]
pub(crate) fn cut_mut<T>(row: &mut [T], start: usize, len: usize) -> Option<&mut [T]> {
    row.get_mut(start..)?.get_mut(..len)
}

/// Each named row (a local slice) [`cut`] to `len` elements from `start`
/// (its first `len` without one), and each after `mut` likewise to be
/// written, or a return from the function where one is shorter (never,
/// for the engine's rows): the row loops' one way to know their rows'
/// lengths.
macro_rules! cut_rows {
    ($len:expr => $($row:ident),* $(; mut $($out:ident),+)?) => {
        let len: usize = $len;
        let ($(Some($row),)* $($(Some($out),)+)?) =
            ($($row.get(..len),)* $($($out.get_mut(..len),)+)?)
        else {
            return;
        };
    };
    ($start:expr, $len:expr => $($row:ident),* $(; mut $($out:ident),+)?) => {
        let (start, len): (usize, usize) = ($start, $len);
        let ($(Some($row),)* $($(Some($out),)+)?) = (
            $($crate::stages::cut($row, start, len),)*
            $($($crate::stages::cut_mut($out, start, len),)+)?
        ) else {
            return;
        };
    };
}
pub(crate) use cut_rows;

/// The row shifted by `−2 … +2` around `len` columns from `start` (tap `k`
/// of column `i` is element `start + i + k − 2`), each [`cut`] to `len`.
#[inline(always)]
fn taps5<T>(row: &[T], start: usize, len: usize) -> Option<[&[T]; 5]> {
    let first = start.checked_sub(2)?;
    Some([
        cut(row, first, len)?,
        cut(row, first + 1, len)?,
        cut(row, first + 2, len)?,
        cut(row, first + 3, len)?,
        cut(row, first + 4, len)?,
    ])
}

/// The five products on columns `cols`: the product rows cut to them, then
/// the set's kernel ([`portable_products_row`] by default).
#[inline(always)]
fn products_row<K: KernelSet>(
    input: &ResidualInputs<'_>,
    [xx, xy, yy]: [&mut [i32]; 3],
    [xd, yd]: [&mut [f32]; 2],
    scratch: ScratchRows<'_>,
    cols: core::ops::Range<usize>,
) {
    cut_rows!(cols.start, cols.len() => ; mut xx, xy, yy, xd, yd);
    let rows = ProductRows {
        ints: [xx, xy, yy],
        floats: [xd, yd],
        scratch,
    };
    K::products_row(input, rows, cols);
}

/// [`products_row`]'s portable kernel, into product rows already cut to
/// the columns.
#[inline(always)]
pub(crate) fn portable_products_row(
    input: &ResidualInputs<'_>,
    [xx, xy, yy]: [&mut [i32]; 3],
    [xd, yd]: [&mut [f32]; 2],
    cols: core::ops::Range<usize>,
) {
    let ResidualInputs {
        vx,
        vy: [vy_up, vy, vy_down],
        p0: [p_up, p_mid, p_down],
        d,
        kappa,
        shift,
    } = *input;
    // Every row cut to exactly the columns (shifted rows one either side),
    // then indexed: a counted loop with no bounds left to check.
    let len = cols.len();
    let first = cols.start.wrapping_sub(1);
    let at = |row, shift| cut::<i32>(row, first.wrapping_add(shift), len);
    let at8 = |row, shift| cut::<u8>(row, first.wrapping_add(shift), len);
    let (Some(vx_l), Some(vx_c), Some(vx_r), Some(vy_u), Some(vy_c), Some(vy_d)) = (
        at(vx, 0),
        at(vx, 1),
        at(vx, 2),
        at(vy_up, 1),
        at(vy, 1),
        at(vy_down, 1),
    ) else {
        return;
    };
    let (Some(pu0), Some(pu1), Some(pu2), Some(pm0), Some(pm1), Some(pm2)) = (
        at8(p_up, 0),
        at8(p_up, 1),
        at8(p_up, 2),
        at8(p_mid, 0),
        at8(p_mid, 1),
        at8(p_mid, 2),
    ) else {
        return;
    };
    let (Some(pd0), Some(pd1), Some(pd2), Some(d)) = (
        at8(p_down, 0),
        at8(p_down, 1),
        at8(p_down, 2),
        cut(d, cols.start, len),
    ) else {
        return;
    };
    products_of(
        (kappa, shift),
        vx_l,
        vx_c,
        vx_r,
        vy_u,
        vy_c,
        vy_d,
        pu0,
        pu1,
        pu2,
        pm0,
        pm1,
        pm2,
        pd0,
        pd1,
        pd2,
        d,
        xx,
        xy,
        yy,
        xd,
        yd,
    );
}

/// [`products_row`]'s loop over rows cut to one length, every row a
/// parameter of its own (see [`binomial_of`]): `V` x left of, at and right
/// of each column, `V` y above, at and below it, `p0`'s 3×3 neighbourhood
/// (rows up, mid, down; columns left, at, right), `d`, and the products.
#[cfg_attr(dispatched_pass, inline(always))]
#[cfg_attr(not(dispatched_pass), inline(never))]
#[allow(clippy::too_many_arguments)]
fn products_of(
    (kappa, shift): ([i32; 2], u32),
    vx_l: &[i32],
    vx_c: &[i32],
    vx_r: &[i32],
    vy_u: &[i32],
    vy_c: &[i32],
    vy_d: &[i32],
    pu0: &[u8],
    pu1: &[u8],
    pu2: &[u8],
    pm0: &[u8],
    pm1: &[u8],
    pm2: &[u8],
    pd0: &[u8],
    pd1: &[u8],
    pd2: &[u8],
    d: &[i16],
    xx: &mut [i32],
    xy: &mut [i32],
    yy: &mut [i32],
    xd: &mut [f32],
    yd: &mut [f32],
) {
    let len = xx.len();
    cut_rows!(len => vx_l, vx_c, vx_r, vy_u, vy_c, vy_d);
    cut_rows!(len => pu0, pu1, pu2, pm0, pm1, pm2);
    cut_rows!(len => pd0, pd1, pd2, d);
    cut_rows!(len => ; mut xy, yy, xd, yd);
    for i in 0..len {
        let (vx_l, vx_c, vx_r) = (vx_l[i], vx_c[i], vx_r[i]);
        let (vy_u, vy_c, vy_d) = (vy_u[i], vy_c[i], vy_d[i]);
        let pu = [pu0[i], pu1[i], pu2[i]].map(i32::from);
        let pm = [pm0[i], pm1[i], pm2[i]].map(i32::from);
        let pd = [pd0[i], pd1[i], pd2[i]].map(i32::from);
        let dd = d[i];
        let q = (vx_r - vx_l) + (vy_d - vy_u);
        let x = (pu[2] - pu[0]) + 2 * (pm[2] - pm[0]) + (pd[2] - pd[0]);
        let y = (pd[0] + 2 * pd[1] + pd[2]) - (pu[0] + 2 * pu[1] + pu[2]);
        debug_assert!(x.abs() <= 1020 && y.abs() <= 1020 && q.abs() <= 16_144_560);
        let dn = rounded_residual(kappa, shift, i32::from(dd), [x, y], [vx_c, vy_c], pm[1], q);
        // `Dn′` rounds to 24 bits (from 28 at most); the scaling is exact.
        let dn = dn as f32 * DN_SCALE;
        xx[i] = x * x;
        xy[i] = x * y;
        yy[i] = y * y;
        xd[i] = x as f32 * dn;
        yd[i] = y as f32 * dn;
    }
}

/// Rows a structure row may use for its intermediate values (the engine
/// lends rows that are free at that point; a kernel set's products may use
/// them, `kernels/`).
pub struct ScratchRows<'a> {
    /// `X`.
    pub gx: &'a mut [i16],
    /// `Y`.
    pub gy: &'a mut [i16],
    /// `4·Q`, then the residual's high part.
    pub high: &'a mut [i32],
    /// The residual's low part.
    pub low: &'a mut [i32],
}

/// The product rows of one structure row cut to its columns, and the rows
/// for intermediate values: what a kernel set's products write.
pub struct ProductRows<'a> {
    /// `X², XY, Y²`.
    pub ints: [&'a mut [i32]; INT_CHANNELS],
    /// `X·Dn′·2⁻²⁰`, `Y·Dn′·2⁻²⁰`.
    pub floats: [&'a mut [f32]; FLOAT_CHANNELS],
    /// Rows for the intermediate values.
    pub scratch: ScratchRows<'a>,
}

/// The products' rows of one structure row: the exact integer channels
/// and the `f32` ones.
pub struct StructureRows<'a, 'm> {
    /// `X², XY, Y²` on `[5, n−5)`.
    pub int_products: &'a mut [&'m mut [i32]; INT_CHANNELS],
    /// `X·Dn′·2⁻²⁰`, `Y·Dn′·2⁻²⁰` on `[5, n−5)`.
    pub float_products: &'a mut [&'m mut [f32]; FLOAT_CHANNELS],
    /// Rows for the intermediate values.
    pub scratch: ScratchRows<'a>,
}

/// The five products on `[5, n−5)` (their horizontal `G` into the sums'
/// rings is the rings' own, `kernels::SumRings::store_row`).
#[inline(always)]
pub fn structure_row<K: KernelSet>(
    input: &ResidualInputs<'_>,
    rows: StructureRows<'_, '_>,
    n: usize,
) {
    let StructureRows {
        int_products,
        float_products,
        scratch,
    } = rows;
    let [xx, xy, yy] = int_products;
    let [xd, yd] = float_products;
    products_row::<K>(input, [xx, xy, yy], [xd, yd], scratch, span(n, 5));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::residual_shift;

    /// Both forms of the horizontal binomial agree with its definition,
    /// on every length and on rows at the bound of the sums.
    #[test]
    fn running_and_tapped_binomials_are_the_binomial() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        for len in 0..40 {
            for bound in [3, 2_139_095_040 / 16] {
                let taps: std::vec::Vec<i32> = (0..len + 4)
                    .map(|_| {
                        seed ^= seed << 13;
                        seed ^= seed >> 7;
                        seed ^= seed << 17;
                        (seed % (2 * bound as u64 + 1)) as i32 - bound
                    })
                    .collect();
                let want: std::vec::Vec<i32> = taps
                    .windows(5)
                    .map(|w| w[0] + 4 * w[1] + 6 * w[2] + 4 * w[3] + w[4])
                    .collect();
                let (mut tapped, mut running) = (std::vec![0; len], std::vec![0; len]);
                tapped_binomial(&taps, 0, &mut tapped);
                running_binomial(&taps, &mut running);
                assert_eq!(tapped, want, "len {len}");
                assert_eq!(running, want, "len {len}");
            }
        }
    }

    /// The scalar boards' sliding `f32` binomial sums in the tapped form's
    /// order: the same bits, on every length.
    #[test]
    fn sliding_binomial_is_the_tapped_one() {
        let mut seed = 0x0bad_5eed_1234_5678u64;
        for len in 0..40 {
            let taps: std::vec::Vec<f32> = (0..len + 4)
                .map(|_| {
                    seed ^= seed << 13;
                    seed ^= seed >> 7;
                    seed ^= seed << 17;
                    // Products as the engine makes them: multiples of 2⁻²⁰
                    // up to 2²⁵, with every bit of the mantissa in use.
                    ((seed >> 11) as i64 - (1 << 52)) as f32 * (1.0 / 1_048_576.0) / 2048.0
                })
                .collect();
            let (mut tapped, mut sliding) = (std::vec![0.0; len], std::vec![0.0; len]);
            tapped_binomial(&taps, 0, &mut tapped);
            sliding_binomial(&taps, &mut sliding);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<std::vec::Vec<_>>();
            assert_eq!(bits(&sliding), bits(&tapped), "len {len}");
        }
    }

    /// The scalar boards' rows of `E` are the tapped components, on every
    /// length and on vertical parts at their bounds.
    #[test]
    fn rows_of_e_are_its_components() {
        let mut seed = 0x1234_5678_9abc_def1u64;
        for len in 0..40 {
            for bound in [2, 255] {
                // Vertical parts as the engine makes them, from five rows
                // of `d` (their bounds hold `E` within its own).
                let mut row = || -> std::vec::Vec<i16> {
                    (0..len + 4)
                        .map(|_| {
                            seed ^= seed << 13;
                            seed ^= seed >> 7;
                            seed ^= seed << 17;
                            [
                                -bound,
                                bound,
                                (seed % (2 * bound as u64 + 1)) as i16 - bound,
                            ][(seed >> 40) as usize % 3]
                        })
                        .collect()
                };
                let d: [std::vec::Vec<i16>; 5] = core::array::from_fn(|_| row());
                let [mut v1, mut v2, mut v3, mut v4] =
                    core::array::from_fn(|_| std::vec![0i16; len + 4]);
                let [d0, d1, d2, d3, d4] = d.each_ref().map(|r| &r[..]);
                vertical_parts_of([d0, d1, d2, d3, d4], &mut v1, &mut v2, &mut v3, &mut v4);
                let taps = |v: &[i16]| -> [std::vec::Vec<i16>; 5] {
                    core::array::from_fn(|k| v[k..k + len].to_vec())
                };
                let [t1, t2, t3, t4] = [&v1, &v2, &v3, &v4].map(|v| taps(v));
                let (mut want_x, mut want_y) = (std::vec![0; len], std::vec![0; len]);
                let [a, b, c, d, e] = &t1;
                let [f, g, h, i, j] = &t2;
                component_of(
                    boundary_minus_domain_x,
                    a,
                    b,
                    c,
                    d,
                    e,
                    f,
                    g,
                    h,
                    i,
                    j,
                    &mut want_x,
                );
                let [a, b, c, d, e] = &t3;
                let [f, g, h, i, j] = &t4;
                component_of(
                    boundary_minus_domain_y,
                    a,
                    b,
                    c,
                    d,
                    e,
                    f,
                    g,
                    h,
                    i,
                    j,
                    &mut want_y,
                );
                let (mut ex, mut ey) = (std::vec![0; len], std::vec![0; len]);
                boundary_minus_domain_x_row(&v1, &v2, &mut ex);
                boundary_minus_domain_y_row(&v3, &v4, &mut ey);
                assert_eq!(ex, want_x, "len {len}");
                assert_eq!(ey, want_y, "len {len}");
            }
        }
    }

    /// The 32-bit form equals rounding the exact 64-bit residual, at every
    /// shift, on extremes and random admissible inputs.
    #[test]
    fn rounded_residual_is_the_rounded_exact_residual() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = |range: i64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % (2 * range as u64 + 1)) as i64 - range
        };
        for kappa in [6144u64, 6144 * 255, 6144 * 1024, 1 << 27, 1 << 32] {
            let shift = residual_shift(kappa);
            let split = [(kappa >> shift) as i32, (kappa & ((1 << shift) - 1)) as i32];
            for case in 0..20_000 {
                let big = case % 4 == 0;
                let pick = |r: i64, v: i64| if big { v } else { r };
                let d = pick(next(255), [255, -255][case % 2]);
                let (x, y) = (next(1020), next(1020));
                let (vx, vy) = (next(6_854_400), next(6_854_400));
                let q = pick(next(16_144_560), [16_144_560, -16_144_560][case / 2 % 2]);
                let p0 = next(127) + 128;
                let exact = -(kappa as i64) * d - (x * vx + y * vy) - 4 * p0 * q;
                let want = (exact + (1 << (shift - 1))) >> shift;
                let got = rounded_residual(
                    split,
                    shift,
                    d as i32,
                    [x as i32, y as i32],
                    [vx as i32, vy as i32],
                    p0 as i32,
                    q as i32,
                );
                assert_eq!(i64::from(got), want, "κ {kappa} case {case}");
            }
        }
    }
}

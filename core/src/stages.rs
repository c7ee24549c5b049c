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
//! | `E = Kb3 ⋆ d − 3 · Box⋆Sob ⋆ d` (`= 3·255·(B − S)`) | i32 | `132 · 255 = 33 660` |
//! | vertical `G` of `E` | i32 | `16 · 33 660 = 538 560` |
//! | `V = G256 ⋆ E` (`v_c = V · s/768`) | i32 | `26 880 · 255 = 6 854 400 < 2²³` |
//! | `Q = 1536 · div / s` (central differences) | i32 | `63 312 · 255 = 16 144 560 < 2²⁴` |
//! | `X, Y = Sobel ⋆ p0` (`fx = X · s/8`) | i32 | 1020 |
//! | `Dn = −κ·d − (X·Vx + Y·Vy) − 4·p0·Q` (`D = Dn · s²/6144`) | i64 | `255·κ + 1020 · 29 853 360 < 2^(27+σ)` |
//! | `Dn′ = round(Dn / 2^σ) = h·2¹⁴ + l`, `l ∈ [−2¹³, 2¹³)` | i32 | `|Dn′| ≤ 2²⁷`, `|h| ≤ 2¹³` |
//! | `X², XY, Y²`, then horizontal `G` | i32 | `16 · 1020² < 2²⁴` |
//! | `X·h, X·l, Y·h, Y·l`, then horizontal `G` | i32 | `16 · 1020 · 2¹³ < 2²⁷` |
//! | `a, b, c` (vertical `G`) | i32 | `256 · 1020² < 2²⁸` |
//! | `p = (p_h, p_l)`, `q` (vertical `G`) | 2 × i32 | `256 · 1020 · 2¹³ = 2 139 095 040 < 2³¹` |
//!
//! `V`'s and `Q`'s bounds are the L1 norms of their kernels on `d` times 255.
//! `Dn′` is the one rounding before the solve: it keeps every later sum in
//! 32-bit lanes (8 per AVX2 register, one per M4 register), and its error,
//! at most `2^(σ−1)` against `|κ·d| ≥ 2^(σ+12)` for any temporal change,
//! stays far inside the SPEC's tolerances (`tests/tests/accuracy.rs`).
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

use core::ops::{Add, Shl};

/// `a + 4b + 6c + 4d + e`, the binomial `[1 4 6 4 1]` (SPEC's `G`, ×16).
#[inline(always)]
fn binomial<T: Copy + Add<Output = T> + Shl<u32, Output = T>>(a: T, b: T, c: T, d: T, e: T) -> T {
    (a + e) + ((b + d) << 2) + (c << 2) + (c << 1)
}

/// Columns `[r, n − r)` of a window of `n` columns. Rows are at least `n`
/// long (the engine carves them so); a shorter one reads as empty.
#[inline(always)]
fn span(n: usize, r: usize) -> core::ops::Range<usize> {
    r..n.saturating_sub(r)
}

/// The vertical binomial of five rows on `[r, n − r)`.
#[cfg_attr(feature = "profile", inline(never))]
#[cfg_attr(not(feature = "profile"), inline(always))]
pub fn vertical_binomial<T>(rows: [&[T]; 5], out: &mut [T], n: usize, r: usize)
where
    T: Copy + Default + Add<Output = T> + Shl<u32, Output = T>,
{
    let cols = span(n, r);
    let len = cols.len();
    let [a, b, c, d, e] = rows.map(|row| cut(row, cols.start, len));
    let (Some(a), Some(b), Some(c), Some(d), Some(e), Some(out)) =
        (a, b, c, d, e, cut_mut(out, cols.start, len))
    else {
        return;
    };
    // Two columns per step, both loaded before either is stored: fewer
    // instructions per pixel on RV32 (1 230 → 1 195), aarch64 (294 → 285),
    // the M4 at 320×240 (851 → 843; 866 → 871 at 160×120) and x86-64
    // (`run` −1 %), `scripts/embedded-check` and callgrind.
    let [pa, pb, pc, pd, pe] = [a, b, c, d, e].map(|row| row.chunks_exact(2));
    let rows = pa.zip(pb).zip(pc).zip(pd).zip(pe);
    for (o, ((((a, b), c), d), e)) in out.chunks_exact_mut(2).zip(rows) {
        let x0 = binomial(a[0], b[0], c[0], d[0], e[0]);
        let x1 = binomial(a[1], b[1], c[1], d[1], e[1]);
        o[0] = x0;
        o[1] = x1;
    }
    if len % 2 == 1 {
        let i = len - 1;
        out[i] = binomial(a[i], b[i], c[i], d[i], e[i]);
    }
}

/// The horizontal binomial of a row valid on `[r − 2, n − r + 2)`, on `[r, n − r)`.
#[inline(always)]
fn horizontal_binomial<T>(row: &[T], out: &mut [T], n: usize, r: usize)
where
    T: Copy + Default + Add<Output = T> + Shl<u32, Output = T>,
{
    let cols = span(n, r.max(2));
    let len = cols.len();
    let Some(out) = cut_mut(out, cols.start, len) else {
        return;
    };
    let first = cols.start.wrapping_sub(2);
    // Running sums on the scalar boards (one load and four adds a column,
    // where the loads are the cost); taps where they vectorise (a running
    // sum would serialise them).
    if !crate::VECTOR_ROWS {
        if let Some(taps) = cut(row, first, len + 4) {
            running_binomial(taps, out);
        }
    } else {
        tapped_binomial(row, first, out);
    }
}

/// `out[i] = G ⋆ row[first + i .. first + i + 5]`, five taps a column.
#[inline(always)]
fn tapped_binomial<T>(row: &[T], first: usize, out: &mut [T])
where
    T: Copy + Default + Add<Output = T> + Shl<u32, Output = T>,
{
    let len = out.len();
    // Each tap cut from the row itself: cut from one slice of `len + 4`
    // instead, aarch64 counts 347 instructions per pixel against 285
    // (`scripts/embedded-check`); `taps5` cost the M4 24 (1 059 against
    // 1 035 at 320×240).
    let at = |shift: usize| cut(row, first.wrapping_add(shift), len);
    let (Some(a), Some(b), Some(c), Some(d), Some(e)) = (at(0), at(1), at(2), at(3), at(4)) else {
        return;
    };
    for i in 0..len {
        out[i] = binomial(a[i], b[i], c[i], d[i], e[i]);
    }
}

/// [`tapped_binomial`] as four running pair sums, `[1 4 6 4 1] = [1 1]⁴`:
/// with `sₖ` the `k`-fold pair sum, each new tap `x` gives `s₁ = x′ + x`,
/// `s₂ = s₁′ + s₁`, `s₃ = s₂′ + s₂` and the output `s₃′ + s₃` (primes: the
/// previous column's). Every partial sum has nonnegative weights summing to
/// at most 16, so it stays within the output's bound.
#[inline(always)]
fn running_binomial<T>(taps: &[T], out: &mut [T])
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

/// `E` (x, y) on `[2, n−2)` from the five `d` rows centred on it.
///
/// Separable forms (rows ⊗ columns, correlation):
/// `Kbx3 = [1 4 1]ᵀ⊗[−1 0 1]`, `Box⋆Sobx = [1 3 4 3 1]ᵀ⊗[−1 −1 0 1 1]`,
/// `Kby3 = [−1 0 1]ᵀ⊗[1 4 1]`, `Box⋆Soby = [−1 −1 0 1 1]ᵀ⊗[1 3 4 3 1]`:
/// the vertical parts first (`[1 4 1]`, `[1 3 4 3 1]`, `[−1 0 1]`,
/// `[−1 −1 0 1 1]`, all within ±3060 in i16), then the horizontal ones.
#[cfg_attr(feature = "profile", inline(never))]
#[cfg_attr(not(feature = "profile"), inline(always))]
pub fn boundary_minus_domain(
    d: [&[i16]; 5],
    vert: &mut [&mut [i16]; 4],
    e: Pair<'_, i32>,
    n: usize,
) {
    let [v1, v2, v3, v4] = vert;
    vertical_parts(d, v1, v2, v3, v4, span(n, 0));
    let (ex, ey) = e;
    horizontal_parts([v1, v2, v3, v4], ex, ey, span(n, 2));
}

/// The four vertical parts of `E` on columns `cols`.
#[inline(always)]
fn vertical_parts(
    d: [&[i16]; 5],
    v1: &mut [i16],
    v2: &mut [i16],
    v3: &mut [i16],
    v4: &mut [i16],
    cols: core::ops::Range<usize>,
) {
    let (start, len) = (cols.start, cols.len());
    let [d0, d1, d2, d3, d4] = d.map(|row| cut(row, start, len));
    let (Some(d0), Some(d1), Some(d2), Some(d3), Some(d4)) = (d0, d1, d2, d3, d4) else {
        return;
    };
    let (Some(v1), Some(v2), Some(v3), Some(v4)) = (
        cut_mut(v1, start, len),
        cut_mut(v2, start, len),
        cut_mut(v3, start, len),
        cut_mut(v4, start, len),
    ) else {
        return;
    };
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
    // Each tap its own shifted slice: independent lanes to vectorise.
    let [v1, v2, v3, v4] = vert.map(|row| taps5(row, start, len));
    let (Some(v1), Some(v2), Some(v3), Some(v4)) = (v1, v2, v3, v4) else {
        return;
    };
    let tap = |row: &[&[i16]; 5], k: usize, i: usize| i32::from(row[k][i]);
    // One loop per component: one for both kept 20 row pointers live,
    // which the M4 spilled (61 instructions per pixel against 45,
    // `scripts/embedded-check`). Counted, not enumerated:
    // `iter_mut().enumerate()` left a bounds check (a panic path) on the taps.
    #[allow(clippy::needless_range_loop)]
    for i in 0..len {
        ex[i] = boundary_minus_domain_x(|k| tap(&v1, k, i), |k| tap(&v2, k, i));
    }
    #[allow(clippy::needless_range_loop)]
    for i in 0..len {
        ey[i] = boundary_minus_domain_y(|k| tap(&v3, k, i), |k| tap(&v4, k, i));
    }
}

/// `E` x of one column from the taps `k ∈ [0, 5)` (column offsets `k − 2`)
/// of its vertical parts `[1 4 1]ᵀ ⋆ d` and `[1 3 4 3 1]ᵀ ⋆ d`.
#[inline(always)]
fn boundary_minus_domain_x(v1: impl Fn(usize) -> i32, v2: impl Fn(usize) -> i32) -> i32 {
    let kb_x = v1(3) - v1(1);
    let bs_x = (v2(3) + v2(4)) - (v2(1) + v2(0));
    let e = kb_x - 3 * bs_x;
    debug_assert!(e.abs() <= E_MAX, "E x = {e}");
    e
}

/// `E` y of one column from the taps of its vertical parts `[−1 0 1]ᵀ ⋆ d`
/// and `[−1 −1 0 1 1]ᵀ ⋆ d`.
#[inline(always)]
fn boundary_minus_domain_y(v3: impl Fn(usize) -> i32, v4: impl Fn(usize) -> i32) -> i32 {
    let kb_y = v3(1) + 4 * v3(2) + v3(3);
    let bs_y = (v4(0) + v4(4)) + 3 * (v4(1) + v4(3)) + 4 * v4(2);
    let e = kb_y - 3 * bs_y;
    debug_assert!(e.abs() <= E_MAX, "E y = {e}");
    e
}

/// `V = G256 ⋆ E` on `[4, n−4)` from the five `E` rows centred on it.
#[cfg_attr(feature = "profile", inline(never))]
#[cfg_attr(not(feature = "profile"), inline(always))]
pub fn smooth(e: [[&[i32]; 5]; 2], vert: &mut [&mut [i32]; 2], v: Pair<'_, i32>, n: usize) {
    let [ex, ey] = e;
    let [tx, ty] = vert;
    vertical_binomial(ex, tx, n, 2);
    vertical_binomial(ey, ty, n, 2);
    horizontal_binomial(tx, v.0, n, 4);
    horizontal_binomial(ty, v.1, n, 4);
    debug_assert!(
        v.0.iter().chain(v.1.iter()).all(|v| v.abs() <= V_MAX),
        "V beyond its bound"
    );
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

/// The seven structure channels, in the order of the product rows and the
/// engine's sum rings: `X², XY, Y², X·h, X·l, Y·h, Y·l`.
pub const CHANNELS: usize = 7;

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

/// `len` elements of `row` from `start` (`None` if it is shorter): a slice
/// whose length the compiler knows is `len`, so indexing it below `len`
/// keeps no bounds check.
#[inline(always)]
fn cut<T>(row: &[T], start: usize, len: usize) -> Option<&[T]> {
    row.get(start..)?.get(..len)
}

/// [`cut`], to be written.
#[inline(always)]
fn cut_mut<T>(row: &mut [T], start: usize, len: usize) -> Option<&mut [T]> {
    row.get_mut(start..)?.get_mut(..len)
}

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

/// The seven products on columns `cols`, each output row a parameter of its
/// own so it can be [`cut`] like the inputs. (What makes the loop vectorise
/// is the cut and the counted loop: once inlined, `&mut` parameters no
/// longer tell the compiler the rows are apart.)
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn products_row(
    input: &ResidualInputs<'_>,
    xx: &mut [i32],
    xy: &mut [i32],
    yy: &mut [i32],
    xh: &mut [i32],
    xl: &mut [i32],
    yh: &mut [i32],
    yl: &mut [i32],
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
    let start = cols.start;
    let (Some(xx), Some(xy), Some(yy), Some(xh), Some(xl), Some(yh), Some(yl)) = (
        cut_mut(xx, start, len),
        cut_mut(xy, start, len),
        cut_mut(yy, start, len),
        cut_mut(xh, start, len),
        cut_mut(xl, start, len),
        cut_mut(yh, start, len),
        cut_mut(yl, start, len),
    ) else {
        return;
    };
    for i in 0..len {
        let (vx_l, vx_c, vx_r) = (vx_l[i], vx_c[i], vx_r[i]);
        let (vy_u, vy_c, vy_d) = (vy_u[i], vy_c[i], vy_d[i]);
        let pu = [pu0[i], pu1[i], pu2[i]].map(i32::from);
        let pm = [pm0[i], pm1[i], pm2[i]].map(i32::from);
        let pd = [pd0[i], pd1[i], pd2[i]].map(i32::from);
        let dd = d[i];
        let (xx, xy, yy, xh, xl, yh, yl) = (
            &mut xx[i], &mut xy[i], &mut yy[i], &mut xh[i], &mut xl[i], &mut yh[i], &mut yl[i],
        );
        let q = (vx_r - vx_l) + (vy_d - vy_u);
        let x = (pu[2] - pu[0]) + 2 * (pm[2] - pm[0]) + (pd[2] - pd[0]);
        let y = (pd[0] + 2 * pd[1] + pd[2]) - (pu[0] + 2 * pu[1] + pu[2]);
        debug_assert!(x.abs() <= 1020 && y.abs() <= 1020 && q.abs() <= 16_144_560);
        let dn = rounded_residual(kappa, shift, i32::from(dd), [x, y], [vx_c, vy_c], pm[1], q);
        // Dn′ = h·2¹⁴ + l, l ∈ [−2¹³, 2¹³), |h| ≤ 2¹³.
        let l = (dn << 18) >> 18;
        let h = (dn - l) >> 14;
        *xx = x * x;
        *xy = x * y;
        *yy = y * y;
        *xh = x * h;
        *xl = x * l;
        *yh = y * h;
        *yl = y * l;
    }
}

/// The seven products on `[5, n−5)`, then their horizontal `G` on
/// `[7, n−7)` into one row of each sum ring.
#[cfg_attr(feature = "profile", inline(never))]
#[cfg_attr(not(feature = "profile"), inline(always))]
pub fn structure_row(
    input: &ResidualInputs<'_>,
    products: &mut [&mut [i32]; CHANNELS],
    sums: [&mut [i32]; CHANNELS],
    n: usize,
) {
    let [xx, xy, yy, xh, xl, yh, yl] = products;
    products_row(input, xx, xy, yy, xh, xl, yh, yl, span(n, 5));
    for (row, sum) in products.iter().zip(sums) {
        horizontal_binomial(row, sum, n, 7);
    }
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

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
//! | `E = Kb3 ⋆ d − 3 · Box⋆Sob ⋆ d` (`= 3·255·(B − S)`) | i32 | `(12 + 3·48)·255 = 39 780` |
//! | vertical `G` of `E` | i32 | `16 · 39 780 = 636 480` |
//! | `V = G256 ⋆ E` (`v_c = V · s/768`) | i32 | `256 · 39 780 = 10 183 680 < 2²⁴` |
//! | `Q = 1536 · div / s` (central differences) | i32 | `4 · 10 183 680 < 2²⁶` |
//! | `X, Y = Sobel ⋆ p0` (`fx = X · s/8`) | i32 | 1020 |
//! | `Dn = −κ·d − (X·Vx + Y·Vy) − 4·p0·Q` (`D = Dn · s²/6144`) | i64 | `2³²·255 + 2.1e10 + 4.2e10 < 2⁴¹` |
//! | `X², XY, Y²`, then horizontal `G` | i32 | `16 · 1020² < 2²⁴` |
//! | `X·Dn, Y·Dn`, then horizontal `G` | i64 | `16 · 1020 · 2⁴¹ < 2⁵⁵` |
//! | `a, b, c` (vertical `G`) | i32 | `256 · 1020² < 2²⁸` |
//! | `p, q` (vertical `G`) | i64 | `256 · 1020 · 2⁴¹ < 2⁵⁹` |
//!
//! The bounds are worst cases over all inputs (`Dn`'s first term at the
//! largest admissible `κ`); the tests run with overflow checks on.
//!
//! Loops run over `lo..hi` clamped so that `i ± r` provably stays inside
//! `[0, COLS)`: the compiler drops the bounds checks (no panic paths).

use core::ops::{Add, Shl};

/// `a + 4b + 6c + 4d + e`, the binomial `[1 4 6 4 1]` (SPEC's `G`, ×16).
#[inline(always)]
fn binomial<T: Copy + Add<Output = T> + Shl<u32, Output = T>>(a: T, b: T, c: T, d: T, e: T) -> T {
    (a + e) + ((b + d) << 2) + (c << 2) + (c << 1)
}

/// Columns `[r, n − r)` of a window of `n` columns, cut to `[r, COLS − r)`
/// so that every `i ± r` indexes a `COLS`-long row.
#[inline(always)]
fn span<const COLS: usize>(n: usize, r: usize) -> core::ops::Range<usize> {
    r..n.min(COLS).saturating_sub(r)
}

/// The vertical binomial of five rows on `[r, n − r)`.
#[inline(always)]
pub(crate) fn vertical_binomial<T, const COLS: usize>(
    rows: [&[T; COLS]; 5],
    out: &mut [T; COLS],
    n: usize,
    r: usize,
) where
    T: Copy + Add<Output = T> + Shl<u32, Output = T>,
{
    let [a, b, c, d, e] = rows;
    for i in span::<COLS>(n, r) {
        out[i] = binomial(a[i], b[i], c[i], d[i], e[i]);
    }
}

/// The horizontal binomial of a row valid on `[r − 2, n − r + 2)`, on `[r, n − r)`.
#[inline(always)]
fn horizontal_binomial<T, const COLS: usize>(
    row: &[T; COLS],
    out: &mut [T; COLS],
    n: usize,
    r: usize,
) where
    T: Copy + Add<Output = T> + Shl<u32, Output = T>,
{
    let cols = span::<COLS>(n, r.max(2));
    for i in cols {
        out[i] = binomial(row[i - 2], row[i - 1], row[i], row[i + 1], row[i + 2]);
    }
}

/// Rows of one channel pair (x, y).
pub(crate) type Pair<'a, T, const COLS: usize> = (&'a mut [T; COLS], &'a mut [T; COLS]);

/// `E` (x, y) on `[2, n−2)` from the five `d` rows centred on it.
///
/// Separable forms (rows ⊗ columns, correlation):
/// `Kbx3 = [1 4 1]ᵀ⊗[−1 0 1]`, `Box⋆Sobx = [1 3 4 3 1]ᵀ⊗[−1 −1 0 1 1]`,
/// `Kby3 = [−1 0 1]ᵀ⊗[1 4 1]`, `Box⋆Soby = [−1 −1 0 1 1]ᵀ⊗[1 3 4 3 1]`:
/// the vertical parts first (`[1 4 1]`, `[1 3 4 3 1]`, `[−1 0 1]`,
/// `[−1 −1 0 1 1]`, all within ±3060 in i16), then the horizontal ones.
pub(crate) fn boundary_minus_domain<const COLS: usize>(
    d: [&[i16; COLS]; 5],
    vert: &mut [[i16; COLS]; 4],
    e: Pair<'_, i32, COLS>,
    n: usize,
) {
    let [d0, d1, d2, d3, d4] = d;
    let [v1, v2, v3, v4] = vert;
    for i in span::<COLS>(n, 0) {
        let (a, b, c, dd, ee) = (d0[i], d1[i], d2[i], d3[i], d4[i]);
        v1[i] = b + 4 * c + dd;
        v2[i] = (a + ee) + 3 * (b + dd) + 4 * c;
        v3[i] = dd - b;
        v4[i] = (dd + ee) - (a + b);
    }
    let (ex, ey) = e;
    for i in span::<COLS>(n, 2) {
        let w = |v: &[i16; COLS], k: usize| i32::from(v[k]);
        let kb_x = w(v1, i + 1) - w(v1, i - 1);
        let bs_x = (w(v2, i + 1) + w(v2, i + 2)) - (w(v2, i - 1) + w(v2, i - 2));
        ex[i] = kb_x - 3 * bs_x;
        let kb_y = w(v3, i - 1) + 4 * w(v3, i) + w(v3, i + 1);
        let bs_y = (w(v4, i - 2) + w(v4, i + 2)) + 3 * (w(v4, i - 1) + w(v4, i + 1)) + 4 * w(v4, i);
        ey[i] = kb_y - 3 * bs_y;
    }
}

/// `V = G256 ⋆ E` on `[4, n−4)` from the five `E` rows centred on it.
pub(crate) fn smooth<const COLS: usize>(
    e: [[&[i32; COLS]; 5]; 2],
    vert: &mut [[i32; COLS]; 2],
    v: Pair<'_, i32, COLS>,
    n: usize,
) {
    let [ex, ey] = e;
    let [tx, ty] = vert;
    vertical_binomial(ex, tx, n, 2);
    vertical_binomial(ey, ty, n, 2);
    horizontal_binomial(tx, v.0, n, 4);
    horizontal_binomial(ty, v.1, n, 4);
}

/// The rows one residual row reads: `V` above, at and below it, `p0` likewise,
/// and `d` at it.
pub(crate) struct ResidualInputs<'a, const COLS: usize> {
    pub vx: &'a [i32; COLS],
    pub vy: [&'a [i32; COLS]; 3],
    pub p0: [&'a [u8; COLS]; 3],
    pub d: &'a [i16; COLS],
    pub kappa: i64,
}

/// Scratch rows of the five structure products (`repr(C)`: see `working_bytes`).
#[repr(C)]
pub(crate) struct Products<const COLS: usize> {
    pub wide: [[i64; COLS]; 2],
    pub small: [[i32; COLS]; 3],
}

/// The five products `X², XY, Y²` and `X·Dn, Y·Dn` on `[5, n−5)`, then their
/// horizontal `G` on `[7, n−7)` into one row of each sum ring.
pub(crate) fn structure_row<const COLS: usize>(
    input: &ResidualInputs<'_, COLS>,
    products: &mut Products<COLS>,
    sums_small: [&mut [i32; COLS]; 3],
    sums_wide: [&mut [i64; COLS]; 2],
    n: usize,
) {
    let ResidualInputs {
        vx,
        vy: [vy_up, vy, vy_down],
        p0: [p_up, p_mid, p_down],
        d,
        kappa,
    } = *input;
    let [xx, xy, yy] = &mut products.small;
    let [xd, yd] = &mut products.wide;
    for i in span::<COLS>(n, 5) {
        let px = |row: &[u8; COLS], k: usize| i32::from(row[k]);
        let q = (vx[i + 1] - vx[i - 1]) + (vy_down[i] - vy_up[i]);
        let diff = |row| px(row, i + 1) - px(row, i - 1);
        let x = diff(p_up) + 2 * diff(p_mid) + diff(p_down);
        let smooth = |row| px(row, i - 1) + 2 * px(row, i) + px(row, i + 1);
        let y = smooth(p_down) - smooth(p_up);
        let advection = i64::from(x) * i64::from(vx[i]) + i64::from(y) * i64::from(vy[i]);
        let dilation = i64::from(4 * px(p_mid, i)) * i64::from(q);
        let dn = -kappa * i64::from(d[i]) - advection - dilation;
        xx[i] = x * x;
        xy[i] = x * y;
        yy[i] = y * y;
        xd[i] = i64::from(x) * dn;
        yd[i] = i64::from(y) * dn;
    }
    let [sa, sb, sc] = sums_small;
    let [sp, sq] = sums_wide;
    horizontal_binomial(xx, sa, n, 7);
    horizontal_binomial(xy, sb, n, 7);
    horizontal_binomial(yy, sc, n, 7);
    horizontal_binomial(xd, sp, n, 7);
    horizontal_binomial(yd, sq, n, 7);
}

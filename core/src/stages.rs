//! The row kernels of SPEC §3, in exact integers at `p ∈ [0, 255]`.
//!
//! Each kernel fills one row of a stage from rows of the stage before. Rows
//! are indexed by window column `i ∈ [0, n)`; a kernel of radius `r` writes
//! columns `[lo + r, n − lo − r)` from inputs valid on `[lo, n − lo)`, so the
//! valid part shrinks by the radii of SPEC §6 (2, 2, 1, 2: seven in all).
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

use core::ops::{Add, Shl};

use crate::solve::StructureSums;

/// `a + 4b + 6c + 4d + e`, the binomial `[1 4 6 4 1]` (SPEC's `G`, ×16).
#[inline(always)]
fn binomial<T: Copy + Add<Output = T> + Shl<u32, Output = T>>([a, b, c, d, e]: [T; 5]) -> T {
    (a + e) + ((b + d) << 2) + (c << 2) + (c << 1)
}

/// Columns `[lo, hi)` of a window of `n ≤ COLS` columns, clamped so that
/// stencils of radius `r ≤ lo` stay inside the row.
#[inline(always)]
fn span<const COLS: usize>(n: usize, lo: usize) -> core::ops::Range<usize> {
    lo..n.min(COLS).saturating_sub(lo)
}

/// `E` (x, y) on `[2, n−2)` from the five `d` rows centred on it.
///
/// Separable forms (rows ⊗ columns, correlation):
/// `Kbx3 = [1 4 1]ᵀ⊗[−1 0 1]`, `Box⋆Sobx = [1 3 4 3 1]ᵀ⊗[−1 −1 0 1 1]`,
/// `Kby3 = [−1 0 1]ᵀ⊗[1 4 1]`, `Box⋆Soby = [−1 −1 0 1 1]ᵀ⊗[1 3 4 3 1]`.
pub(crate) fn boundary_minus_domain<const COLS: usize>(
    d: [&[i16; COLS]; 5],
    vert: &mut [[i16; 4]; COLS],
    e: &mut [[i32; 2]; COLS],
    n: usize,
) {
    let [d0, d1, d2, d3, d4] = d;
    for i in span::<COLS>(n, 0) {
        let (a, b, c, dd, ee) = (d0[i], d1[i], d2[i], d3[i], d4[i]);
        vert[i] = [
            b + 4 * c + dd,
            a + 3 * b + 4 * c + 3 * dd + ee,
            dd - b,
            dd + ee - a - b,
        ];
    }
    for i in span::<COLS>(n, 2) {
        let w =
            [vert[i - 2], vert[i - 1], vert[i], vert[i + 1], vert[i + 2]].map(|v| v.map(i32::from));
        let ex = (w[3][0] - w[1][0]) - 3 * (w[3][1] + w[4][1] - w[0][1] - w[1][1]);
        let ey = (w[1][2] + 4 * w[2][2] + w[3][2])
            - 3 * (w[0][3] + 3 * w[1][3] + 4 * w[2][3] + 3 * w[3][3] + w[4][3]);
        e[i] = [ex, ey];
    }
}

/// `V = G256 ⋆ E` on `[4, n−4)` from the five `E` rows centred on it.
pub(crate) fn smooth<const COLS: usize>(
    e: [&[[i32; 2]; COLS]; 5],
    vert: &mut [[i32; 2]; COLS],
    v: &mut [[i32; 2]; COLS],
    n: usize,
) {
    for i in span::<COLS>(n, 2) {
        vert[i] = [0, 1].map(|k| binomial(e.map(|row| row[i][k])));
    }
    for i in span::<COLS>(n, 4) {
        let w = [vert[i - 2], vert[i - 1], vert[i], vert[i + 1], vert[i + 2]];
        v[i] = [0, 1].map(|k| binomial(w.map(|c| c[k])));
    }
}

/// The rows one residual row reads: `V` and `p0` above, at and below it, and `d` at it.
pub(crate) struct ResidualInputs<'a, const COLS: usize> {
    pub v: [&'a [[i32; 2]; COLS]; 3],
    pub p0: [&'a [u8; COLS]; 3],
    pub d: &'a [i16; COLS],
    pub kappa: i64,
}

/// The five products `X², XY, Y²` and `X·Dn, Y·Dn` on `[5, n−5)`, then their
/// horizontal `G` on `[7, n−7)` into one row of each sum ring.
pub(crate) fn structure_row<const COLS: usize>(
    input: &ResidualInputs<'_, COLS>,
    products: (&mut [[i32; 3]; COLS], &mut [[i64; 2]; COLS]),
    sums: (&mut [[i32; 3]; COLS], &mut [[i64; 2]; COLS]),
    n: usize,
) {
    let [v_up, v_mid, v_down] = input.v;
    let [p_up, p_mid, p_down] = input.p0;
    let (prod3, prod2) = products;
    for i in span::<COLS>(n, 5) {
        let px = |row: &[u8; COLS], k: usize| i32::from(row[k]);
        let q = v_mid[i + 1][0] - v_mid[i - 1][0] + v_down[i][1] - v_up[i][1];
        let diff = |row| px(row, i + 1) - px(row, i - 1);
        let x = diff(p_up) + 2 * diff(p_mid) + diff(p_down);
        let smooth = |row| px(row, i - 1) + 2 * px(row, i) + px(row, i + 1);
        let y = smooth(p_down) - smooth(p_up);
        let [vx, vy] = v_mid[i].map(i64::from);
        let dn = -input.kappa * i64::from(input.d[i])
            - (i64::from(x) * vx + i64::from(y) * vy)
            - 4 * i64::from(px(p_mid, i)) * i64::from(q);
        prod3[i] = [x * x, x * y, y * y];
        prod2[i] = [i64::from(x) * dn, i64::from(y) * dn];
    }
    let (sum3, sum2) = sums;
    for i in span::<COLS>(n, 7) {
        sum3[i] = [0, 1, 2].map(|k| binomial([i - 2, i - 1, i, i + 1, i + 2].map(|j| prod3[j][k])));
        sum2[i] = [0, 1].map(|k| binomial([i - 2, i - 1, i, i + 1, i + 2].map(|j| prod2[j][k])));
    }
}

/// The structure sums of column `i` from the five horizontally filtered rows.
#[inline(always)]
pub(crate) fn structure_sums<const COLS: usize>(
    sum3: [&[[i32; 3]; COLS]; 5],
    sum2: [&[[i64; 2]; COLS]; 5],
    i: usize,
) -> StructureSums {
    let [a, b, c] = [0, 1, 2].map(|k| binomial(sum3.map(|row| row[i][k])));
    let [p, q] = [0, 1].map(|k| binomial(sum2.map(|row| row[i][k])));
    StructureSums { a, b, c, p, q }
}

//! The row kernels as a set a target may override: the one place where the
//! core names a CPU.
//!
//! [`KernelSet`]'s default methods are the portable kernels, the reference
//! a reader reads first: their loops live with their stage (`stages`,
//! `tail`, `sink`), written once for every target. A target's set
//! overrides the loops it has faster forms of, each computing exactly the
//! values (and, in `f32`, the roundings in the order) of the portable one:
//! - `m4` (with `wide_products`): the Cortex-M4F's and M7's hottest row
//!   loops in `asm!`, chosen at compile time (`m4_kernels`), held equal to
//!   their portable twins by `kernel_check` on the emulated boards;
//! - `avx2`: the structure sums and the tail in AVX2 lanes for x86-64
//!   hosts that find AVX2 and FMA at run time, chosen when a job is bound
//!   (`Job::with_avx2`), held equal to the
//!   portable pass by `tests/tests/simd.rs`. It keeps the structure sums
//!   in a layout of its own (`blocked`, shared with `neon`), which it
//!   names as its [`KernelSet::Sums`];
//! - `neon`: the same layout and tail, and the bytes, the rows of `d`,
//!   `E`, its smoothing along the row, `V`, and the structure products
//!   with their horizontal `G` in one pass, in NEON lanes for aarch64,
//!   fixed at compile time, held equal to their portable twins by
//!   `kernel_check` under `qemu-aarch64`.
//!
//! [`fpu`] holds the two per-target instructions the portable code itself
//! calls (the `f32` square root, the byte of a clamped value).
//!
//! The engine runs one set for a whole tile ([`Choice::run`]): firmware
//! and aarch64 get [`Native`], fixed at compile time; an x86-64 host's job
//! may carry the AVX2 set instead.

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;
#[cfg(any(
    target_arch = "x86_64",
    all(target_arch = "aarch64", target_feature = "neon")
))]
pub(crate) mod blocked;
pub(crate) mod fpu;
#[cfg(feature = "kernel-check")]
pub mod kernel_check;
#[cfg(m4_kernels)]
pub(crate) mod m4;
#[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
pub(crate) mod neon;
pub(crate) mod wide_products;

use core::ops::Range;

use crate::ring::RowRing;
use crate::schedule::{HALO, SUM_DEPTH, SUM_RADIUS};
use crate::stages::{
    Binomial, FLOAT_CHANNELS, INT_CHANNELS, Pair, ProductRows, ResidualInputs, StructureRows,
    binomial_of, horizontal_binomial, portable_boundary_minus_domain, portable_products_row,
    portable_smooth, portable_smoothed_e, running_binomial, sliding_binomial, structure_row,
    vertical_binomial, vertical_parts_of,
};
use crate::tail::{self, TailConstants, TailOut, TailRows};
use crate::{ByteScale, ExtremesSink, Pixels};

/// The product rows of one structure row: the exact integer channels
/// (`X², XY, Y²`) and the `f32` ones (`X·Dn′·2⁻²⁰`, `Y·Dn′·2⁻²⁰`).
pub(crate) type Products<'a, 'm> = (
    &'a mut [&'m mut [i32]; INT_CHANNELS],
    &'a mut [&'m mut [f32]; FLOAT_CHANNELS],
);

/// A set of row kernels. Every method defaults to the portable kernel; a
/// set overrides one with a loop that gives the same values. The methods
/// take rows already cut to the columns they cover, as their portable
/// forms do.
pub(crate) trait KernelSet: Copy {
    /// How the structure sums' rings lie in memory ([`PlanarSums`]: a row
    /// per channel, the portable layout).
    type Sums<'m>: SumRings<'m, Self>;

    /// The binomials of exact sums on the scalar boards: the vertical one
    /// (`stages::binomial_of`), the horizontal one as running sums (any
    /// order of exact sums is the same value).
    #[inline(always)]
    fn binomial_exact(binomial: Binomial<'_, i32>) {
        match binomial {
            Binomial::Rows([a, b, c, d, e], out) => binomial_of(a, b, c, d, e, out),
            Binomial::Taps(taps, out) => running_binomial(taps, out),
        }
    }

    /// The binomials of `f32` sums on the scalar boards, both in the tapped
    /// order (`f32` sums keep one order on every target).
    #[inline(always)]
    fn binomial_float(binomial: Binomial<'_, f32>) {
        match binomial {
            Binomial::Rows([a, b, c, d, e], out) => binomial_of(a, b, c, d, e, out),
            Binomial::Taps(taps, out) => sliding_binomial(taps, out),
        }
    }

    /// `E`'s four vertical parts (`stages::vertical_parts_of`).
    #[inline(always)]
    fn vertical_parts(d: [&[i16]; 5], [v1, v2, v3, v4]: [&mut [i16]; 4]) {
        vertical_parts_of(d, v1, v2, v3, v4);
    }

    /// `p0` and `d = p1 − p0` of the frame's columns a window row holds:
    /// `p` and `d` as far as the shortest of the four rows goes.
    #[inline(always)]
    fn load_pixels([prev, next]: [&[u8]; 2], p: &mut [u8], d: &mut [i16]) {
        crate::stages::load_pixels_of([prev, next], p, d);
    }

    /// `E` smoothed along the row (the horizontal half of `V`) on `[4, n −
    /// 4)` into `e_smoothed`, from `E`'s four vertical parts (window
    /// columns, valid on `[0, n)`): `stages::portable_smoothed_e`, which
    /// also leaves `E` itself in `e` on `[2, n − 2)`, rows a set may use
    /// as scratch instead (nothing reads them after).
    #[inline(always)]
    fn smoothed_e(vert: [&[i16]; 4], e: Pair<'_, i32>, e_smoothed: Pair<'_, i32>, n: usize) {
        portable_smoothed_e::<Self>(vert, e, e_smoothed, n);
    }

    /// `E` (x, y) and `E` smoothed along the row on `[4, n − 4)` into
    /// `e_smoothed`, from the five rows of `d` centred on them (valid on
    /// `[0, n)`): `stages::portable_boundary_minus_domain`, the vertical
    /// parts into `vert` ([`Self::vertical_parts`]), then
    /// [`Self::smoothed_e`] of them. A set may keep the parts in registers
    /// and leave `vert` and `e` as they were (nothing reads them after).
    #[inline(always)]
    fn boundary_minus_domain(
        d: [&[i16]; 5],
        vert: &mut [&mut [i16]; 4],
        e: Pair<'_, i32>,
        e_smoothed: Pair<'_, i32>,
        n: usize,
    ) {
        portable_boundary_minus_domain::<Self>(d, vert, e, e_smoothed, n);
    }

    /// `V`'s vertical binomials on `[4, n − 4)` of both components, from
    /// the five rows of `E` (smoothed along the row) centred on them:
    /// `stages::portable_smooth`.
    #[inline(always)]
    fn smooth(e_smoothed: [[&[i32]; 5]; 2], v: Pair<'_, i32>, n: usize) {
        portable_smooth::<Self>(e_smoothed, v, n);
    }

    /// The five structure products on columns `cols`, into product rows
    /// cut to them (`stages::portable_products_row`); `scratch` is the
    /// engine's free rows for intermediate values.
    #[inline(always)]
    fn products_row(input: &ResidualInputs<'_>, rows: ProductRows<'_>, cols: Range<usize>) {
        // The portable loop needs no scratch rows.
        let _ = rows.scratch;
        portable_products_row(input, rows.ints, rows.floats, cols);
    }

    /// An output row's tail (`tail::tail_row`).
    #[inline(always)]
    fn tail_row(k: &TailConstants, rows: &TailRows<'_>, out: TailOut<'_>) {
        tail::tail_row(k, rows, out);
    }

    /// The representation's bytes of a row segment (`sink::rgb_row`; the
    /// fields unread):
    /// [`sink::batched_rgb_row`](crate::sink::batched_rgb_row), whose
    /// remainder (all of it on the scalar boards) goes to
    /// [`KernelSet::rgb_pixels`].
    #[inline(always)]
    fn rgb_row(pixels: Pixels<'_>, scales: [&ByteScale; 2], out: &mut [[u8; 3]]) {
        let Pixels { m_d, m_c, luma, .. } = pixels;
        crate::sink::batched_rgb_row::<Self>(m_d, m_c, luma, scales, out);
    }

    /// The representation's bytes of a row segment one pixel at a time
    /// (`sink::portable_rgb_tail`; all of it on the scalar boards, what
    /// the batches leave elsewhere).
    #[inline(always)]
    fn rgb_pixels(
        m_d: &[f32],
        m_c: &[f32],
        luma: &[u8],
        scales: [&ByteScale; 2],
        out: &mut [[u8; 3]],
    ) {
        crate::sink::portable_rgb_tail(m_d, m_c, luma, scales, out);
    }
}

/// The structure sums' rings as the kernel set `K` lays them out: the
/// engine stores each structure row's horizontal sums in them and reads
/// them back for an output row's tail.
pub(crate) trait SumRings<'m, K: KernelSet>: Sized {
    /// The rings of windows of `cols` columns, the integer ones from
    /// `words` and the `f32` ones from `floats` (`SUM_DEPTH · cols` values
    /// per channel either way).
    fn carve(
        kernels: K,
        words: &mut &'m mut [i32],
        floats: &mut &'m mut [f32],
        cols: usize,
    ) -> Self;

    /// The horizontal `G` of the five product rows (window columns, valid
    /// on `[5, n − 5)`) into window row `t` of the rings, on `[7, n − 7)`.
    fn store_row(&mut self, t: usize, products: Products<'_, 'm>, n: usize);

    /// The five structure products of window row `t` on `[5, n − 5)`
    /// and their horizontal `G` into row `t` of the rings:
    /// [`products_then_store`]. A layout may do both in one pass, the
    /// products never stored.
    #[inline(always)]
    fn push_structure(
        &mut self,
        t: usize,
        input: &ResidualInputs<'_>,
        rows: StructureRows<'_, 'm>,
        n: usize,
    ) {
        products_then_store::<K, Self>(self, t, input, rows, n);
    }

    /// The tail of an output row: the vertical `G` of the five sums rows
    /// centred on it (into the product rows, free by then, where the
    /// layout needs them there), the solve and `out`. The two magnitude
    /// rows' extremes where the set found them as it wrote them, `None`
    /// where it did not.
    fn tail_row(&mut self, row: OutputRow<'_, 'm>, out: TailOut<'_>) -> Option<ExtremesSink>;
}

/// The five structure products of window row `t` into the product rows
/// (`stages::structure_row`), then their horizontal `G` into row `t` of
/// the rings ([`SumRings::store_row`]).
#[inline(always)]
pub(crate) fn products_then_store<'m, K: KernelSet, R: SumRings<'m, K>>(
    rings: &mut R,
    t: usize,
    input: &ResidualInputs<'_>,
    rows: StructureRows<'_, 'm>,
    n: usize,
) {
    let products = StructureRows {
        int_products: &mut *rows.int_products,
        float_products: &mut *rows.float_products,
        scratch: rows.scratch,
    };
    structure_row::<K>(input, products, n);
    rings.store_row(t, (rows.int_products, rows.float_products), n);
}

/// What an output row's tail reads besides the sums' rings.
pub(crate) struct OutputRow<'a, 'm> {
    /// The window row (`o ≥ 7`).
    pub o: usize,
    /// The window's columns.
    pub n: usize,
    /// The product rows (window columns).
    pub products: Products<'a, 'm>,
    /// `V` of the row (window columns).
    pub v: [&'a [i32]; 2],
    /// What the tail needs of the configuration.
    pub constants: &'a TailConstants,
}

/// The portable layout: a ring of rows per channel.
pub(crate) struct PlanarSums<'m> {
    ints: [RowRing<'m, i32, SUM_DEPTH>; INT_CHANNELS],
    floats: [RowRing<'m, f32, SUM_DEPTH>; FLOAT_CHANNELS],
}

impl<'m, K: KernelSet> SumRings<'m, K> for PlanarSums<'m> {
    /// A ring per channel, rows `cols` long.
    #[inline(always)]
    fn carve(_: K, words: &mut &'m mut [i32], floats: &mut &'m mut [f32], cols: usize) -> Self {
        Self {
            ints: core::array::from_fn(|_| RowRing::carve(words, cols)),
            floats: core::array::from_fn(|_| RowRing::carve(floats, cols)),
        }
    }

    #[inline(always)]
    fn store_row(&mut self, t: usize, (ints, floats): Products<'_, 'm>, n: usize) {
        for (row, ring) in ints.iter().zip(self.ints.iter_mut()) {
            horizontal_binomial::<K, _>(row, ring.row_mut(t), n, 7);
        }
        for (row, ring) in floats.iter().zip(self.floats.iter_mut()) {
            horizontal_binomial::<K, _>(row, ring.row_mut(t), n, 7);
        }
    }

    #[inline(always)]
    fn tail_row(&mut self, row: OutputRow<'_, 'm>, out: TailOut<'_>) -> Option<ExtremesSink> {
        let OutputRow {
            o,
            n,
            products: (ints, floats),
            v,
            constants,
        } = row;
        for (ring, sums) in self.ints.iter().zip(ints.iter_mut()) {
            vertical_binomial::<K, _>(ring.rows(o - SUM_RADIUS), sums, n, HALO);
        }
        for (ring, sums) in self.floats.iter().zip(floats.iter_mut()) {
            vertical_binomial::<K, _>(ring.rows(o - SUM_RADIUS), sums, n, HALO);
        }
        let rows = TailRows {
            abc: ints.each_ref().map(|row| from_first_output(row)),
            pq: floats.each_ref().map(|row| from_first_output(row)),
            v: v.map(from_first_output),
        };
        K::tail_row(constants, &rows, out);
        None
    }
}

/// A window row from the first output column (`HALO`) on.
#[inline(always)]
pub(crate) fn from_first_output<T>(row: &[T]) -> &[T] {
    row.split_at(HALO.min(row.len())).1
}

/// The portable kernels, every method its default.
#[derive(Clone, Copy, Debug, Default)]
// Where a target's own set is `Native` (M4F, aarch64), only
// `kernel_check` names this one.
#[cfg_attr(
    any(m4_kernels, all(target_arch = "aarch64", target_feature = "neon")),
    allow(dead_code)
)]
pub(crate) struct Portable;

impl KernelSet for Portable {
    type Sums<'m> = PlanarSums<'m>;
}

/// The set this target's firmware runs, fixed at compile time: the
/// M4F's (and M7's) on 32-bit hard-float Arm, NEON's on aarch64, the
/// portable one elsewhere.
#[cfg(m4_kernels)]
pub(crate) type Native = m4::M4;
/// The set this target runs, fixed at compile time.
#[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
pub(crate) type Native = neon::Neon;
/// The set this target runs, fixed at compile time.
#[cfg(not(any(m4_kernels, all(target_arch = "aarch64", target_feature = "neon"))))]
pub(crate) type Native = Portable;

/// What runs with the set a job chose, monomorphised per set
/// ([`Choice::run`]).
pub(crate) trait WithKernels {
    /// Run with `kernels`.
    fn run<K: KernelSet>(self, kernels: K);
}

/// Which set a job's pass runs: [`Native`], or on x86-64 with an
/// [`Avx2`](crate::Avx2) token the AVX2 set.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Choice {
    #[cfg(target_arch = "x86_64")]
    pub(crate) avx2: Option<avx2::Avx2>,
}

impl Choice {
    /// `work` with the chosen set.
    #[inline(always)]
    pub(crate) fn run<W: WithKernels>(self, work: W) {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = self.avx2 {
            return work.run(avx2);
        }
        work.run(Native::default());
    }
}

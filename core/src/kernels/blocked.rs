//! The structure sums' rings in blocks, for the sets whose vectors hold
//! `B` output columns (`avx2`: eight, `neon`: four): the layout, the
//! horizontal `G` into it (in lanes, and one lane at a time where a row
//! ends), the vertical `G` out of it, and an output row's tail up to the
//! set's own loop. What a set brings is its lanes' instructions
//! ([`Lanes`]) and that loop ([`Blocked::tail_row`]).
//!
//! The engine keeps each sums ring (the three integer channels', the two
//! `f32` ones') in blocks of `B` output columns: a block holds those
//! columns of every channel of all five rows of the ring, row slot by row
//! slot. One loop then does an output row's work: the vertical `G` of the
//! five sums, the solve, both magnitudes and their extremes (or the
//! fields, for sinks that read them), `B` pixels a step, reading each ring
//! through one pointer at constant offsets (the loop is compiled once per
//! slot of the window's first row: [`by_slot`]).
//!
//! The functions here that run lanes are `#[inline(always)]` and carry no
//! target features: they are compiled into the set's own
//! `#[target_feature]` functions, which call them.
//!
//! `unsafe` here: the lanes' loads, stores and sums (whose callers run
//! where the set's instructions are), each within a row whose length is
//! checked once a row.
#![allow(unsafe_code)]

use super::{KernelSet, OutputRow, Products, SumRings, products_then_store};
use crate::ring::take;
use crate::schedule::{HALO, SUM_DEPTH, SUM_RADIUS};
use crate::stages::{FLOAT_CHANNELS, INT_CHANNELS, ResidualInputs, Sample, StructureRows};
use crate::tail::{TailConstants, TailOut};
use crate::{Extremes, ExtremesSink};

/// Integer channels (`X², XY, Y²`) and `f32` channels (`X·Dn′`, `Y·Dn′`).
pub(crate) const INTS: usize = INT_CHANNELS;
pub(crate) const FLOATS: usize = FLOAT_CHANNELS;

/// Values a block of a ring of `K` channels: output column `Bb + j` of
/// channel `ch` of the row in slot `s` (window row `t` is in slot
/// `t mod 5`) at `b · ring_block(K) + (s · K + ch) · B + j`. A ring of rows
/// `cols` long per channel holds `⌈w / B⌉` blocks (`B ⌈w / B⌉ < w + 14`
/// for `B ≤ 8`).
pub(crate) const fn ring_block<const B: usize>(k: usize) -> usize {
    SUM_DEPTH * k * B
}

/// Where lane 0 of channel `ch` of slot `slot` of block `b` lies.
pub(crate) const fn at<const B: usize>(k: usize, b: usize, slot: usize, ch: usize) -> usize {
    b * ring_block::<B>(k) + (slot * k + ch) * B
}

/// Blocks of a row of `w` output columns.
pub(crate) const fn blocks<const B: usize>(w: usize) -> usize {
    w.div_ceil(B)
}

/// The two kinds of sums in a set's lanes, `B` values a vector: exact
/// `i32`s and `f32`s.
pub(crate) trait Lanes<const B: usize>: Sample {
    /// `B` lanes of `Self`.
    type Vector: Copy;

    /// `B` lanes from `p`.
    ///
    /// # Safety
    /// `p` points to `B` readable values, and the CPU runs the set's
    /// instructions.
    unsafe fn load(p: *const Self) -> Self::Vector;

    /// `B` lanes to `p`.
    ///
    /// # Safety
    /// `p` points to `B` writable values nothing else borrows, and the CPU
    /// runs the set's instructions.
    unsafe fn store(p: *mut Self, v: Self::Vector);

    /// `a + 4b + 6c + 4d + e` of the lanes, rounded as `Sample::binomial`.
    ///
    /// # Safety
    /// The CPU runs the set's instructions.
    unsafe fn binomial_lanes(taps: [Self::Vector; 5]) -> Self::Vector;
}

/// The lanes of a set's integer sums and `f32` sums.
pub(crate) type IntLanes<const B: usize> = <i32 as Lanes<B>>::Vector;
pub(crate) type FloatLanes<const B: usize> = <f32 as Lanes<B>>::Vector;

/// The binomial of the `B`-lane vectors at the five taps.
///
/// # Safety
/// Each tap points to `B` readable values, and the CPU runs the set's
/// instructions.
#[inline(always)]
unsafe fn binomial_at<T: Lanes<B>, const B: usize>([a, b, c, d, e]: [*const T; 5]) -> T::Vector {
    // SAFETY: the caller's.
    unsafe { T::binomial_lanes([T::load(a), T::load(b), T::load(c), T::load(d), T::load(e)]) }
}

/// The horizontal `G` of block `b` of `K` product rows (taps from window
/// column `first`) into their channels' lanes of slot `slot` of a ring.
///
/// # Safety
/// Every row holds `first + B + 4` values, block `b` lies in the ring, and
/// the CPU runs the set's instructions.
#[inline(always)]
unsafe fn row_sums<T: Lanes<B>, const K: usize, const B: usize>(
    rows: &[&[T]; K],
    first: usize,
    ring: *mut T,
    (b, slot): (usize, usize),
) {
    for (ch, row) in rows.iter().enumerate() {
        let p = row.as_ptr();
        // SAFETY: the caller's.
        unsafe {
            let sum = binomial_at::<T, B>(core::array::from_fn(|t| p.add(first + t)));
            T::store(ring.add(at::<B>(K, b, slot, ch)), sum);
        }
    }
}

/// The vertical `G` of block `b` of channel `ch` of a ring of `K`
/// channels, from the five rows from slot `first` on.
///
/// # Safety
/// Block `b` lies in the ring, and the CPU runs the set's instructions.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn column_sum<T: Lanes<B>, const K: usize, const B: usize>(
    ring: *const T,
    (b, first, ch): (usize, usize, usize),
) -> T::Vector {
    let tap = |k: usize| at::<B>(K, b, (first + k) % SUM_DEPTH, ch);
    // SAFETY: the caller's.
    unsafe { binomial_at::<T, B>(core::array::from_fn(|k| ring.add(tap(k)))) }
}

/// The vertical `G` of block `b` of each channel: `a, b, c` and `p, q`,
/// from the five rows of the rings from slot `FIRST` on, each tap one
/// vector load (the AVX2 set's; the NEON set loads a block whole, four
/// vectors an instruction: `neon::block_sums`).
///
/// # Safety
/// Block `b` lies in both rings, and the CPU runs the set's instructions.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) unsafe fn block_sums<const FIRST: usize, const B: usize>(
    ints: *const i32,
    floats: *const f32,
    b: usize,
) -> ([IntLanes<B>; INTS], [FloatLanes<B>; FLOATS])
where
    i32: Lanes<B>,
    f32: Lanes<B>,
{
    // SAFETY: the caller's.
    let int = |ch| unsafe { column_sum::<i32, INTS, B>(ints, (b, FIRST, ch)) };
    // SAFETY: the caller's.
    let float = |ch| unsafe { column_sum::<f32, FLOATS, B>(floats, (b, FIRST, ch)) };
    ([int(0), int(1), int(2)], [float(0), float(1)])
}

/// The horizontal `G` of the five products of a row (window columns,
/// valid on `[5, n − 5)`) into slot `slot` of both sums rings. The last
/// block's lanes past the row's last output column get sums of columns
/// past the window (bounded like any sum: the rows there hold earlier
/// products or zeros), unless those would lie past the rows' ends: then
/// those lanes keep what they held.
///
/// # Safety
/// The CPU runs the set's instructions.
#[inline(always)]
pub(crate) unsafe fn horizontal_sums<const B: usize>(
    ints: [&[i32]; INTS],
    floats: [&[f32]; FLOATS],
    (int_ring, float_ring, slot): (&mut [i32], &mut [f32], usize),
    n: usize,
) where
    i32: Lanes<B>,
    f32: Lanes<B>,
{
    let nb = blocks::<B>(n.saturating_sub(2 * HALO));
    let slot = slot % SUM_DEPTH;
    let (Some(int_ring), Some(float_ring)) = (
        int_ring.get_mut(..nb * ring_block::<B>(INTS)),
        float_ring.get_mut(..nb * ring_block::<B>(FLOATS)),
    ) else {
        return;
    };
    // Tap `t` of lane `j` of block `b` is window column `HALO − 2 + Bb + j
    // + t`: the block reads `Bb + B + 9` columns of every product row. The
    // blocks that fit in all of them run in lanes.
    let len = ints
        .iter()
        .map(|r| r.len())
        .chain(floats.iter().map(|r| r.len()))
        .min();
    let reach = HALO - 2 + B + 4;
    let whole = match len {
        Some(len) if len >= reach => ((len - reach) / B + 1).min(nb),
        _ => 0,
    };
    let (int_out, float_out) = (int_ring.as_mut_ptr(), float_ring.as_mut_ptr());
    for b in 0..whole {
        let first = HALO - 2 + B * b;
        // SAFETY: `first + B + 4 ≤ len` (`whole`), block `b < nb` lies in
        // both rings, and the CPU runs the set's instructions (the
        // caller's).
        unsafe {
            row_sums::<i32, INTS, B>(&ints, first, int_out, (b, slot));
            row_sums::<f32, FLOATS, B>(&floats, first, float_out, (b, slot));
        }
    }
    // A last block whose taps would pass a row's end: its lanes one at a
    // time, those whose taps lie in the row.
    for b in whole..nb {
        let first = HALO - 2 + B * b;
        scalar_sums::<i32, INTS, B>(&ints, first, int_ring, (b, slot));
        scalar_sums::<f32, FLOATS, B>(&floats, first, float_ring, (b, slot));
    }
}

/// [`row_sums`] one lane at a time, the lanes whose five taps lie in the
/// row (`Sample::binomial`, the portable sum); the others keep what they
/// held.
#[inline(never)]
fn scalar_sums<T: Sample, const K: usize, const B: usize>(
    rows: &[&[T]; K],
    first: usize,
    ring: &mut [T],
    (b, slot): (usize, usize),
) {
    for (ch, row) in rows.iter().enumerate() {
        let out = ring
            .get_mut(at::<B>(K, b, slot, ch)..)
            .and_then(|r| r.first_chunk_mut::<B>());
        for (j, out) in out.into_iter().flatten().enumerate() {
            if let Some(&[a, b, c, d, e]) = row.get(first + j..).and_then(|t| t.first_chunk()) {
                *out = T::binomial(a, b, c, d, e);
            }
        }
    }
}

/// A set that keeps the structure sums in blocks ([`BlockedSums`]): the
/// horizontal `G` into them and an output row's tail from them, each in
/// the set's own `#[target_feature]` function (the set's value proves the
/// CPU runs them).
pub(crate) trait Blocked: KernelSet {
    /// The five structure products of a window row and their horizontal
    /// `G` into slot `rings.2` of both rings in one pass, the products
    /// never stored: whether the set did (by default it does not, and the
    /// engine goes through the product rows: `products_then_store`).
    #[inline(always)]
    fn structure_sums(
        self,
        input: &ResidualInputs<'_>,
        rings: (&mut [i32], &mut [f32], usize),
        n: usize,
    ) -> bool {
        let _ = (input, rings, n);
        false
    }

    /// [`horizontal_sums`] in the set's lanes.
    fn horizontal_sums(
        self,
        ints: [&[i32]; INTS],
        floats: [&[f32]; FLOATS],
        rings: (&mut [i32], &mut [f32], usize),
        n: usize,
    );

    /// The vertical `G` of the blocked sums centred on an output row (the
    /// first of its five rows in slot `FIRST`), the solve and the
    /// magnitudes (and the fields when `FIELDS`), `B` pixels a step, for
    /// the `w` output columns of a window of `n` (the outputs' length;
    /// shorter rows write nothing); the magnitudes' extremes when
    /// `EXTREMES` (the others' are not to be read).
    fn tail_row<const FIELDS: bool, const EXTREMES: bool, const FIRST: usize>(
        self,
        k: &TailConstants,
        rows: &BlockedRows<'_>,
        m: [&mut [f32]; 2],
        fields: [&mut [f32]; 4],
    ) -> ExtremesSink;
}

/// The sums' rings in blocks (module doc): the integer channels' ring and
/// the `f32` ones', each `SUM_DEPTH · K · cols` values for `K` channels
/// (the memory of the portable layout's rings), and the set.
pub(crate) struct BlockedSums<'m, S> {
    set: S,
    ints: &'m mut [i32],
    floats: &'m mut [f32],
}

impl<'m, S: Blocked> SumRings<'m, S> for BlockedSums<'m, S> {
    #[inline(always)]
    fn carve(set: S, words: &mut &'m mut [i32], floats: &mut &'m mut [f32], cols: usize) -> Self {
        Self {
            set,
            ints: take(words, SUM_DEPTH * INTS * cols),
            floats: take(floats, SUM_DEPTH * FLOATS * cols),
        }
    }

    #[inline(always)]
    fn store_row(&mut self, t: usize, (ints, floats): Products<'_, 'm>, n: usize) {
        let ints = ints.each_ref().map(|row| &row[..]);
        let floats = floats.each_ref().map(|row| &row[..]);
        let rings = (&mut *self.ints, &mut *self.floats, t % SUM_DEPTH);
        self.set.horizontal_sums(ints, floats, rings, n);
    }

    #[inline(always)]
    fn push_structure(
        &mut self,
        t: usize,
        input: &ResidualInputs<'_>,
        rows: StructureRows<'_, 'm>,
        n: usize,
    ) {
        let rings = (&mut *self.ints, &mut *self.floats, t % SUM_DEPTH);
        if !self.set.structure_sums(input, rings, n) {
            products_then_store::<S, Self>(self, t, input, rows, n);
        }
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
        let TailOut {
            m,
            fields,
            extremes,
        } = out;
        let no_fields = || -> [&mut [f32]; 4] { [&mut [], &mut [], &mut [], &mut []] };
        match (fields, extremes) {
            (None, true) => Some(by_slot::<S, false, true>(
                self.set,
                constants,
                &rows,
                m,
                no_fields(),
            )),
            (None, false) => {
                by_slot::<S, false, false>(self.set, constants, &rows, m, no_fields());
                None
            }
            (Some(fields), _) => {
                by_slot::<S, true, false>(self.set, constants, &rows, m, fields);
                None
            }
        }
    }
}

/// What one output row's tail reads: both sums rings, the slot of the
/// first of the five rows centred on it, and `V` (window columns).
pub(crate) struct BlockedRows<'a> {
    /// The integer sums' ring.
    pub ints: &'a [i32],
    /// The `f32` sums' ring.
    pub floats: &'a [f32],
    /// The slot of the row two above the output row (below `SUM_DEPTH`).
    pub first_slot: usize,
    /// `V` (x, y) of the row.
    pub v: [&'a [i32]; 2],
}

/// [`Blocked::tail_row`] compiled for the slot of the output row's first
/// sums row, so that every load is at a constant offset from one pointer a
/// ring.
#[inline(always)]
fn by_slot<S: Blocked, const FIELDS: bool, const EXTREMES: bool>(
    set: S,
    k: &TailConstants,
    rows: &BlockedRows<'_>,
    m: [&mut [f32]; 2],
    fields: [&mut [f32]; 4],
) -> ExtremesSink {
    match rows.first_slot {
        0 => set.tail_row::<FIELDS, EXTREMES, 0>(k, rows, m, fields),
        1 => set.tail_row::<FIELDS, EXTREMES, 1>(k, rows, m, fields),
        2 => set.tail_row::<FIELDS, EXTREMES, 2>(k, rows, m, fields),
        3 => set.tail_row::<FIELDS, EXTREMES, 3>(k, rows, m, fields),
        _ => set.tail_row::<FIELDS, EXTREMES, 4>(k, rows, m, fields),
    }
}

/// `V` (x, y) on the `w` output columns, where the rings hold the row's
/// blocks and `V`, `m_c` (and the fields, when `FIELDS`) hold `w` values;
/// `None` where one does not (the tail then writes nothing).
#[inline(always)]
pub(crate) fn tail_v<'a, const FIELDS: bool, const B: usize>(
    rows: &BlockedRows<'a>,
    w: usize,
    m_c: &[f32],
    fields: &[&mut [f32]; 4],
) -> Option<[&'a [i32]; 2]> {
    let nb = blocks::<B>(w);
    let [vx, vy] = rows.v.map(|row| row.get(HALO..HALO + w).unwrap_or(&[]));
    let fields_len = if FIELDS { w } else { 0 };
    if rows.ints.len() < nb * ring_block::<B>(INTS)
        || rows.floats.len() < nb * ring_block::<B>(FLOATS)
        || vx.len() < w
        || vy.len() < w
        || m_c.len() < w
        || fields.iter().any(|row| row.len() < fields_len)
    {
        return None;
    }
    Some([vx, vy])
}

/// The last, partial block's `V` from column `at` of `row`: lanes past the
/// row's end read as 0.
#[inline(always)]
pub(crate) fn padded<const B: usize>(row: &[i32], at: usize) -> [i32; B] {
    let mut lanes = [0; B];
    for (l, &x) in lanes.iter_mut().zip(row.get(at..).unwrap_or(&[])) {
        *l = x;
    }
    lanes
}

/// The last, partial block's results (`local`, in the order of `rows`:
/// `[|v_d|, |v_c|, v_c x, v_c y, v_d x, v_d y]`) into the rows' columns
/// from `at` on, and the magnitudes' lanes of the row's `w` columns into
/// their extremes.
#[inline(always)]
pub(crate) fn finish_partial<const B: usize>(
    rows: [&mut [f32]; 6],
    local: &[[f32; B]; 6],
    (at, w): (usize, usize),
    extremes: &mut [Extremes; 2],
) {
    for (row, lanes) in rows.into_iter().zip(local) {
        for (o, &x) in row.get_mut(at..).unwrap_or(&mut []).iter_mut().zip(lanes) {
            *o = x;
        }
    }
    for (extremes, lanes) in extremes.iter_mut().zip(local) {
        extremes.add_all(lanes.get(..w - at).unwrap_or(&[]));
    }
}

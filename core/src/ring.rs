//! A ring of image rows written in place, addressed by absolute row number.

/// `DEPTH` rows of `cols` elements, carved from the engine's memory; row `t`
/// lives in slot `t mod DEPTH`, so a stage keeps exactly the rows the next
/// stage still reads.
///
/// Two forms of one ring. On x86-64 (`offset_rings`), whose row loops are
/// inlined into the pass: one slice and the width, each row worked out
/// from `t` and clamped into the memory, so that the rows' addresses stay
/// arithmetic on one base the compiler follows into the inlined loops
/// (rows kept as slices and loaded from the ring keep such loops out of
/// vector lanes). Elsewhere: the slots carved once a window, a row one
/// index below `DEPTH`, which spares each of some 60 row accesses a pushed
/// row a multiply and clamps that memory of a run-time width cannot fold.
/// On aarch64, whose row loops are functions of their own taking their
/// rows as parameters, that is 0.4 instructions a pixel at 640×480 and 1.7
/// in 128-px strips (`scripts/embedded-check`); on the M4F, the C API's
/// firmware (`kernels/m4.rs`, run-time width) comes within 2.4 % (320×240)
/// and 3.1 % (160×120) of the Rust firmware's compile-time arrays, against
/// 3 % and 5 % with offsets. The slots (8 bytes each on 32-bit targets) fit
/// the M0's 16 KiB stack.
pub(crate) struct RowRing<'m, T, const DEPTH: usize> {
    #[cfg(offset_rings)]
    rows: &'m mut [T],
    #[cfg(offset_rings)]
    cols: usize,
    #[cfg(not(offset_rings))]
    slots: [&'m mut [T]; DEPTH],
}

impl<'m, T, const DEPTH: usize> RowRing<'m, T, DEPTH> {
    /// The next `DEPTH` rows of `cols` elements of `memory` (see [`take`]).
    #[inline(always)]
    pub(crate) fn carve(memory: &mut &'m mut [T], cols: usize) -> Self {
        #[cfg(offset_rings)]
        return Self {
            rows: take(memory, DEPTH * cols),
            cols,
        };
        #[cfg(not(offset_rings))]
        Self {
            slots: take_rows(memory, cols),
        }
    }

    /// Where row `t` starts (the slot it shares with rows `t ± DEPTH`),
    /// clamped to the memory (which the engines size so it never is).
    #[cfg(offset_rings)]
    #[inline(always)]
    fn slot(&self, t: usize) -> core::ops::Range<usize> {
        let len = self.rows.len();
        let start = ((t % DEPTH) * self.cols).min(len);
        start..(start + self.cols).min(len)
    }

    /// Row `t` (shorter if the memory was short, which the engines rule
    /// out). Indexed within clamped bounds, not `get(…).unwrap_or(&[])`:
    /// a row that may be the empty slice's dangling pointer instead of one
    /// into the memory has no known bounds, and the compiler then keeps
    /// the loops over it out of vector lanes (the x86-64 pass's vertical
    /// sums ran scalar).
    #[inline(always)]
    pub(crate) fn row(&self, t: usize) -> &[T] {
        #[cfg(offset_rings)]
        {
            let slot = self.slot(t);
            let (_, rest) = self.rows.split_at(slot.start);
            rest.split_at(slot.len().min(rest.len())).0
        }
        #[cfg(not(offset_rings))]
        &*self.slots[t % DEPTH]
    }

    /// Rows `first .. first + K`, oldest first.
    #[inline(always)]
    pub(crate) fn rows<const K: usize>(&self, first: usize) -> [&[T]; K] {
        core::array::from_fn(|k| self.row(first + k))
    }

    /// Row `t`, to be written.
    #[inline(always)]
    pub(crate) fn row_mut(&mut self, t: usize) -> &mut [T] {
        #[cfg(offset_rings)]
        {
            let slot = self.slot(t);
            let (_, rest) = self.rows.split_at_mut(slot.start);
            let len = slot.len().min(rest.len());
            rest.split_at_mut(len).0
        }
        #[cfg(not(offset_rings))]
        &mut *self.slots[t % DEPTH]
    }
}

/// The first `len` elements of `memory`, which keeps the rest; fewer when
/// `memory` is shorter (the engines size their memory so it never is, and
/// the kernels treat a short row as empty rather than index past it).
#[inline(always)]
pub(crate) fn take<'m, T>(memory: &mut &'m mut [T], len: usize) -> &'m mut [T] {
    let all = core::mem::take(memory);
    let (row, rest) = all.split_at_mut(len.min(all.len()));
    *memory = rest;
    row
}

/// The next `K` rows of `cols` elements of `memory` ([`take`] each).
#[inline(always)]
pub(crate) fn take_rows<'m, T, const K: usize>(
    memory: &mut &'m mut [T],
    cols: usize,
) -> [&'m mut [T]; K] {
    core::array::from_fn(|_| take(memory, cols))
}

//! A ring of image rows written in place, addressed by absolute row number.

/// `DEPTH` rows of `cols` elements, carved from the engine's memory; row `t`
/// lives in slot `t mod DEPTH`, so a stage keeps exactly the rows the next
/// stage still reads. One slice, not `DEPTH`: the engine's rows sit on the
/// stack of a 16 KiB M0 while it runs.
pub(crate) struct RowRing<'m, T, const DEPTH: usize> {
    rows: &'m mut [T],
    cols: usize,
}

impl<'m, T, const DEPTH: usize> RowRing<'m, T, DEPTH> {
    /// The next `DEPTH` rows of `cols` elements of `memory` (see [`take`]).
    #[inline(always)]
    pub(crate) fn carve(memory: &mut &'m mut [T], cols: usize) -> Self {
        Self {
            rows: take(memory, DEPTH * cols),
            cols,
        }
    }

    /// Where row `t` starts (the slot it shares with rows `t ± DEPTH`),
    /// clamped to the memory (which the engines size so it never is).
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
        let slot = self.slot(t);
        let (_, rest) = self.rows.split_at(slot.start);
        rest.split_at(slot.len().min(rest.len())).0
    }

    /// Rows `first .. first + K`, oldest first.
    #[inline(always)]
    pub(crate) fn rows<const K: usize>(&self, first: usize) -> [&[T]; K] {
        core::array::from_fn(|k| self.row(first + k))
    }

    /// Row `t`, to be written.
    #[inline(always)]
    pub(crate) fn row_mut(&mut self, t: usize) -> &mut [T] {
        let slot = self.slot(t);
        let (_, rest) = self.rows.split_at_mut(slot.start);
        let len = slot.len().min(rest.len());
        rest.split_at_mut(len).0
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

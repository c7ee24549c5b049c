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

    /// Where row `t` starts (the slot it shares with rows `t ± DEPTH`).
    #[inline(always)]
    fn slot(&self, t: usize) -> core::ops::Range<usize> {
        let start = (t % DEPTH) * self.cols;
        start..start + self.cols
    }

    /// Row `t` (empty if the memory was short, which the engines rule out).
    #[inline(always)]
    pub(crate) fn row(&self, t: usize) -> &[T] {
        self.rows.get(self.slot(t)).unwrap_or(&[])
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
        self.rows.get_mut(slot).unwrap_or(&mut [])
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

//! A ring of image rows written in place, addressed by absolute row number.

/// `DEPTH` rows of `cols` elements, carved from the engine's memory; row `t`
/// lives in slot `t mod DEPTH`, so a stage keeps exactly the rows the next
/// stage still reads.
pub(crate) struct RowRing<'m, T, const DEPTH: usize> {
    rows: [&'m mut [T]; DEPTH],
}

impl<'m, T, const DEPTH: usize> RowRing<'m, T, DEPTH> {
    /// The next `DEPTH` rows of `cols` elements of `memory` (see
    /// [`take_rows`]).
    #[inline(always)]
    pub(crate) fn carve(memory: &mut &'m mut [T], cols: usize) -> Self {
        Self {
            rows: take_rows(memory, cols),
        }
    }

    /// Row `t` (the slot it shares with rows `t ± DEPTH`).
    #[inline(always)]
    pub(crate) fn row(&self, t: usize) -> &[T] {
        // `t % DEPTH < DEPTH`: the compiler keeps no bounds check.
        self.rows[t % DEPTH]
    }

    /// Rows `first .. first + K`, oldest first.
    #[inline(always)]
    pub(crate) fn rows<const K: usize>(&self, first: usize) -> [&[T]; K] {
        core::array::from_fn(|k| self.row(first + k))
    }

    /// Row `t`, to be written.
    #[inline(always)]
    pub(crate) fn row_mut(&mut self, t: usize) -> &mut [T] {
        self.rows[t % DEPTH]
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

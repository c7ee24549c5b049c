//! A ring of image rows written in place, addressed by absolute row number.

/// `DEPTH` rows of `COLS` elements; row `t` lives in slot `t mod DEPTH`, so a
/// stage keeps exactly the rows the next stage still reads.
#[repr(transparent)]
pub(crate) struct RowRing<T, const COLS: usize, const DEPTH: usize> {
    rows: [[T; COLS]; DEPTH],
}

impl<T: Copy, const COLS: usize, const DEPTH: usize> RowRing<T, COLS, DEPTH> {
    pub(crate) const fn new(zero: T) -> Self {
        Self {
            rows: [[zero; COLS]; DEPTH],
        }
    }

    /// Row `t` (the slot it shares with rows `t ± DEPTH`).
    #[inline(always)]
    pub(crate) fn row(&self, t: usize) -> &[T; COLS] {
        &self.rows[t % DEPTH]
    }

    /// Rows `first .. first + K`, oldest first.
    #[inline(always)]
    pub(crate) fn rows<const K: usize>(&self, first: usize) -> [&[T; COLS]; K] {
        core::array::from_fn(|k| self.row(first + k))
    }

    /// Row `t`, to be written.
    #[inline(always)]
    pub(crate) fn row_mut(&mut self, t: usize) -> &mut [T; COLS] {
        &mut self.rows[t % DEPTH]
    }
}

//! The caller's working memory, carved into what a handle needs: a header
//! struct at the first suitably aligned address, then arrays, each at the
//! next multiple of its alignment. The size queries and the carving walk
//! the same [`Carver`], so they cannot disagree.

use core::mem::{align_of, size_of};

/// Offsets of consecutive parts within a block that starts at an address
/// aligned to [`Carver::ALIGN`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Carver {
    end: usize,
}

impl Carver {
    /// Every part's alignment divides this (8: the header structs hold
    /// `u64`s; the arrays need 4 at most).
    pub(crate) const ALIGN: usize = 8;

    /// A block whose first part is a `T`.
    pub(crate) const fn after_header<T>() -> Self {
        assert!(Self::ALIGN.is_multiple_of(align_of::<T>()));
        Self {
            end: size_of::<T>(),
        }
    }

    /// Room for `n` `T`s: their offset, or `None` when the size overflows.
    pub(crate) fn array<T>(&mut self, n: usize) -> Option<usize> {
        assert!(Self::ALIGN.is_multiple_of(align_of::<T>()));
        let offset = self.end.checked_next_multiple_of(align_of::<T>())?;
        self.end = offset.checked_add(n.checked_mul(size_of::<T>())?)?;
        Some(offset)
    }

    /// Bytes a caller must provide: the parts, and the slack to reach an
    /// aligned start from any address.
    pub(crate) fn bytes(&self) -> Option<usize> {
        self.end.checked_add(Self::ALIGN - 1)
    }

    /// Bytes the parts span from the aligned start.
    pub(crate) const fn end(&self) -> usize {
        self.end
    }
}

/// The aligned start of a caller's block of `len` bytes at `mem`, if the
/// block holds `span` bytes from there.
pub(crate) fn aligned_start(mem: *mut u8, len: usize, span: usize) -> Option<*mut u8> {
    let skip = (mem as usize).wrapping_neg() % Carver::ALIGN;
    if len < skip.checked_add(span)? {
        return None;
    }
    Some(mem.wrapping_add(skip))
}

/// `n` zeroed `T`s at `offset` from `start`, as a slice the handle owns.
///
/// # Safety
/// `start + offset` lies in a block the caller handed over for the whole
/// life of the handle, with room for `n` `T`s at the alignment [`Carver`]
/// gave, not overlapping any other part.
pub(crate) unsafe fn zeroed<T: Zeroable>(
    start: *mut u8,
    offset: usize,
    n: usize,
) -> &'static mut [T] {
    // SAFETY: in the block and aligned (the caller's contract, from `Carver`).
    let ptr = unsafe { start.add(offset) }.cast::<T>();
    // SAFETY: all-zero bytes are a valid `T` (`Zeroable`), written before
    // the slice exists; the block is the handle's alone for its life.
    unsafe {
        ptr.write_bytes(0, n);
        core::slice::from_raw_parts_mut(ptr, n)
    }
}

/// Types whose all-zero bytes are a valid value.
pub(crate) trait Zeroable {}
impl Zeroable for i32 {}
impl Zeroable for i16 {}
impl Zeroable for u8 {}
impl Zeroable for f32 {}
impl Zeroable for [f32; 2] {}
impl Zeroable for [u8; 3] {}

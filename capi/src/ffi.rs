//! C pointers to Rust references: every check a pointer and a length allow
//! (NULL, alignment, a size that fits the address space), in one place.
//!
//! What no check can see is the caller's part of the contract, stated in
//! the header: a pointer with a length points to at least that many
//! readable (or, for outputs, writable) elements, which nothing else
//! accesses during the call.

use core::mem::{align_of, size_of};

use crate::status::*;

/// `len` elements at `ptr` as a slice; NULL is `None`.
///
/// # Safety
/// A non-NULL `ptr` points to `len` initialised `T`s that stay valid and
/// unmodified for `'a`.
pub(crate) unsafe fn optional<'a, T>(
    ptr: *const T,
    len: usize,
) -> Result<Option<&'a [T]>, rf_status> {
    if ptr.is_null() {
        return Ok(None);
    }
    checked(ptr, len)?;
    // SAFETY: non-NULL, aligned, `len · size_of::<T>() ≤ isize::MAX` (checked
    // above); validity for `'a` is the caller's contract.
    Ok(Some(unsafe { core::slice::from_raw_parts(ptr, len) }))
}

/// `len` elements at `ptr`, which must not be NULL.
///
/// # Safety
/// As [`optional`].
pub(crate) unsafe fn required<'a, T>(ptr: *const T, len: usize) -> Result<&'a [T], rf_status> {
    // SAFETY: the caller's contract is `optional`'s.
    unsafe { optional(ptr, len) }?.ok_or(RF_ERR_NULL_POINTER)
}

/// `len` writable elements at `ptr`; NULL is `None`.
///
/// # Safety
/// A non-NULL `ptr` points to `len` initialised `T`s that nothing else
/// reads or writes for `'a`.
pub(crate) unsafe fn optional_mut<'a, T>(
    ptr: *mut T,
    len: usize,
) -> Result<Option<&'a mut [T]>, rf_status> {
    if ptr.is_null() {
        return Ok(None);
    }
    checked(ptr, len)?;
    // SAFETY: as in `optional`; exclusive access is the caller's contract.
    Ok(Some(unsafe { core::slice::from_raw_parts_mut(ptr, len) }))
}

/// Alignment and size checks of a non-NULL pointer to `len` `T`s.
fn checked<T>(ptr: *const T, len: usize) -> Result<(), rf_status> {
    if !(ptr as usize).is_multiple_of(align_of::<T>()) {
        return Err(RF_ERR_MISALIGNED);
    }
    match len.checked_mul(size_of::<T>()) {
        Some(bytes) if bytes <= isize::MAX as usize => Ok(()),
        _ => Err(RF_ERR_FRAME_TOO_LARGE),
    }
}

/// The value behind a pointer to a C struct, copied.
///
/// # Safety
/// A non-NULL `ptr` points to a valid, initialised `T`.
pub(crate) unsafe fn read<T: Copy>(ptr: *const T) -> Result<T, rf_status> {
    if ptr.is_null() {
        return Err(RF_ERR_NULL_POINTER);
    }
    if !(ptr as usize).is_multiple_of(align_of::<T>()) {
        return Err(RF_ERR_MISALIGNED);
    }
    // SAFETY: non-NULL and aligned; validity is the caller's contract.
    Ok(unsafe { ptr.read() })
}

/// Store `value` through an out-pointer.
///
/// # Safety
/// A non-NULL `ptr` points to writable memory for a `T`.
pub(crate) unsafe fn write<T>(ptr: *mut T, value: T) -> Result<(), rf_status> {
    if ptr.is_null() {
        return Err(RF_ERR_NULL_POINTER);
    }
    if !(ptr as usize).is_multiple_of(align_of::<T>()) {
        return Err(RF_ERR_MISALIGNED);
    }
    // SAFETY: non-NULL and aligned; writability is the caller's contract.
    unsafe { ptr.write(value) };
    Ok(())
}

/// The status of a result, for the `extern "C"` functions' return.
pub(crate) fn status(result: Result<(), rf_status>) -> rf_status {
    match result {
        Ok(()) => RF_OK,
        Err(e) => e,
    }
}

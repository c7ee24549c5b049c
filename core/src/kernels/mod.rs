//! The target kernels: every form of a row loop that exists for one CPU,
//! in one place.
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;
pub(crate) mod fpu;
#[cfg(feature = "kernel-check")]
pub mod kernel_check;
#[cfg(fpu_f32)]
pub(crate) mod m4;
pub(crate) mod wide_products;

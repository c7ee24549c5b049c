//! Names, once, the target families the core's forms depend on, so each
//! choice reads `#[cfg(fpu_f32)]` instead of repeating the target list:
//! - `fpu_f32`: 32-bit Arm with the hard-float ABI (the M4F), whose `f32`
//!   square root is `VSQRT.F32` in `asm!` (`fpu.rs`);
//! - `vector_rows`: targets whose compilers take the row loops in vector
//!   lanes (x86-64, aarch64), which keep the forms that vectorise; the
//!   scalar boards (M-profile, RV32) take forms with fewer loads and fewer
//!   live registers (`stages`, `sink`);
//! - `dispatched_pass`: x86-64, whose hosts compile the engine pass twice
//!   (baseline and AVX2, chosen at run time), which needs every row kernel
//!   inlined into the pass. Elsewhere each row kernel is a function of its
//!   own: its rows arrive as parameters the compiler knows apart (`noalias`)
//!   and its registers are its own (`stages`).

use std::env;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(fpu_f32, vector_rows, dispatched_pass)");
    let arch = env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let abi = env::var("CARGO_CFG_TARGET_ABI").unwrap_or_default();
    match (arch.as_str(), abi.as_str()) {
        ("x86_64", _) => {
            println!("cargo::rustc-cfg=vector_rows");
            println!("cargo::rustc-cfg=dispatched_pass");
        }
        ("aarch64", _) => println!("cargo::rustc-cfg=vector_rows"),
        ("arm", "eabihf") => println!("cargo::rustc-cfg=fpu_f32"),
        _ => {}
    }
}

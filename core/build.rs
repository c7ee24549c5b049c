//! Names, once, the FPU forms the exact floors (`isqrt`, `reciprocal`)
//! start from, so each choice reads `#[cfg(fpu_f64)]` instead of repeating
//! the target list:
//! - `fpu_f64`: a correctly rounded `f64` root and quotient (x86-64, aarch64);
//! - `fpu_f32`: only `f32` ones, by `asm!` (32-bit Arm, hard-float ABI: the M4F).
//!
//! Neither: the Newton forms (M0, RV32, …).
//!
//! And `vector_rows`: targets whose compilers take the row loops in vector
//! lanes (x86-64, aarch64), which keep the forms that vectorise; the scalar
//! boards (M-profile, RV32) take forms with fewer loads and fewer live
//! registers (`stages`, `scale`).

use std::env;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(fpu_f64, fpu_f32, vector_rows)");
    let arch = env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let abi = env::var("CARGO_CFG_TARGET_ABI").unwrap_or_default();
    match (arch.as_str(), abi.as_str()) {
        ("x86_64" | "aarch64", _) => {
            println!("cargo::rustc-cfg=fpu_f64");
            println!("cargo::rustc-cfg=vector_rows");
        }
        ("arm", "eabihf") => println!("cargo::rustc-cfg=fpu_f32"),
        _ => {}
    }
}

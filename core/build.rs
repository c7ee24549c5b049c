//! Names, once, the target families the core's forms depend on, so each
//! choice reads `#[cfg(fpu_f32)]` instead of repeating the target list:
//! - `fpu_f32`: 32-bit Arm with the hard-float ABI (the M4F), whose `f32`
//!   square root is `VSQRT.F32` in `asm!` (`fpu.rs`);
//! - `m4_kernels`: those of them with the DSP instructions (`SADD16`, …) the
//!   M4 kernel set's `asm!` uses (`kernels/m4.rs`): every ARMv7E-M part, but
//!   an ARMv8-M Mainline one (`thumbv8m.main`: the M33, M35P, M55, M85) only
//!   where the build names a core that has them or `+dsp` (the target's
//!   baseline lacks them); elsewhere the portable set, the same bytes.
//! - `vector_rows`: targets whose compilers take the row loops in vector
//!   lanes (x86-64, aarch64), which keep the forms that vectorise; the
//!   scalar boards (M-profile, RV32) take forms with fewer loads and fewer
//!   live registers (`stages`, `sink`);
//! - `offset_rings`: x86-64, whose rings of rows work each row's place
//!   out from one slice (`ring`); elsewhere the rows' slices are carved
//!   once a window;
//! - `dispatched_pass`: x86-64, whose hosts compile the engine pass twice
//!   (baseline and AVX2, chosen at run time), which needs every row kernel
//!   inlined into the pass. Elsewhere each row kernel is a function of its
//!   own: its rows arrive as parameters the compiler knows apart (`noalias`)
//!   and its registers are its own (`stages`).

use std::env;

/// Cores of ARMv8-M Mainline that always have the DSP extension.
const V8M_DSP_CORES: [&str; 4] = ["cortex-m33", "cortex-m35p", "cortex-m55", "cortex-m85"];

/// Whether a `thumbv8m.main` build has the DSP instructions: a core that
/// has them (`-C target-cpu`) or `-C target-feature=+dsp`, and no `-dsp`.
fn v8m_has_dsp(rustflags: &str) -> bool {
    // The codegen options, whether written `-C opt`, `-Copt` or `-C` `opt`.
    let mut options = Vec::new();
    let mut flags = rustflags.split('\x1f');
    while let Some(flag) = flags.next() {
        match flag.strip_prefix("-C") {
            Some("") => options.extend(flags.next()),
            Some(option) => options.push(option.trim_start()),
            None => {}
        }
    }
    let mut dsp = false;
    for option in options {
        if let Some(cpu) = option.strip_prefix("target-cpu=") {
            dsp = V8M_DSP_CORES.contains(&cpu);
        } else if let Some(features) = option.strip_prefix("target-feature=") {
            for feature in features.split(',') {
                match feature {
                    "+dsp" => dsp = true,
                    "-dsp" => dsp = false,
                    _ => {}
                }
            }
        }
    }
    dsp
}

fn main() {
    println!(
        "cargo::rustc-check-cfg=cfg(fpu_f32, m4_kernels, vector_rows, offset_rings, dispatched_pass)"
    );
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-env-changed=CARGO_ENCODED_RUSTFLAGS");
    let arch = env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let abi = env::var("CARGO_CFG_TARGET_ABI").unwrap_or_default();
    match (arch.as_str(), abi.as_str()) {
        ("x86_64", _) => {
            println!("cargo::rustc-cfg=vector_rows");
            println!("cargo::rustc-cfg=offset_rings");
            println!("cargo::rustc-cfg=dispatched_pass");
        }
        ("aarch64", _) => println!("cargo::rustc-cfg=vector_rows"),
        ("arm", "eabihf") => {
            println!("cargo::rustc-cfg=fpu_f32");
            let target = env::var("TARGET").unwrap_or_default();
            let rustflags = env::var("CARGO_ENCODED_RUSTFLAGS").unwrap_or_default();
            if !target.starts_with("thumbv8m.main") || v8m_has_dsp(&rustflags) {
                println!("cargo::rustc-cfg=m4_kernels");
            }
        }
        _ => {}
    }
}

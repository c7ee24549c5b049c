//! Board table and fixtures: picks the board from the target, writes its
//! `memory.x` and linker arguments, generates the frame pair and the host's
//! expected bytes into `OUT_DIR`, and a `config.rs` the firmware includes.

use std::path::PathBuf;
use std::{env, fs};

use reynoldsflow_fixtures::{K_C, K_D, pair, representation};

/// What differs between the boards; the firmware body is shared.
struct Board {
    name: &'static str,
    memory_x: &'static str,
    /// Window columns of the engine for a frame width: all three boards
    /// hold the frame in flash, only RAM for the engine differs.
    cols: fn(usize) -> usize,
    link_args: &'static [&'static str],
}

/// `COLS = width + 14`: one full-width strip, no halo recomputed (mps2 and
/// virt have megabytes of RAM).
fn one_strip(width: usize) -> usize {
    width + 14
}

/// The micro:bit has 16 KiB of RAM for everything: 46 columns is 11 608
/// bytes of engine (252 a column) and tiles of 32 px (160 = 5 × 32, no
/// narrow last tile), leaving about 4.6 KiB for the stack (about 1.4 KiB
/// used). `Engine<54>` (four 40-px tiles, 13 624 bytes) fits too, but
/// saves under 1 % of the instructions (8 077 → 8 003 a pixel) for 2 KiB
/// less stack margin.
fn microbit_cols(_width: usize) -> usize {
    46
}

const CORTEX_M_LINK: &[&str] = &["-Tlink.x", "-Tdefmt.x"];

fn board(target: &str) -> Option<Board> {
    Some(match target {
        "thumbv7em-none-eabihf" => Board {
            name: "mps2-an386",
            memory_x: "MEMORY {\n  FLASH : ORIGIN = 0x00000000, LENGTH = 4M\n  RAM : ORIGIN = 0x20000000, LENGTH = 4M\n}\n",
            cols: one_strip,
            link_args: CORTEX_M_LINK,
        },
        "thumbv6m-none-eabi" => Board {
            name: "microbit",
            memory_x: "MEMORY {\n  FLASH : ORIGIN = 0x00000000, LENGTH = 256K\n  RAM : ORIGIN = 0x20000000, LENGTH = 16K\n}\n",
            cols: microbit_cols,
            link_args: CORTEX_M_LINK,
        },
        // The Cortex-M33 (with DSP and FPU): the AN505 boots in the Secure
        // state, its vector table at the secure alias of SSRAM1
        // (0x1000_0000), and its data in the secure alias of SSRAM2 and 3.
        "thumbv8m.main-none-eabihf" => Board {
            name: "mps2-an505",
            memory_x: "MEMORY {\n  FLASH : ORIGIN = 0x10000000, LENGTH = 4M\n  RAM : ORIGIN = 0x38000000, LENGTH = 4M\n}\n",
            cols: one_strip,
            link_args: CORTEX_M_LINK,
        },
        // `-bios none`: QEMU starts at the ELF's entry in DRAM (RV32 with
        // and without the F extension alike).
        "riscv32imac-unknown-none-elf" | "riscv32imafc-unknown-none-elf" => Board {
            name: "virt",
            memory_x: "MEMORY {\n  RAM : ORIGIN = 0x80000000, LENGTH = 16M\n}\n\
                REGION_ALIAS(\"REGION_TEXT\", RAM);\nREGION_ALIAS(\"REGION_RODATA\", RAM);\n\
                REGION_ALIAS(\"REGION_DATA\", RAM);\nREGION_ALIAS(\"REGION_BSS\", RAM);\n\
                REGION_ALIAS(\"REGION_HEAP\", RAM);\nREGION_ALIAS(\"REGION_STACK\", RAM);\n",
            cols: one_strip,
            link_args: &["-Tmemory.x", "-Tlink.x", "-Tdefmt.x"],
        },
        _ => return None,
    })
}

fn main() {
    println!("cargo::rerun-if-changed=build.rs");
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let target = env::var("TARGET").expect("cargo sets TARGET");
    let Some(board) = board(&target) else {
        // A host build only compiles the stub `main` (clippy, `cargo build --workspace`).
        return;
    };
    let (w, h) = if env::var_os("CARGO_FEATURE_FRAMES_320X240").is_some() {
        (320, 240)
    } else {
        (160, 120)
    };

    fs::write(out.join("memory.x"), board.memory_x).expect("write memory.x");
    println!("cargo::rustc-link-search={}", out.display());
    for arg in board.link_args {
        println!("cargo::rustc-link-arg-bins={arg}");
    }

    let [prev, next] = pair(w, h);
    let expected = representation(w, h, &prev, &next);
    fs::write(out.join("prev.gray"), &prev).expect("write prev");
    fs::write(out.join("next.gray"), &next).expect("write next");
    fs::write(out.join("expected.rgb"), &expected).expect("write expected");

    let cols = (board.cols)(w);
    let config = format!(
        "/// QEMU board this build is for.\n\
         pub const BOARD: &str = {board:?};\n\
         /// Frame width and height.\n\
         pub const WIDTH: usize = {w};\npub const HEIGHT: usize = {h};\n\
         /// Engine window columns (tiles of `COLS - 14`).\n\
         pub const COLS: usize = {cols};\n\
         /// Where the representation goes, in QEMU's working directory.\n\
         pub const OUT_FILE: &core::ffi::CStr = c{file:?};\n\
         /// `Scaling::Fixed` gains (U16F16 bits), the same the host used.\n\
         pub const K_D_BITS: u32 = {kd};\npub const K_C_BITS: u32 = {kc};\n",
        board = board.name,
        file = format!("rgb-{}-{w}x{h}.bin", board.name),
        kd = K_D.to_bits(),
        kc = K_C.to_bits(),
    );
    fs::write(out.join("config.rs"), config).expect("write config.rs");
}

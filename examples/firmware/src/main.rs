//! The ReynoldsFlow core on emulated boards: runs the tiled engine over a
//! frame pair held in flash, streams the representation's rows out over
//! semihosting as they are produced, compares them with the host's bytes,
//! and exits non-zero on any difference.
//!
//! One body for every board (`app`, `entry`, `stack`); `board` holds only
//! the runtime's entry and the linker symbols. `build.rs` picks the board
//! from the target and generates the pair, the expected bytes and
//! `config.rs`. On the host this builds to a stub, so `cargo build` and
//! clippy work across the workspace.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod app;
#[cfg(target_os = "none")]
mod board;
#[cfg(target_os = "none")]
mod entry;
#[cfg(target_os = "none")]
mod stack;

/// Board, frame size, engine columns and gains of this build.
#[cfg(target_os = "none")]
mod config {
    include!(concat!(env!("OUT_DIR"), "/config.rs"));
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "firmware: build with --target thumbv7em-none-eabihf, thumbv6m-none-eabi or \
         riscv32imac-unknown-none-elf (see scripts/embedded-check)"
    );
    std::process::exit(2);
}

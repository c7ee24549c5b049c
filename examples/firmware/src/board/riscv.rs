//! RV32 (QEMU virt, `-bios none`) through `riscv-rt`.

// The critical-section implementation defmt-semihosting needs.
use riscv as _;

#[riscv_rt::entry]
fn main() -> ! {
    crate::app::main()
}

unsafe extern "C" {
    /// Lowest address the stack may reach (end of the heap).
    static __estack: u32;
    /// Initial stack pointer (end of RAM).
    static _stack_start: u32;
}

/// `(lowest, highest)` address of the stack.
pub fn stack_bounds() -> (usize, usize) {
    (
        &raw const __estack as usize,
        &raw const _stack_start as usize,
    )
}

//! Cortex-M (mps2-an386, micro:bit) through `cortex-m-rt`.

// The critical-section implementation defmt-semihosting needs.
use cortex_m as _;

#[cortex_m_rt::entry]
fn main() -> ! {
    crate::app::main()
}

unsafe extern "C" {
    /// Lowest address the stack may reach (end of `.uninit`).
    static _stack_end: u32;
    /// Initial stack pointer (top of RAM).
    static _stack_start: u32;
}

/// `(lowest, highest)` address of the stack.
pub fn stack_bounds() -> (usize, usize) {
    (
        &raw const _stack_end as usize,
        &raw const _stack_start as usize,
    )
}

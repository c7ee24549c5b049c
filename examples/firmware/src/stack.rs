//! Stack high-water mark: paint the free stack with a pattern before the
//! run, find the deepest overwritten word after it.

use core::ptr;

use crate::board::stack_bounds;

const PATTERN: u32 = 0x5AC3_96E1;
/// Paint at most this much: enough for the firmware, quick on boards with
/// megabytes of stack (RISC-V virt).
const PAINT_LIMIT: usize = 64 * 1024;
/// Left unpainted below the painting function's frame.
const MARGIN: usize = 256;

/// The painted range `[low, top)` of the stack.
pub struct Painted {
    low: usize,
    top: usize,
}

/// Paint everything between the stack's floor and a margin below the
/// caller's frame.
#[inline(never)]
pub fn paint() -> Painted {
    let here = 0u32;
    let sp = core::hint::black_box(&here) as *const u32 as usize;
    let (floor, top) = stack_bounds();
    let low = floor
        .max(top.saturating_sub(PAINT_LIMIT))
        .next_multiple_of(4);
    let high = (sp - MARGIN) & !3;
    for addr in (low..high).step_by(4) {
        // SAFETY: `[low, high)` is free stack below this frame: nothing
        // live is stored there, and it is word-aligned RAM.
        unsafe { ptr::write_volatile(addr as *mut u32, PATTERN) };
    }
    Painted { low, top }
}

/// Bytes of stack used since `paint` (from the top of the stack), and
/// whether the deepest painted word was reached (then it is a lower bound).
pub fn high_water(painted: &Painted) -> (usize, bool) {
    let mut addr = painted.low;
    // SAFETY: reads of the word-aligned stack range painted above.
    while addr < painted.top && unsafe { ptr::read_volatile(addr as *const u32) } == PATTERN {
        addr += 4;
    }
    (painted.top - addr, addr == painted.low)
}

//! An exact reciprocal without a divide: `⌊(2⁶³ − 1) / d⌋` for a normalised
//! 32-bit `d`, from a table seed, two Newton steps (multiplies and shifts)
//! and a correction to the exact floor. A 64-bit divide is a library call
//! of a hundred-odd instructions on Cortex-M and RV32; this is about twenty.

use crate::isqrt::mul;

/// `2⁴⁰ / (2k + 1)` for the top byte `k ∈ [128, 256)` of `d`: `2⁶³ / d` at
/// the middle of the byte's interval, good to 8 bits.
const SEED: [u32; 128] = {
    let mut table = [0u32; 128];
    let mut k = 0;
    while k < 128 {
        table[k] = ((1u64 << 40) / (2 * (k as u64 + 128) + 1)) as u32;
        k += 1;
    }
    table
};

/// `⌊(2⁶³ − 1) / d⌋` for `d ∈ [2³¹, 2³²)`, in `[2³¹, 2³²)`; other `d` are
/// raised to 2³¹ (the caller normalises).
#[inline]
pub fn reciprocal(d: u32) -> u64 {
    let d = d.max(1 << 31);
    let mut y = SEED[((d >> 24) as usize) % 128];
    // y ≈ 2⁶³/d < 2³² with relative error ε: err = 2⁶³ − d·y ≈ 2⁶³·ε (|·| < 2⁵⁶
    // after the seed), and y += y·err/2⁶³ squares ε: y·|err >> 31| < 2³²·2²⁵.
    for _ in 0..2 {
        let err = (1u64 << 63).wrapping_sub(mul(d, y)) as i64 >> 31;
        let step = (mul(y, err.unsigned_abs() as u32) >> 32) as u32;
        y = if err < 0 {
            y - step
        } else {
            y.saturating_add(step)
        };
    }
    // Within a few units of the floor; the floor itself is below 2³².
    let limit = u64::MAX >> 1;
    while mul(d, y) > limit {
        y -= 1;
    }
    while y < u32::MAX && mul(d, y + 1) <= limit {
        y += 1;
    }
    u64::from(y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_at_the_edges_and_on_a_dense_grid() {
        let limit = u64::MAX >> 1;
        for d in
            (1u64 << 31..1 << 32)
                .step_by(4093)
                .chain([1 << 31, (1 << 31) + 1, u32::MAX as u64])
        {
            assert_eq!(reciprocal(d as u32), limit / d, "{d}");
        }
        let mut s = 0x1234_5678u64;
        for _ in 0..1_000_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let d = (s >> 32) | 1 << 31;
            assert_eq!(reciprocal(d as u32), limit / d, "{d}");
        }
    }
}

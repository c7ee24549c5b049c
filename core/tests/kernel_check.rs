//! The target's own row loops against their portable twins
//! (`reynoldsflow_core::kernel_check`): on aarch64 the NEON sums, tail, bytes, products and their horizontal `G`, `E` smoothed along the row, `V`'s vertical binomials and rows of `d`,
//! which `scripts/embedded-check` runs under `qemu-aarch64`. Targets whose
//! set is the portable one compare nothing, and say so (`Ok(0)`).

#[test]
fn the_targets_row_loops_equal_their_portable_twins() {
    let compared = reynoldsflow_core::kernel_check::run();
    if cfg!(target_arch = "aarch64") {
        // Every output length from 0 to 41 (42): both parameter sets (2),
        // the magnitudes with their extremes, without, and with the fields
        // (3), ten output rows each (every ring slot twice); the bytes under three pairs of scales; the products
        // and their horizontal `G` at three residual shifts, through ten
        // output rows each; `E` smoothed along the row from five patterns
        // of `d`; `V`'s vertical binomials; the rows of `p0` and `d`.
        assert_eq!(compared, Ok(42 * (2 * 3 * 10 + 3 + 3 * 10 + 5 + 1 + 1)));
    } else {
        assert_eq!(compared, Ok(0));
    }
}

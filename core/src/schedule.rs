//! The engine's row schedule, derived from the stage radii of SPEC §6.
//!
//! Window rows stream in one at a time. A stage of vertical radius `r`
//! can finish its row `k` once row `k + r` of its input exists, so each
//! stage runs a fixed number of rows (its *lag*) behind the newest input
//! row, and each ring keeps exactly the rows its readers still need.

/// Vertical radius of `E = Kb3 ⋆ d − 3·Box⋆Sob ⋆ d` (the 5×5 box-Sobel).
pub const E_RADIUS: usize = 2;
/// Vertical radius of `V = G ⋆ E` (the 5-tap binomial).
pub const V_RADIUS: usize = 2;
/// Vertical radius of the structure products (central differences of `V`,
/// Sobel of `p0`).
pub const PRODUCT_RADIUS: usize = 1;
/// Vertical radius of the structure sums (`G` of the products).
pub const SUM_RADIUS: usize = 2;

/// Radius of input that one output pixel depends on: the radii add up.
pub const HALO: usize = E_RADIUS + V_RADIUS + PRODUCT_RADIUS + SUM_RADIUS;

/// Rows behind the newest input row at which an `E` row completes.
pub const E_LAG: usize = E_RADIUS;
/// … a `V` row.
pub const V_LAG: usize = E_LAG + V_RADIUS;
/// … a row of structure products (and of their horizontal sums).
pub const PRODUCT_LAG: usize = V_LAG + PRODUCT_RADIUS;
/// … an output row.
pub const OUTPUT_LAG: usize = PRODUCT_LAG + SUM_RADIUS;

/// First window row at which a stage has every input row: its first row
/// lies its radius inside the first row of its input, and runs its lag
/// behind. `E` starts at row `E_RADIUS`, `V` at `E_RADIUS + V_RADIUS`, …
pub const E_START: usize = E_RADIUS + E_LAG;
/// First window row at which `V` runs.
pub const V_START: usize = E_RADIUS + V_RADIUS + V_LAG;
/// First window row at which the products run.
pub const PRODUCT_START: usize = E_RADIUS + V_RADIUS + PRODUCT_RADIUS + PRODUCT_LAG;
/// First window row at which an output row leaves (`2 · HALO`).
pub const OUTPUT_START: usize = HALO + OUTPUT_LAG;

/// Ring depths: the rows a stage's readers still need when its newest row
/// is written.
/// `d` is read by `E` (`t − 2·E_RADIUS ..= t`) and by the products (row
/// `t − PRODUCT_LAG`).
pub const D_DEPTH: usize = PRODUCT_LAG + 1;
/// `p0` is read by the products (`±PRODUCT_RADIUS` around their row) and
/// by the output (its luma, row `t − OUTPUT_LAG`).
pub const P0_DEPTH: usize = OUTPUT_LAG + 1;
/// `E` is read by `V`, `2·V_RADIUS + 1` rows.
pub const E_DEPTH: usize = 2 * V_RADIUS + 1;
/// `V` is read by the products (`±PRODUCT_RADIUS`) and by the output (`v_c`
/// of its row): rows `t − OUTPUT_LAG ..= t − V_LAG`.
pub const V_DEPTH: usize = OUTPUT_LAG - V_LAG + 1;
/// The sums are read by the output, `2·SUM_RADIUS + 1` rows.
pub const SUM_DEPTH: usize = 2 * SUM_RADIUS + 1;

// The schedule SPEC §6 states: a 7-px halo, output 7 rows behind input.
const _: () = assert!(HALO == 7 && OUTPUT_LAG == HALO && OUTPUT_START == 2 * HALO);
// Every reader's oldest row is still in its ring.
const _: () = assert!(D_DEPTH > 2 * E_RADIUS && D_DEPTH > PRODUCT_LAG);
const _: () = assert!(P0_DEPTH > PRODUCT_LAG + PRODUCT_RADIUS && P0_DEPTH > OUTPUT_LAG);
const _: () = assert!(V_DEPTH > PRODUCT_RADIUS + (PRODUCT_LAG - V_LAG));

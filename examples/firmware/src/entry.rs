//! The engine's processing entry point, the RGB sink, and the harness
//! boundary (`rf_emit_row`) where rows leave the computation.
//!
//! `rf_engine_entry` is what the panic check walks: everything it reaches
//! by direct calls, except through `rf_emit_row` (comparison and file I/O,
//! not part of the computation), must be free of panic paths.

use reynoldsflow_core::fixed::types::U16F16;
use reynoldsflow_core::{ByteScale, Engine, Job, Pixels, Sink, rgb_row};
use semihosting::fs::File;
use semihosting::io::{Seek, SeekFrom, Write};

use crate::config::{COLS, K_C_BITS, K_D_BITS, WIDTH};

/// What the markers write: volatile, so the optimiser keeps the calls, and
/// different values, so the linker cannot fold the two into one address.
static mut BENCH: u32 = 0;

/// The instruction counter counts from here (QEMU plugin `start=`)...
#[unsafe(no_mangle)]
#[inline(never)]
pub extern "C" fn bench_start() {
    // SAFETY: a plain word written only here and below, never read.
    unsafe { core::ptr::write_volatile(&raw mut BENCH, 1) };
}

/// ...to here (`stop=`), summed over every start/stop window.
#[unsafe(no_mangle)]
#[inline(never)]
pub extern "C" fn bench_stop() {
    // SAFETY: as above.
    unsafe { core::ptr::write_volatile(&raw mut BENCH, 2) };
}

/// Where rows go after the computation: compared with the host's bytes and
/// written at their place in the output file.
pub struct Harness {
    /// The host's representation of the pair, row-major RGB8.
    pub expected: &'static [u8],
    pub file: File,
    /// Pixels received, and how many differ from `expected`.
    pub pixels: usize,
    pub mismatched: usize,
    /// First differing pixel: `(y, x, got, expected)`.
    pub first_mismatch: Option<(usize, usize, [u8; 3], [u8; 3])>,
    pub io_failed: bool,
}

/// The representation's bytes of each output row segment, made in a row
/// buffer (no frame buffer) and handed to the harness.
pub struct RgbRows<'h> {
    scale_d: ByteScale,
    scale_c: ByteScale,
    row: [[u8; 3]; COLS],
    harness: &'h mut Harness,
}

impl<'h> RgbRows<'h> {
    /// `Scaling::Fixed` with the gains the host used.
    pub fn new(harness: &'h mut Harness) -> Self {
        Self {
            scale_d: ByteScale::fixed(U16F16::from_bits(K_D_BITS)),
            scale_c: ByteScale::fixed(U16F16::from_bits(K_C_BITS)),
            row: [[0; 3]; COLS],
            harness,
        }
    }
}

impl Sink for RgbRows<'_> {
    // Bytes only: the engine skips the fields' conversions.
    fn reads_fields(&self) -> bool {
        false
    }

    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        let n = pixels.len().min(COLS);
        let row = &mut self.row[..n];
        rgb_row(pixels, &self.scale_d, &self.scale_c, row);
        rf_emit_row(self.harness, y, x, row);
    }
}

/// The harness side of a row: outside the measured window and outside the
/// panic check (I/O and comparison are not the computation).
#[unsafe(no_mangle)]
#[inline(never)]
pub fn rf_emit_row(harness: &mut Harness, y: usize, x: usize, row: &[[u8; 3]]) {
    bench_stop();
    let offset = (y * WIDTH + x) * 3;
    let got = row.as_flattened();
    let want = harness
        .expected
        .get(offset..offset + got.len())
        .unwrap_or(&[]);
    for (i, (g, w)) in row.iter().zip(want.as_chunks::<3>().0).enumerate() {
        if g != w {
            harness.mismatched += 1;
            harness.first_mismatch.get_or_insert((y, x + i, *g, *w));
        }
    }
    harness.mismatched += row.len() - row.len().min(want.len() / 3);
    harness.pixels += row.len();
    let written = harness
        .file
        .seek(SeekFrom::Start(offset as u64))
        .and_then(|_| harness.file.write_all(got));
    harness.io_failed |= written.is_err();
    bench_start();
}

/// The engine's processing entry point: every tile of the job through the
/// engine into the RGB sink.
#[unsafe(no_mangle)]
#[inline(never)]
pub fn rf_engine_entry(engine: &mut Engine<COLS>, job: &Job<'_>, sink: &mut RgbRows<'_>) {
    engine.run(job, sink)
}

/// The same entry plus a panic path the optimiser cannot remove (an index
/// it cannot prove in bounds), one call deep so the walk must follow calls:
/// the panic check must flag this entry.
#[cfg(feature = "panic-canary")]
#[unsafe(no_mangle)]
#[inline(never)]
pub fn rf_canary_entry(
    engine: &mut Engine<COLS>,
    job: &Job<'_>,
    sink: &mut RgbRows<'_>,
    index: usize,
) {
    engine.run(job, sink);
    rf_canary_index(sink.harness.expected, index);
}

#[cfg(feature = "panic-canary")]
#[unsafe(no_mangle)]
#[inline(never)]
fn rf_canary_index(bytes: &[u8], index: usize) -> u8 {
    core::hint::black_box(bytes[index])
}

//! The firmware body shared by every board: set up, run the engine once
//! over the pair between the benchmark markers, measure the stack, report
//! over defmt, exit with the verdict.

use reynoldsflow_core::{Config, Engine, FramePair, Params, Plan};
// The defmt global logger: frames go to semihosting stdout.
use defmt_semihosting as _;

use crate::config::{BOARD, COLS, HEIGHT, OUT_FILE, WIDTH};
use crate::entry::{Harness, RgbRows, bench_start, bench_stop, rf_engine_entry};
use crate::stack;

static PREV: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/prev.gray"));
static NEXT: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/next.gray"));
static EXPECTED: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/expected.rgb"));

/// The engine lives in `.bss`, so static RAM shows its full size.
static mut ENGINE: Engine<COLS> = Engine::new();

/// Exit statuses (QEMU returns them, so cargo and the check see them).
const MISMATCH: i32 = 1;
const SETUP_FAILED: i32 = 2;
const IO_FAILED: i32 = 3;
const INCOMPLETE: i32 = 4;
#[cfg(feature = "kernel-check")]
const KERNEL_MISMATCH: i32 = 5;

pub fn main() -> ! {
    semihosting::process::exit(run())
}

fn run() -> i32 {
    #[cfg(feature = "kernel-check")]
    match reynoldsflow_core::kernel_check::run() {
        Ok(rows) => defmt::info!(
            "kernel check: {=usize} rows identical to the portable loops'",
            rows
        ),
        Err(kernel) => {
            defmt::error!(
                "kernel check: {=str} differs from its portable twin",
                kernel
            );
            return KERNEL_MISMATCH;
        }
    }
    defmt::info!(
        "board={=str} size={=usize}x{=usize} cols={=usize} engine_bytes={=usize}",
        BOARD,
        WIDTH,
        HEIGHT,
        COLS,
        Engine::<COLS>::WORKING_BYTES
    );
    let setup = Config::new(WIDTH, HEIGHT, Params::DEFAULT).and_then(|config| {
        Ok((
            config,
            Plan::strips(config, Engine::<COLS>::MAX_TILE_WIDTH)?,
            FramePair::packed(&config, PREV, NEXT)?,
        ))
    });
    let (_config, plan, frames) = match setup {
        Ok(setup) => setup,
        Err(e) => {
            defmt::error!("core refused the setup: {}", e);
            return SETUP_FAILED;
        }
    };
    let job = match plan.bind(frames) {
        Ok(job) => job,
        Err(e) => {
            defmt::error!("core refused the frames: {}", e);
            return SETUP_FAILED;
        }
    };
    let Ok(file) = semihosting::fs::File::create(OUT_FILE) else {
        defmt::error!("cannot create the output file");
        return IO_FAILED;
    };
    let mut harness = Harness {
        expected: EXPECTED,
        file,
        pixels: 0,
        mismatched: 0,
        first_mismatch: None,
        io_failed: false,
    };
    let mut sink = RgbRows::new(&mut harness);
    let engine: *mut Engine<COLS> = &raw mut ENGINE;
    // SAFETY: the only reference to ENGINE, taken once (`run` runs once).
    let engine = unsafe { &mut *engine };

    #[cfg(feature = "panic-canary")]
    if core::hint::black_box(false) {
        // Never runs: links the canary entry in for the panic check.
        crate::entry::rf_canary_entry(engine, &job, &mut sink, 0);
    }

    let painted = stack::paint();
    bench_start();
    rf_engine_entry(engine, &job, &mut sink);
    bench_stop();
    let (stack_bytes, saturated) = stack::high_water(&painted);

    defmt::info!(
        "result pixels={=usize} mismatched={=usize} stack={=usize} stack_saturated={=bool} tiles={=usize}",
        harness.pixels,
        harness.mismatched,
        stack_bytes,
        saturated,
        plan.tile_count()
    );
    if let Some((y, x, got, want)) = harness.first_mismatch {
        defmt::error!(
            "{=usize} pixels differ from the host; first at (x={=usize}, y={=usize}): {=[u8]} != {=[u8]}",
            harness.mismatched,
            x,
            y,
            got,
            want
        );
        return MISMATCH;
    }
    if harness.mismatched > 0 {
        defmt::error!(
            "{=usize} pixels beyond the expected bytes",
            harness.mismatched
        );
        return MISMATCH;
    }
    if harness.io_failed {
        defmt::error!("writing the output file failed");
        return IO_FAILED;
    }
    if harness.pixels != WIDTH * HEIGHT {
        defmt::error!(
            "{=usize} of {=usize} pixels produced",
            harness.pixels,
            WIDTH * HEIGHT
        );
        return INCOMPLETE;
    }
    defmt::info!("identical to the host's bytes");
    0
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(info));
    semihosting::process::exit(101)
}

//! The engine's one tiling policy and its one way of spreading a pair over
//! threads.
//!
//! Tiling: one thread computes a pair in full-height strips
//! ([`strip_width`]); several threads cut those strips into bands
//! (`balanced_tile`); `--tile` overrides both. Every tiling gives the
//! same bytes.
//!
//! Threads: a pair's tiles are `Bands`, taken one at a time by whichever
//! thread is free (the thread that asked, and the engine's kept pool),
//! each writing straight into the pair's shared planes through its tile's
//! sink; once every tile is computed, each thread finishes the tiles it
//! computed (their bytes: their magnitudes are still in its core's cache).
//! A thread that starts late finds every tile taken and only leaves.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex};

use reynoldsflow_core::{Config, FramePair, HALO, Params, Plan, Sink};

use super::bytes::{self, Isa, Pass};
use super::memory::HostEngine;
use crate::{Gray, HostError};

/// The widest of the host's default tiles: full-height strips of at most
/// 1 280 columns (windows of 1 294, 409 KiB of working memory, inside a
/// core's L2 cache on current x86-64 and Arm server cores).
pub(crate) const MAX_STRIP_WIDTH: usize = 1280;

/// The host's default tile width for a frame `width` wide: the fewest
/// full-height strips of at most `MAX_STRIP_WIDTH` columns, of equal
/// width (one strip up to 1 280 columns). Every row loop then runs the
/// strip's whole width, and the halo's 14 columns are paid once per strip:
/// `reynoldsflow run` (640×480, one thread) counted 286 M instructions
/// for 4 pairs in 128-column strips, 231 M in one strip, and ran in 0.79
/// of the time; at 1280×720, 0.75 (`farm-bench`, side by side). Any other
/// tile width up to the frame's runs too, in an engine grown to it; every
/// tiling gives the same bytes.
pub fn strip_width(width: usize) -> usize {
    let strips = width.div_ceil(MAX_STRIP_WIDTH).max(1);
    width.div_ceil(strips).max(1)
}

/// Tile size for `threads`: the host's full-width strips (one thread's
/// strips, at most [`MAX_STRIP_WIDTH`] wide) cut into as many bands as
/// gives the shortest pass, counting each band's halo (`HALO` rows above
/// and below) and `⌈tiles / threads⌉` rounds. Bands, not columns: a
/// tile's cost grows with its rows (each row is a step of the engine's
/// row rings), and bands keep each tile's planes and image rows whole.
pub(crate) fn balanced_tile(width: usize, height: usize, threads: usize) -> (usize, usize) {
    let strip = strip_width(width);
    let across = width.div_ceil(strip);
    let mut best = (usize::MAX, height.max(1));
    for down in 1..=(2 * threads).min(height).max(1) {
        let band = height.div_ceil(down);
        let tiles = across * height.div_ceil(band);
        let cost = tiles.div_ceil(threads) * (band + 2 * HALO);
        if cost < best.0 {
            best = (cost, band);
        }
    }
    (strip, best.1)
}

/// Checked geometry of one pair: configuration, tiling and the frames.
pub(crate) fn prepare<'a>(
    prev: &'a Gray,
    next: &'a Gray,
    params: Params,
    tile: Option<(usize, usize)>,
) -> Result<(Plan, FramePair<'a>), HostError> {
    if prev.size() != next.size() {
        return Err(HostError::SizeMismatch {
            prev: prev.size(),
            next: next.size(),
        });
    }
    let (width, height) = prev.size();
    let config = Config::new(width, height, params)?;
    let plan = match tile {
        None => Plan::strips(config, strip_width(width))?,
        Some((tw, th)) => Plan::new(config, tw, th)?,
    };
    let frames = FramePair::packed(&config, &prev.pixels, &next.pixels)?;
    Ok((plan, frames))
}

/// One pair's tiles, each behind its lock with the sink that receives it,
/// taken one at a time by whichever thread calls [`Self::work`].
pub(crate) struct Bands<'a, 'p, S> {
    plan: &'a Plan,
    frames: &'a FramePair<'p>,
    isa: Isa,
    tiles: &'a [Mutex<S>],
    /// The next tile nobody has taken.
    next: AtomicUsize,
    progress: Mutex<Progress>,
    /// Signalled when every tile is computed, or one failed.
    finished: Condvar,
}

/// How far the tiles' computation is.
#[derive(Default)]
struct Progress {
    /// Tiles computed.
    computed: usize,
    /// The first failure.
    failed: Option<HostError>,
}

impl<'a, 'p, S: Sink> Bands<'a, 'p, S> {
    /// The tiles of `plan` over `frames` (one sink per tile, in the plan's
    /// order), the pass compiled for `isa`.
    pub(crate) fn new(
        plan: &'a Plan,
        frames: &'a FramePair<'p>,
        isa: Isa,
        tiles: &'a [Mutex<S>],
    ) -> Self {
        Self {
            plan,
            frames,
            isa,
            tiles,
            next: AtomicUsize::new(0),
            progress: Mutex::new(Progress::default()),
            finished: Condvar::new(),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Progress> {
        self.progress.lock().expect("no panic while holding it")
    }

    /// One thread's part: tiles until none is left (in `memory`), then,
    /// once every tile is computed and none failed, `finish` with the
    /// indices of the tiles this thread computed. The others wait for the
    /// tiles, not for the threads.
    pub(crate) fn work(&self, memory: &mut HostEngine, finish: impl FnOnce(&[usize])) {
        let mut mine = Vec::new();
        let computed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let next = || {
                Some(self.next.fetch_add(1, Ordering::Relaxed))
                    .filter(|&index| index < self.tiles.len())
            };
            let Some(mut index) = next() else {
                return Ok(());
            };
            let mut engine = memory.engine(self.plan)?;
            loop {
                let mut tile = self.tiles[index]
                    .lock()
                    .expect("each tile is taken once at a time");
                let pass = Pass::Tile(index);
                let frames = self.frames;
                bytes::run(self.isa, &mut engine, self.plan, frames, pass, &mut *tile)?;
                drop(tile);
                mine.push(index);
                let mut progress = self.lock();
                progress.computed += 1;
                if progress.computed == self.tiles.len() {
                    self.finished.notify_all();
                }
                drop(progress);
                match next() {
                    Some(i) => index = i,
                    None => return Ok::<_, HostError>(()),
                }
            }
        }))
        .unwrap_or_else(|_| Err(HostError::internal_panic("pair", "computing a tile")));
        let mut progress = self.lock();
        if let Err(e) = computed {
            // Nobody waits for the tiles of a failed pair.
            progress.failed.get_or_insert(e);
            self.next.store(self.tiles.len(), Ordering::Relaxed);
            self.finished.notify_all();
        }
        while progress.computed < self.tiles.len() && progress.failed.is_none() {
            progress = self
                .finished
                .wait(progress)
                .expect("no panic while holding it");
        }
        if progress.failed.is_some() {
            return;
        }
        drop(progress);
        finish(&mine);
    }

    /// The first failure of any thread, once every thread has left
    /// [`Self::work`].
    pub(crate) fn result(self) -> Result<(), HostError> {
        let progress = self.progress.into_inner();
        match progress.expect("no panic while holding it").failed {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

/// [`Bands::work`] on this thread with `here`, and on as many of `pool`'s
/// threads as there are `helpers` (each with its memory), until the pair
/// is done; `finish` as in [`Bands::work`].
pub(crate) fn spread<S: Sink + Send>(
    bands: &Bands<'_, '_, S>,
    pool: Option<&rayon::ThreadPool>,
    here: &mut HostEngine,
    helpers: &mut [HostEngine],
    finish: &(dyn Fn(&[usize]) + Sync),
) {
    let wanted = bands.tiles.len().max(1).min(helpers.len() + 1) - 1;
    let helpers = &mut helpers[..wanted];
    match pool {
        // This thread takes tiles too; the pool's threads join it.
        Some(pool) if !helpers.is_empty() => pool.in_place_scope(|scope| {
            for memory in helpers.iter_mut() {
                scope.spawn(move |_| bands.work(memory, finish));
            }
            bands.work(here, finish);
        }),
        _ => bands.work(here, finish),
    }
}

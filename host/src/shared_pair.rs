//! A pair whose tiles more than one worker computes: how `run` ends.
//!
//! `run` gives each worker whole pairs ([`crate::pipeline`]). At the end of
//! the input the workers run out of pairs one after another, and one that
//! finds none left would wait while another finishes its last pair alone:
//! at 1280×720 on two threads the workers' last pairs ended 5.8 ms apart
//! (median of 15 runs of a 31-frame clip, 4 % of the run). So each of the
//! run's last `threads − 1` pairs is posted on the run's [`Desk`] when it
//! starts: its owner takes its tiles one at a time, and a worker with no
//! pair left takes tiles of it too, each into its own kept magnitudes
//! (per-frame min–max). The owner then copies the helpers' tiles into its
//! planes, merges the extremes and makes the bytes. Every tiling gives the
//! same bytes, so who computed a tile does not show in them. A failed or
//! panicking helper fails the pair, as a failing owner would.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex};

use reynoldsflow_core::{ExtremesSink, Params, Plan};

use crate::HostError;
use crate::dispatch::{self, Isa, Pass};
use crate::fixed_engine::{FrameEngine, HostEngine, Kept, KeptMagnitudes, prepare, strip_width};
use crate::page_buffer::ByteBuffer;
use crate::sequence::Frame;

/// Where a run's workers find pairs they can help with (with one worker,
/// no pair is ever shared).
pub(crate) struct Desk {
    workers: usize,
    /// Frames in the input, once the reader has found its end (0 before).
    frames: AtomicUsize,
    /// Pairs being computed whose tiles others may take.
    open: Mutex<Vec<Arc<SharedPair>>>,
}

impl Desk {
    /// A desk for `workers` workers.
    pub(crate) fn new(workers: usize) -> Self {
        Self {
            workers,
            frames: AtomicUsize::new(0),
            open: Mutex::new(Vec::new()),
        }
    }

    /// The reader reached the end of the input after `frames` frames.
    pub(crate) fn end_input(&self, frames: usize) {
        self.frames.store(frames, Ordering::SeqCst);
    }

    /// Whether pair `index` is shared: it is one of the last `workers − 1`
    /// (when it starts, the other workers have one pair left at most, and
    /// they finish it first), and the reader has told where the input ends.
    pub(crate) fn shares(&self, index: usize) -> bool {
        let frames = self.frames.load(Ordering::SeqCst);
        frames > 0 && index + self.workers >= frames
    }

    /// Compute `pair` with `engine`, its tiles open to other workers
    /// meanwhile; its representation into `rgb`.
    pub(crate) fn represent(
        &self,
        pair: SharedPair,
        engine: &mut FrameEngine,
        rgb: &mut impl ByteBuffer,
    ) -> Result<(), HostError> {
        let pair = Arc::new(pair);
        self.lock().push(Arc::clone(&pair));
        let result = pair.represent(engine, rgb);
        self.lock().retain(|open| !Arc::ptr_eq(open, &pair));
        result
    }

    /// Help with a posted pair that still has tiles to take, if any: the
    /// helper's kept planes go to that pair's owner.
    pub(crate) fn help(&self, engine: &mut FrameEngine) {
        let pair = self.lock().iter().find(|pair| pair.tiles_left()).cloned();
        if let Some(pair) = pair {
            pair.help(engine);
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Arc<SharedPair>>> {
        self.open.lock().expect("no panic while holding it")
    }
}

/// Bands of a shared pair (without `--tile`): each recomputes a 7-row
/// halo above and below, which at 1280×720 costs the pair 4.5 % in 8
/// bands of 90 rows (1 % in 6, 12 % in 16), while a helper that arrives
/// waits at most for the band in hand: about 1 ms at 1280×720.
const SHARED_BANDS: usize = 8;

/// No thinner band than this (a short frame's halo would cost more than
/// the band).
const MIN_BAND_ROWS: usize = 32;

/// One pair of the fixed engine in per-frame min–max, computed tile by
/// tile by its owner and any helpers.
pub(crate) struct SharedPair {
    prev: Arc<Frame>,
    next: Arc<Frame>,
    params: Params,
    /// Its tile size: `--tile`'s, else that of [`SHARED_BANDS`] bands.
    tile: (usize, usize),
    /// Tiles of the pair's plan.
    tiles: usize,
    /// The next tile nobody has taken (past `tiles` once all are).
    next_tile: AtomicUsize,
    progress: Mutex<Progress>,
    /// Signalled when helpers report.
    reported: Condvar,
}

/// What the helpers have handed back.
#[derive(Default)]
struct Progress {
    /// Tiles the helpers have finished.
    finished: usize,
    parts: Vec<Part>,
    /// A helper failed (or panicked): the pair fails.
    failed: Option<HostError>,
}

/// A helper's work: its kept planes (whole-frame layout), the tiles they
/// hold of the pair, and those tiles' extremes.
struct Part {
    kept: Kept,
    tiles: Vec<usize>,
    extremes: ExtremesSink,
}

impl SharedPair {
    /// The pair `(prev, next)`, checked as the engine checks it, in the
    /// tiles of `--tile` or else in [`SHARED_BANDS`] bands.
    pub(crate) fn new(
        prev: Arc<Frame>,
        next: Arc<Frame>,
        params: Params,
        tile: Option<(usize, usize)>,
    ) -> Result<Self, HostError> {
        let (width, height) = prev.gray.size();
        let band = height.div_ceil(SHARED_BANDS).max(MIN_BAND_ROWS);
        let tile = tile.unwrap_or((strip_width(width), band));
        let (plan, _) = prepare(&prev.gray, &next.gray, params, Some(tile))?;
        Ok(Self {
            tiles: plan.tile_count(),
            prev,
            next,
            params,
            tile,
            next_tile: AtomicUsize::new(0),
            progress: Mutex::new(Progress::default()),
            reported: Condvar::new(),
        })
    }

    fn tiles_left(&self) -> bool {
        self.next_tile.load(Ordering::Relaxed) < self.tiles
    }

    /// The owner's part: tiles until none is left, then, once every helper
    /// has reported, the helpers' tiles into its planes and the bytes.
    fn represent(
        &self,
        engine: &mut FrameEngine,
        rgb: &mut impl ByteBuffer,
    ) -> Result<(), HostError> {
        let (prev, next) = (&self.prev.gray, &self.next.gray);
        let (plan, frames) = prepare(prev, next, self.params, Some(self.tile))?;
        let width = prev.width;
        let (memory, isa, kept) = engine.parts();
        let mut sink = KeptMagnitudes::new(width, kept.planes(prev.pixels.len())?);
        let mut mine = 0;
        let computed = self.take_tiles(memory, isa, &plan, &frames, &mut sink, &mut |_| mine += 1);
        if computed.is_err() {
            // Nobody starts another tile of a failed pair.
            self.next_tile.store(self.tiles, Ordering::Relaxed);
        }
        computed?;
        let parts = self.wait_for_helpers(self.tiles - mine)?;
        for part in parts {
            sink.extremes.merge(part.extremes);
            let mut kept = part.kept;
            let [m_d, m_c] = kept.planes(prev.pixels.len())?;
            for tile in part.tiles.iter().filter_map(|&t| plan.tile(t)) {
                for y in tile.y..tile.y + tile.height {
                    let row = y * width + tile.x..y * width + tile.x + tile.width;
                    sink.planes[0][row.clone()].copy_from_slice(&m_d[row.clone()]);
                    sink.planes[1][row.clone()].copy_from_slice(&m_c[row]);
                }
            }
        }
        sink.into_bytes(isa, &prev.pixels, rgb)
    }

    /// The helpers' parts, once they have reported `tiles` tiles.
    fn wait_for_helpers(&self, tiles: usize) -> Result<Vec<Part>, HostError> {
        let mut progress = self.progress.lock().expect("no panic while holding it");
        while progress.finished < tiles && progress.failed.is_none() {
            progress = self
                .reported
                .wait(progress)
                .expect("no panic while holding it");
        }
        match progress.failed.take() {
            Some(e) => Err(e),
            None => Ok(std::mem::take(&mut progress.parts)),
        }
    }

    /// A helper's part: tiles until none is left into its own planes, then
    /// the planes to the owner (the helper's engine keeps none).
    fn help(&self, engine: &mut FrameEngine) {
        let mut tiles = Vec::new();
        let helped = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let (prev, next) = (&self.prev.gray, &self.next.gray);
            let (plan, frames) = prepare(prev, next, self.params, Some(self.tile))?;
            let (memory, isa, kept) = engine.parts();
            let mut sink = KeptMagnitudes::new(prev.width, kept.planes(prev.pixels.len())?);
            self.take_tiles(memory, isa, &plan, &frames, &mut sink, &mut |t| {
                tiles.push(t)
            })?;
            Ok(sink.extremes)
        }))
        .unwrap_or_else(|_| {
            Err(HostError::invalid(
                format!("frame {}", self.prev.stem),
                "internal error (panic) while helping with this pair",
            ))
        });
        if tiles.is_empty() {
            // Nothing taken: the owner does not wait for this helper.
            return;
        }
        let mut progress = self.progress.lock().expect("no panic while holding it");
        progress.finished += tiles.len();
        match helped {
            Ok(extremes) => {
                let kept = std::mem::take(engine.parts().2);
                progress.parts.push(Part {
                    kept,
                    tiles,
                    extremes,
                });
            }
            Err(e) => {
                progress.failed.get_or_insert(e);
            }
        }
        self.reported.notify_all();
    }

    /// Compute the tiles nobody has taken, one at a time, into `sink`;
    /// `taken` hears of each before it is computed.
    fn take_tiles(
        &self,
        memory: &mut HostEngine,
        isa: Isa,
        plan: &Plan,
        frames: &reynoldsflow_core::FramePair<'_>,
        sink: &mut KeptMagnitudes<'_>,
        taken: &mut dyn FnMut(usize),
    ) -> Result<(), HostError> {
        let engine = &mut memory.engine(plan)?;
        loop {
            let tile = self.next_tile.fetch_add(1, Ordering::Relaxed);
            if tile >= self.tiles {
                return Ok(());
            }
            taken(tile);
            dispatch::run(isa, engine, plan, frames, Pass::Tile(tile), sink)?;
        }
    }
}

#[cfg(test)]
mod tests {
    use reynoldsflow_core::Scaling;

    use super::*;
    use crate::Gray;

    fn frame(width: usize, height: usize, seed: usize) -> Arc<Frame> {
        let pixels = (0..width * height)
            .map(|i| ((i * 7 + seed).wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        Arc::new(Frame {
            gray: Gray::new(width, height, pixels).unwrap(),
            stem: format!("{seed:06}"),
            index: seed,
        })
    }

    /// The bytes of the whole-frame path, one worker.
    fn alone(prev: &Frame, next: &Frame, tile: Option<(usize, usize)>) -> Vec<u8> {
        let mut rgb = Vec::new();
        let scaling = Scaling::PerFrameMinMax;
        let (params, engine) = (Params::DEFAULT, &mut FrameEngine::new());
        engine
            .represent(&prev.gray, &next.gray, params, tile, scaling, &mut rgb)
            .unwrap();
        rgb
    }

    fn pair(prev: &Arc<Frame>, next: &Arc<Frame>, tile: Option<(usize, usize)>) -> SharedPair {
        SharedPair::new(Arc::clone(prev), Arc::clone(next), Params::DEFAULT, tile).unwrap()
    }

    /// Tiles the helpers reported.
    fn helped(pair: &SharedPair) -> usize {
        pair.progress.lock().unwrap().finished
    }

    #[test]
    fn a_pair_gives_the_same_bytes_whoever_computes_its_tiles() {
        let (prev, next) = (frame(90, 300, 0), frame(90, 300, 1));
        for tile in [None, Some((40, 70))] {
            let expected = alone(&prev, &next, tile);
            assert!(expected.chunks(3).any(|p| p[0] > 0 && p[1] > 0));

            // The owner alone, through the desk.
            let shared = pair(&prev, &next, tile);
            let tiles = shared.tiles;
            assert_eq!(tiles, if tile.is_some() { 15 } else { 8 }, "{tile:?}");
            let mut rgb = Vec::new();
            Desk::new(2)
                .represent(shared, &mut FrameEngine::new(), &mut rgb)
                .unwrap();
            assert!(rgb == expected, "owner alone, {tile:?}");

            // A helper takes every tile before the owner starts.
            let shared = pair(&prev, &next, tile);
            shared.help(&mut FrameEngine::new());
            assert_eq!(helped(&shared), tiles);
            let mut rgb = Vec::new();
            shared.represent(&mut FrameEngine::new(), &mut rgb).unwrap();
            assert!(rgb == expected, "helper alone, {tile:?}");

            // The owner and three helpers at once; a late helper finds nothing.
            let shared = pair(&prev, &next, tile);
            let mut rgb = Vec::new();
            std::thread::scope(|scope| {
                for _ in 0..3 {
                    scope.spawn(|| shared.help(&mut FrameEngine::new()));
                }
                shared.represent(&mut FrameEngine::new(), &mut rgb).unwrap();
            });
            assert!(rgb == expected, "owner and helpers, {tile:?}");
            let before = helped(&shared);
            assert!(before <= tiles);
            shared.help(&mut FrameEngine::new());
            assert_eq!(helped(&shared), before, "a tile computed twice");
        }
    }

    #[test]
    fn a_pair_is_shared_once_it_is_one_of_the_last() {
        let desk = Desk::new(2);
        assert!(!desk.shares(29), "before the end is known");
        desk.end_input(31);
        assert!(desk.shares(29) && !desk.shares(28));
        let desk = Desk::new(3);
        desk.end_input(31);
        assert!(desk.shares(28) && !desk.shares(27));
        let desk = Desk::new(4);
        desk.end_input(2);
        assert!(desk.shares(0));
        let desk = Desk::new(1);
        desk.end_input(31);
        assert!(
            (0..30).all(|pair| !desk.shares(pair)),
            "one worker shares nothing"
        );
    }

    #[test]
    fn a_helper_that_finds_no_tile_left_reports_nothing() {
        let (prev, next) = (frame(64, 100, 2), frame(64, 100, 3));
        let shared = pair(&prev, &next, None);
        shared.next_tile.store(shared.tiles, Ordering::Relaxed);
        let mut helper = FrameEngine::new();
        shared.help(&mut helper);
        assert_eq!(helped(&shared), 0);
        assert!(shared.progress.lock().unwrap().parts.is_empty());
    }
}

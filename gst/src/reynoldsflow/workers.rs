//! Whole pairs on several threads, for a stream whose frames come faster
//! than one pair takes (a file, a non-live source): each thread computes a
//! pair of its own on one core, as `reynoldsflow run`'s workers do, while
//! the streaming thread goes on to the next frame; the [`Outbox`] pushes
//! the results in stream order. (A live source gets each pair's tiles
//! spread over the threads instead: one pair's latency, [`super::imp`].)
//!
//! The bytes are those of any other path: every pair is computed alone
//! (the host's cues use an absolute level, so a pair's regions do not
//! depend on the pairs before it either).

use std::sync::{Arc, Mutex};

use reynoldsflow_host::Gray;
use reynoldsflow_host::settings::Settings;
use reynoldsflow_host::workers;

use super::message;
use super::outbox::{Outbox, Slot};
use super::pairs::{Failure, Pairs};

/// The threads and each one's engine.
pub(super) struct Workers {
    pool: rayon::ThreadPool,
    /// Engines not in use, each built for a generation of the properties:
    /// one per thread at most of the current one (in-flight pairs hold
    /// the others); older ones go when the generation changes.
    idle: Arc<Mutex<Vec<Pairs>>>,
}

/// What a worker needs to build an engine for a pair (shared by the
/// pairs of one generation).
pub(super) struct Recipe {
    /// The properties' settings, one thread each.
    pub(super) settings: Settings,
    pub(super) cues: bool,
    pub(super) generation: u64,
    pub(super) out_info: gst_video::VideoInfo,
}

impl Workers {
    /// `threads` threads.
    pub(super) fn new(threads: usize) -> Result<Self, Failure> {
        let pool = workers::kept_pool(threads, "reynoldsflow-worker")
            .map_err(|e| Failure::Settings(message(&e)))?;
        Ok(Self {
            pool,
            idle: Arc::default(),
        })
    }

    /// The pairs computed at once.
    pub(super) fn threads(&self) -> usize {
        self.pool.current_num_threads()
    }

    /// Check `recipe`'s settings by building an engine for it (kept for a
    /// worker), unless one of its generation is kept already.
    pub(super) fn prepare(&self, recipe: &Recipe) -> Result<(), Failure> {
        let mut idle = self.idle.lock().unwrap_or_else(|e| e.into_inner());
        idle.retain(|p| p.generation == recipe.generation);
        if idle.is_empty() {
            idle.push(Pairs::new(
                &recipe.settings,
                recipe.cues,
                recipe.generation,
            )?);
        }
        Ok(())
    }

    /// Compute the pair `(prev, next)` on a worker: its result fills the
    /// slot returned, which `outbox` is told of.
    pub(super) fn submit(
        &self,
        recipe: &Arc<Recipe>,
        prev: Arc<Gray>,
        next: Arc<Gray>,
        outbox: &Arc<Outbox>,
    ) -> Slot {
        let slot = Slot::default();
        outbox.computing();
        let (idle, outbox, recipe) = (
            Arc::clone(&self.idle),
            Arc::clone(outbox),
            Arc::clone(recipe),
        );
        let filled = Arc::clone(&slot);
        self.pool.spawn(move || {
            let compute = || {
                let kept = {
                    let mut idle = idle.lock().unwrap_or_else(|e| e.into_inner());
                    let at = idle.iter().position(|p| p.generation == recipe.generation);
                    at.map(|at| idle.swap_remove(at))
                };
                let mut pairs = match kept {
                    Some(pairs) => pairs,
                    None => Pairs::new(&recipe.settings, recipe.cues, recipe.generation)?,
                };
                let output = pairs.pair(&recipe.out_info, &prev, &next);
                idle.lock().unwrap_or_else(|e| e.into_inner()).push(pairs);
                output
            };
            // The slot is filled whatever happens: the outbox waits for it.
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(compute))
                .unwrap_or_else(|_| {
                    Err(Failure::Stream(
                        "internal error (panic) while computing a pair".into(),
                    ))
                });
            *filled.lock().unwrap_or_else(|e| e.into_inner()) = Some(result);
            outbox.computed();
        });
        slot
    }
}

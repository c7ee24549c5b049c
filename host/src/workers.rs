//! How the host uses several cores. Within one call: scoped OS threads
//! (`std::thread::scope`), each with its own state (an engine, buffers).
//! [`map_indices`] spreads independent jobs (the items of `dataset`, the
//! tiles of one pair, the pairs of an in-memory clip) over them; `run`'s
//! pipeline runs its reader, workers and writer as scoped threads too.
//! The jobs are few and coarse (an item, a tile, a pair), workers block on
//! I/O and channels, and `dataset` nests `run`'s pipeline inside each item:
//! plain scoped threads nest without one pool's thread waiting on, or
//! stealing from, another.
//!
//! From one call to the next, for a stream of pairs where starting threads
//! for each would cost more than waking them: a [`kept_pool`] (the pair
//! engine's helpers, the GStreamer element's workers).

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::HostError;
use crate::settings::Setting;

/// `threads` threads kept until the pool is dropped (which lets the jobs
/// given to it finish), named `name-0`, `name-1`, …; failing to start them
/// is an error of the threads setting.
pub fn kept_pool(threads: usize, name: &'static str) -> Result<rayon::ThreadPool, HostError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(move |i| format!("{name}-{i}"))
        .build()
        .map_err(|e| {
            HostError::setting(
                Setting::Threads,
                format!("cannot start {threads} more threads: {e}"),
            )
        })
}

/// `work(state, i)` for every `i` in `0..count`, spread over `threads`
/// scoped threads (this thread is one of them), each with its own `state`
/// from `init`; every thread takes the next `i` not yet taken, so they are
/// started in increasing order. The results, in index order.
pub fn map_indices<S, R: Send>(
    threads: usize,
    count: usize,
    init: impl Fn() -> S + Sync,
    work: impl Fn(&mut S, usize) -> R + Sync,
) -> Vec<R> {
    let next = AtomicUsize::new(0);
    let done = Mutex::new(Vec::with_capacity(count));
    let take_jobs = || {
        let mut state = None;
        loop {
            let i = next.fetch_add(1, Ordering::SeqCst);
            if i >= count {
                return;
            }
            let result = work(state.get_or_insert_with(&init), i);
            done.lock()
                .expect("no panic while holding it")
                .push((i, result));
        }
    };
    std::thread::scope(|scope| {
        for _ in 1..threads.clamp(1, count.max(1)) {
            scope.spawn(take_jobs);
        }
        take_jobs();
    });
    let mut done = done.into_inner().expect("every thread has finished");
    done.sort_unstable_by_key(|&(i, _)| i);
    done.into_iter().map(|(_, result)| result).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_index_once_in_order_whatever_the_thread_count() {
        for threads in [0, 1, 2, 3, 8] {
            for count in [0, 1, 5, 40] {
                let inits = AtomicUsize::new(0);
                let out = map_indices(
                    threads,
                    count,
                    || inits.fetch_add(1, Ordering::SeqCst),
                    |_, i| i * i,
                );
                let expected: Vec<usize> = (0..count).map(|i| i * i).collect();
                assert_eq!(out, expected, "{threads} threads, {count} jobs");
                // One state per thread that took a job, at most.
                assert!(inits.load(Ordering::SeqCst) <= threads.max(1).min(count));
            }
        }
    }
}

//! The host's one way to use several cores: scoped OS threads
//! (`std::thread::scope`), each with its own state (an engine, buffers).
//! [`map_indices`] spreads independent jobs (the items of `dataset`, the
//! tiles of one pair, the pairs of an in-memory clip) over them; `run`'s
//! pipeline runs its reader, workers and writer as scoped threads too.
//!
//! Why not a work-stealing pool (rayon): the jobs are few and coarse (an
//! item, a tile, a pair), workers block on I/O and channels, and `dataset`
//! nests `run`'s pipeline inside each item: plain scoped threads nest
//! without one pool's thread waiting on, or stealing from, another, and
//! need no dependency.

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

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

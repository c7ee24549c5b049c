//! The one ordered driver of whole pairs: jobs in (from a feeding thread),
//! each computed on one of a pool of worker threads with the worker's own
//! state (its engine and buffers, reused job after job), outputs handed
//! out in the order the jobs came, on the calling thread. `run` and
//! `dataset` (`pipeline::process`) and Python's `represent_clip`
//! drive their pairs through it.
//!
//! At most `2 · threads` jobs are in flight (fed but not yet handed out),
//! so memory stays bounded whatever the input's length, and the outputs
//! are the same for every thread count. A job that fails (or panics) stops
//! the run at once; the feed's own failure comes after the jobs fed before
//! it are handed out; the receiver of the outputs stops the run by
//! returning [`ControlFlow::Break`] or an error. Once stopped, no new job
//! starts and the feeder is unblocked ([`Feed::send`] returns false).

use std::any::Any;
use std::cell::Cell;
use std::collections::BTreeMap;
use std::ops::ControlFlow;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender};

/// What a run computes: one job on one worker, with that worker's state.
pub trait Work: Sync {
    /// What the feeder hands out (a pair of frames, an index).
    type Job: Send;
    /// One job's result.
    type Output: Send;
    /// Why a job (or the feed) failed.
    type Error: Send;
    /// Each worker's own state, made once per worker thread.
    type State;

    /// A worker's state (on its thread, before its first job).
    fn state(&self) -> Self::State;

    /// Compute `job`.
    fn compute(
        &self,
        state: &mut Self::State,
        job: &Self::Job,
    ) -> Result<Self::Output, Self::Error>;

    /// The error of a job whose computation panicked with `payload`.
    fn panicked(&self, job: &Self::Job, payload: Box<dyn Any + Send>) -> Self::Error;

    /// A job done with (computed, failed or skipped): its buffers may go
    /// back for reuse.
    fn release(&self, job: Self::Job) {
        drop(job);
    }
}

/// The feeder's end: jobs go in here, in order.
pub struct Feed<'s, J> {
    jobs: SyncSender<(usize, J)>,
    /// One per job in flight; the receiver hands one back per output.
    tokens: Receiver<()>,
    stop: &'s AtomicBool,
    /// The number of the next job.
    next: Cell<usize>,
}

impl<J> Feed<'_, J> {
    /// Queue the next job once there is room; false when the run is
    /// stopping (the job is dropped and nothing more should be fed).
    pub fn send(&self, job: J) -> bool {
        if self.stopped() || self.tokens.recv().is_err() {
            return false;
        }
        let i = self.next.get();
        self.next.set(i + 1);
        self.jobs.send((i, job)).is_ok()
    }

    /// Whether the run is stopping (a job or the receiver failed).
    pub fn stopped(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }
}

enum Msg<O, E, T> {
    Done(usize, Result<O, E>),
    Fed(Result<T, E>),
}

/// Run `feed` on a thread of its own and `work` on `threads` workers,
/// handing each output to `deliver` on this thread in the order its job
/// was fed. `Ok(Some(t))`: every job's output was delivered and the feed
/// returned `t`; `Ok(None)`: `deliver` stopped the run. The error is the
/// first of a job or of `deliver`, else the feed's (after every job fed
/// before it was delivered).
pub fn in_order<W: Work, T: Send>(
    work: &W,
    threads: usize,
    feed: impl FnOnce(&Feed<'_, W::Job>) -> Result<T, W::Error> + Send,
    mut deliver: impl FnMut(W::Output) -> Result<ControlFlow<()>, W::Error>,
) -> Result<Option<T>, W::Error> {
    let threads = threads.max(1);
    let in_flight = 2 * threads;
    let stop = AtomicBool::new(false);
    let (job_tx, job_rx) = mpsc::sync_channel::<(usize, W::Job)>(threads);
    let job_rx = Mutex::new(job_rx);
    let (msg_tx, msg_rx) = mpsc::channel::<Msg<W::Output, W::Error, T>>();
    let (token_tx, token_rx) = mpsc::sync_channel::<()>(in_flight);
    for _ in 0..in_flight {
        token_tx.send(()).expect("the receiver is alive");
    }
    std::thread::scope(|scope| {
        let stop = &stop;
        let fed = msg_tx.clone();
        scope.spawn(move || {
            let feeder = Feed {
                jobs: job_tx,
                tokens: token_rx,
                stop,
                next: Cell::new(0),
            };
            let result = feed(&feeder);
            // The workers end once the jobs' channel closes.
            drop(feeder);
            let _ = fed.send(Msg::Fed(result));
        });
        for _ in 0..threads {
            let (job_rx, msg_tx) = (&job_rx, msg_tx.clone());
            scope.spawn(move || take_jobs(work, job_rx, &msg_tx, stop));
        }
        drop(msg_tx);
        collect(msg_rx, token_tx, stop, &mut deliver)
    })
}

/// A worker: take jobs until the feeder is done, compute each (unless the
/// run is stopping), release it, report its output.
fn take_jobs<W: Work, T>(
    work: &W,
    jobs: &Mutex<Receiver<(usize, W::Job)>>,
    msgs: &mpsc::Sender<Msg<W::Output, W::Error, T>>,
    stop: &AtomicBool,
) {
    let mut state = work.state();
    loop {
        // The lock is held only while waiting for the next job: a guard
        // in a `while let` condition would live through the whole body
        // and keep every other worker waiting.
        let next = jobs.lock().expect("no worker panics holding it").recv();
        let Ok((index, job)) = next else {
            return;
        };
        if stop.load(Ordering::SeqCst) {
            work.release(job);
            continue;
        }
        // A panic too gives the job an output: the others must not wait
        // for it.
        let output = catch_unwind(AssertUnwindSafe(|| work.compute(&mut state, &job)))
            .unwrap_or_else(|payload| Err(work.panicked(&job, payload)));
        work.release(job);
        if msgs.send(Msg::Done(index, output)).is_err() {
            return;
        }
    }
}

/// The calling thread's part: outputs in order as they arrive.
fn collect<O, E, T>(
    msgs: Receiver<Msg<O, E, T>>,
    tokens: SyncSender<()>,
    stop: &AtomicBool,
    deliver: &mut impl FnMut(O) -> Result<ControlFlow<()>, E>,
) -> Result<Option<T>, E> {
    // Dropped to unblock the feeder when the run stops.
    let mut tokens = Some(tokens);
    let fail = |tokens: &mut Option<SyncSender<()>>| {
        stop.store(true, Ordering::SeqCst);
        *tokens = None;
    };
    let mut pending = BTreeMap::new();
    let (mut error, mut fed, mut feed_error) = (None, None, None);
    let mut delivered = 0;
    let mut closed = false;
    for msg in msgs {
        match msg {
            Msg::Done(index, Ok(output)) => {
                pending.insert(index, output);
            }
            Msg::Done(_, Err(e)) => {
                fail(&mut tokens);
                error.get_or_insert(e);
            }
            Msg::Fed(Ok(t)) => fed = Some(t),
            Msg::Fed(Err(e)) => feed_error = Some(e),
        }
        while error.is_none() && !closed {
            let Some(output) = pending.remove(&delivered) else {
                break;
            };
            match deliver(output) {
                Ok(ControlFlow::Continue(())) => {
                    delivered += 1;
                    if let Some(t) = &tokens {
                        let _ = t.send(());
                    }
                }
                Ok(ControlFlow::Break(())) => {
                    closed = true;
                    fail(&mut tokens);
                }
                Err(e) => {
                    error = Some(e);
                    fail(&mut tokens);
                }
            }
        }
    }
    if let Some(e) = error.or(feed_error) {
        return Err(e);
    }
    if closed {
        return Ok(None);
    }
    Ok(Some(fed.expect("the feeder ends with its result")))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Squares; job `fail` fails, job `panic` panics; each worker counts
    /// its jobs in its state.
    struct Squares {
        fail: Option<usize>,
        panic: Option<usize>,
    }

    impl Work for Squares {
        type Job = usize;
        type Output = usize;
        type Error = String;
        type State = usize;

        fn state(&self) -> usize {
            0
        }

        fn compute(&self, done: &mut usize, &i: &usize) -> Result<usize, String> {
            *done += 1;
            assert!(self.panic != Some(i), "job {i} panics on purpose");
            match self.fail == Some(i) {
                true => Err(format!("job {i} failed")),
                false => Ok(i * i),
            }
        }

        fn panicked(&self, &i: &usize, payload: Box<dyn Any + Send>) -> String {
            format!("job {i}: {}", crate::panic_message(payload.as_ref()))
        }
    }

    /// `jobs` jobs on `threads` workers, the feed failing after them if
    /// `feed_fails`, the receiver stopping after `take` outputs: the
    /// result and the outputs received.
    fn run(
        work: &Squares,
        threads: usize,
        jobs: usize,
        feed_fails: bool,
        take: usize,
    ) -> (Result<Option<&'static str>, String>, Vec<usize>) {
        let mut got = Vec::new();
        let result = in_order(
            work,
            threads,
            |feed| {
                (0..jobs).all(|i| feed.send(i));
                match feed_fails {
                    true => Err("feed failed".to_string()),
                    false => Ok("fed"),
                }
            },
            |out| {
                got.push(out);
                Ok(match got.len() < take {
                    true => ControlFlow::Continue(()),
                    false => ControlFlow::Break(()),
                })
            },
        );
        (result, got)
    }

    const ALL: Squares = Squares {
        fail: None,
        panic: None,
    };

    #[test]
    fn outputs_in_feed_order_whatever_the_thread_count() {
        let squares: Vec<usize> = (0..40).map(|i| i * i).collect();
        for threads in [0, 1, 2, 3, 8] {
            let (result, got) = run(&ALL, threads, 40, false, usize::MAX);
            assert_eq!(result, Ok(Some("fed")), "{threads} threads");
            assert_eq!(got, squares, "{threads} threads");
        }
        assert_eq!(
            run(&ALL, 2, 0, false, usize::MAX),
            (Ok(Some("fed")), vec![])
        );
    }

    #[test]
    fn the_feeds_failure_comes_after_the_jobs_fed_before_it() {
        let (result, got) = run(&ALL, 3, 7, true, usize::MAX);
        assert_eq!(result, Err("feed failed".into()));
        assert_eq!(got, (0..7).map(|i| i * i).collect::<Vec<_>>());
    }

    #[test]
    fn a_failed_or_panicking_job_stops_the_run_before_any_later_output() {
        for threads in [1, 2, 4] {
            let fails = Squares {
                fail: Some(5),
                panic: None,
            };
            let (result, got) = run(&fails, threads, 200, false, usize::MAX);
            assert_eq!(result, Err("job 5 failed".into()));
            assert!(got.len() <= 5 && got.iter().enumerate().all(|(i, &o)| o == i * i));
            let panics = Squares {
                fail: None,
                panic: Some(3),
            };
            let (result, got) = run(&panics, threads, 200, false, usize::MAX);
            assert_eq!(result, Err("job 3: job 3 panics on purpose".into()));
            assert!(got.len() <= 3);
        }
    }

    #[test]
    fn the_receiver_stops_the_run_and_unblocks_the_feeder() {
        for threads in [1, 2, 4] {
            // Without the stop, the feeder would wait for room for ever
            // after `2 · threads` jobs past the last output taken.
            let (result, got) = run(&ALL, threads, 10_000, false, 4);
            assert_eq!(result, Ok(None), "{threads} threads");
            assert_eq!(got, vec![0, 1, 4, 9]);
        }
    }
}

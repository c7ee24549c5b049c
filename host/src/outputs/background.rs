//! A few threads that take jobs off the caller's thread: a result's images
//! encoded and its files written (each flushed to disk before it is
//! renamed into place) while the engine's thread computes the next pair.
//!
//! A job is handed over only when a thread is free to take it (no queue),
//! so at most one job a thread is held beyond the caller's own, whatever
//! the speed of the disk: at 3840×2160 with `--npy` a result's fields are
//! 265 MB. The
//! first failure is kept and returned by the next [`Stage::submit`] or by
//! [`Stage::flush`], which waits until every job submitted is done.

use std::sync::mpsc::{self, Receiver, SyncSender};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;

use crate::HostError;

/// Jobs submitted and not yet done, and the first failure.
#[derive(Default)]
struct Pending {
    jobs: usize,
    error: Option<HostError>,
}

/// What the caller and the threads share.
#[derive(Default)]
struct State {
    pending: Mutex<Pending>,
    done: Condvar,
}

impl State {
    fn lock(&self) -> std::sync::MutexGuard<'_, Pending> {
        self.pending.lock().expect("no panics holding it")
    }
}

/// Threads running `work` on each job submitted, in any order.
pub(crate) struct Stage<J> {
    jobs: Option<SyncSender<J>>,
    threads: Vec<JoinHandle<()>>,
    state: Arc<State>,
}

impl<J> std::fmt::Debug for Stage<J> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Stage({} threads)", self.threads.len())
    }
}

impl<J: Send + 'static> Stage<J> {
    /// `threads` threads (at least one) running `work`; fails only when the
    /// system refuses a thread.
    pub(crate) fn spawn(
        threads: usize,
        work: impl Fn(J) -> Result<(), HostError> + Send + Sync + 'static,
    ) -> Result<Self, HostError> {
        let threads = threads.max(1);
        let (tx, rx) = mpsc::sync_channel::<J>(0);
        let rx = Arc::new(Mutex::new(rx));
        let work = Arc::new(work);
        let state = Arc::new(State::default());
        let mut stage = Self {
            jobs: Some(tx),
            threads: Vec::new(),
            state,
        };
        for n in 0..threads {
            let (rx, work, state) = (Arc::clone(&rx), Arc::clone(&work), Arc::clone(&stage.state));
            let handle = std::thread::Builder::new()
                .name(format!("reynoldsflow-write-{n}"))
                .spawn(move || serve(&rx, &*work, &state))
                .map_err(|e| HostError::io("writer thread", e))?;
            stage.threads.push(handle);
        }
        Ok(stage)
    }

    /// Hand `job` over (waiting until a thread is free); an earlier job's
    /// failure instead, if there was one.
    pub(crate) fn submit(&self, job: J) -> Result<(), HostError> {
        {
            let mut pending = self.state.lock();
            if let Some(e) = pending.error.take() {
                return Err(e);
            }
            pending.jobs += 1;
        }
        let sent = self
            .jobs
            .as_ref()
            .is_some_and(|jobs| jobs.send(job).is_ok());
        if !sent {
            self.state.lock().jobs -= 1;
            return Err(HostError::invalid(
                "output",
                "the writer threads have stopped",
            ));
        }
        Ok(())
    }

    /// Wait until every job submitted is done; the first failure, if any.
    pub(crate) fn flush(&self) -> Result<(), HostError> {
        let mut pending = self.state.lock();
        while pending.jobs > 0 {
            pending = self.state.done.wait(pending).expect("no panics holding it");
        }
        pending.error.take().map_or(Ok(()), Err)
    }
}

impl<J> Drop for Stage<J> {
    /// Let the threads finish the jobs queued, then end them.
    fn drop(&mut self) {
        self.jobs = None;
        for thread in self.threads.drain(..) {
            let _ = thread.join();
        }
    }
}

/// One thread: jobs until the queue closes. A panic in `work` is a
/// failure of its job, not a job never done (which `flush` would wait for).
fn serve<J>(jobs: &Mutex<Receiver<J>>, work: &dyn Fn(J) -> Result<(), HostError>, state: &State) {
    loop {
        // Locked only while waiting for a job, so the threads work at once.
        let next = jobs.lock().expect("no panics holding it").recv();
        let Ok(job) = next else {
            return;
        };
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(job)))
            .unwrap_or_else(|_| Err(HostError::internal_panic("output", "writing a result")));
        let mut pending = state.lock();
        if let Err(e) = result {
            pending.error.get_or_insert(e);
        }
        pending.jobs -= 1;
        if pending.jobs == 0 {
            state.done.notify_all();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    #[test]
    fn every_job_is_done_by_flush_and_the_first_failure_is_returned() {
        let done = Arc::new(AtomicUsize::new(0));
        let counter = Arc::clone(&done);
        let stage = Stage::spawn(3, move |n: usize| {
            std::thread::sleep(std::time::Duration::from_millis(1));
            counter.fetch_add(1, Ordering::SeqCst);
            if n == 7 {
                return Err(HostError::invalid("job", "seven"));
            }
            assert_ne!(n, 9, "a panicking job");
            Ok(())
        })
        .unwrap();
        for n in 0..7 {
            stage.submit(n).unwrap();
        }
        stage.flush().unwrap();
        assert_eq!(done.load(Ordering::SeqCst), 7);
        stage.submit(7).unwrap();
        let e = stage.flush().unwrap_err();
        assert!(e.to_string().contains("seven"), "{e}");
        stage.submit(9).unwrap();
        assert!(stage.flush().unwrap_err().to_string().contains("panic"));
        stage.flush().unwrap();
        drop(stage);
        assert_eq!(done.load(Ordering::SeqCst), 9);
    }
}

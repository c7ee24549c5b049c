//! The element's outputs, pushed downstream in stream order: every output
//! leaves through here ([`Outbox::send`]), so the element marks `DISCONT`
//! and keeps the position the same way on every path (the base class sees
//! no output buffer). Those of pairs computed on other threads
//! ([`super::workers`]) wait here until they and every output before them
//! are ready. Whichever thread finds the front ready pushes (a worker that
//! just finished a pair, or the streaming thread after adding a ready
//! output), one at a time: no thread of its own to start and stop.
//!
//! The streaming thread waits here, never holding the element's state:
//! for room before it takes the next frame (as many pairs computing as
//! there are threads), and for every output to be pushed before a
//! serialized event or query goes on (so caps, segments, gaps and EOS stay
//! where they were among the outputs). A flush, a stop or a failed push
//! stops the waits at once.

use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};

use gst::prelude::*;

use super::pairs::{Failure, PairOutput, Stamps, outputs_of};

/// A pair's result, once its thread has computed it.
pub(super) type Slot = Arc<Mutex<Option<Result<PairOutput, Failure>>>>;

/// An output made on the streaming thread, ready to go.
pub(super) enum Ready {
    /// A stamped buffer.
    Buffer(gst::Buffer),
    /// A gap in the input, passed on in its place.
    Gap(gst::Event),
}

/// One output, in stream order.
pub(super) enum Item {
    /// A pair computed elsewhere, going out once per label (two for the
    /// copy of `first-frame=repeat`).
    Pair {
        slot: Slot,
        labels: Vec<Stamps>,
        /// Its first output follows a reset.
        discont: bool,
    },
    /// Made on the streaming thread.
    Ready(Ready),
}

impl Item {
    fn ready(&self) -> bool {
        match self {
            Self::Pair { slot, .. } => lock(slot).is_some(),
            Self::Ready(_) => true,
        }
    }
}

#[derive(Default)]
struct Inner {
    items: VecDeque<Item>,
    /// Pairs handed to the workers and not finished (stale ones too: they
    /// hold a thread).
    computing: usize,
    /// A thread is pushing the front (one at a time, in order).
    pushing: bool,
    /// Between a flush's start and its stop, and after a stop.
    flushing: bool,
    /// An error a push returned (or a failed pair's): the outputs stop and
    /// it goes upstream with the next frame, until a flush or a stop.
    failed: Option<gst::FlowError>,
}

/// Where the outputs are in the stream, for POSITION queries (the base
/// class keeps it only for buffers it pushes itself).
#[derive(Default)]
struct Position {
    /// The last time segment (none in a flush, or one in another format).
    segment: Option<gst::FormattedSegment<gst::ClockTime>>,
    /// The end of the last output pushed (its timestamp plus duration).
    end: Option<gst::ClockTime>,
}

/// The element's outputs in order.
pub(super) struct Outbox {
    inner: Mutex<Inner>,
    changed: Condvar,
    /// Its own lock: a query reads it while a push is in hand.
    position: Mutex<Position>,
    src: gst::Pad,
    element: gst::glib::WeakRef<super::ReynoldsFlow>,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // Nothing panics while holding these (plain assignments).
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Outbox {
    /// The outbox of `element`, pushing on its source pad.
    pub(super) fn new(element: &super::ReynoldsFlow) -> Self {
        use gst_base::prelude::*;
        Self {
            inner: Mutex::default(),
            changed: Condvar::new(),
            position: Mutex::default(),
            src: element.src_pad().clone(),
            element: element.downgrade(),
        }
    }

    fn inner(&self) -> MutexGuard<'_, Inner> {
        lock(&self.inner)
    }

    fn wait<'a>(&self, guard: MutexGuard<'a, Inner>) -> MutexGuard<'a, Inner> {
        self.changed.wait(guard).unwrap_or_else(|e| e.into_inner())
    }

    /// What the streaming thread returns upstream: `Flushing` in a flush,
    /// a failed push's error, else OK.
    fn flow(inner: &Inner) -> Result<gst::FlowSuccess, gst::FlowError> {
        match (inner.flushing, inner.failed) {
            (true, _) => Err(gst::FlowError::Flushing),
            (false, Some(e)) => Err(e),
            (false, None) => Ok(gst::FlowSuccess::Ok),
        }
    }

    /// Queue `item` after the others.
    pub(super) fn add(&self, item: Item) {
        self.inner().items.push_back(item);
    }

    /// A pair goes to a worker: call before handing it over.
    pub(super) fn computing(&self) {
        self.inner().computing += 1;
    }

    /// A worker finished a pair (its slot filled): push what is ready.
    pub(super) fn computed(&self) {
        {
            let mut inner = self.inner();
            inner.computing -= 1;
            self.changed.notify_all();
        }
        self.push_ready();
    }

    /// Wait until fewer than `threads` pairs are computing and at most
    /// `2 · threads` outputs wait (downstream keeps up).
    pub(super) fn wait_room(&self, threads: usize) -> Result<gst::FlowSuccess, gst::FlowError> {
        let mut inner = self.inner();
        while (inner.computing >= threads || inner.items.len() > 2 * threads)
            && Self::flow(&inner).is_ok()
        {
            inner = self.wait(inner);
        }
        Self::flow(&inner)
    }

    /// Wait until every output is pushed (or a flush, a stop or a failed
    /// push ends the wait).
    pub(super) fn drain(&self) -> Result<gst::FlowSuccess, gst::FlowError> {
        let mut inner = self.inner();
        while (!inner.items.is_empty() || inner.pushing) && Self::flow(&inner).is_ok() {
            inner = self.wait(inner);
        }
        Self::flow(&inner)
    }

    /// A flush starts (any thread): the waits end, nothing more is pushed.
    pub(super) fn flush_start(&self) {
        self.inner().flushing = true;
        self.changed.notify_all();
    }

    /// A flush stops, or the element stops: the outputs not yet pushed are
    /// dropped (pairs still computing fill slots nobody reads), and the
    /// next ones are pushed again.
    pub(super) fn flush_stop(&self) {
        let mut inner = self.inner();
        inner.flushing = true;
        self.changed.notify_all();
        // The push in hand returns soon: downstream flushes too.
        while inner.pushing {
            inner = self.wait(inner);
        }
        inner.items.clear();
        inner.flushing = false;
        inner.failed = None;
        // As the base class: a new segment comes after a flush.
        *lock(&self.position) = Position::default();
    }

    /// The segment the next outputs are in.
    pub(super) fn set_segment(&self, segment: &gst::Segment) {
        lock(&self.position).segment = segment.downcast_ref::<gst::ClockTime>().cloned();
    }

    /// The stream time of the end of the last output pushed, once one is
    /// (in a time segment).
    pub(super) fn position(&self) -> Option<gst::ClockTime> {
        let position = lock(&self.position);
        position.segment.as_ref()?.to_stream_time(position.end?)
    }

    /// Push `ready` downstream now: a buffer's end is the position from
    /// now on.
    pub(super) fn send(&self, ready: Ready) -> Result<gst::FlowSuccess, gst::FlowError> {
        match ready {
            Ready::Buffer(buffer) => {
                if let Some(pts) = buffer.pts() {
                    let end = pts.saturating_add(buffer.duration().unwrap_or_default());
                    lock(&self.position).end = Some(end);
                }
                self.src.push(buffer)
            }
            Ready::Gap(gap) => {
                self.src.push_event(gap);
                Ok(gst::FlowSuccess::Ok)
            }
        }
    }

    /// Push the ready outputs at the front, unless another thread is.
    pub(super) fn push_ready(&self) {
        let mut inner = self.inner();
        if inner.pushing {
            return;
        }
        inner.pushing = true;
        while Self::flow(&inner).is_ok() && inner.items.front().is_some_and(Item::ready) {
            let item = inner.items.pop_front().expect("a front item");
            drop(inner);
            let pushed = self.push(item);
            inner = self.inner();
            if let Err(e) = pushed {
                // A flush's `Flushing` is no failure: the stop clears it.
                if !inner.flushing {
                    inner.failed = Some(e);
                }
            }
        }
        inner.pushing = false;
        self.changed.notify_all();
    }

    /// Push one output downstream (its stamps, cue metas and messages).
    fn push(&self, item: Item) -> Result<gst::FlowSuccess, gst::FlowError> {
        match item {
            Item::Ready(ready) => self.send(ready),
            Item::Pair {
                slot,
                labels,
                discont,
            } => {
                let computed = lock(&slot).take().expect("a ready slot");
                let element = self.element.upgrade().ok_or(gst::FlowError::Flushing)?;
                let output = computed.map_err(|failure| {
                    failure.post(&element);
                    gst::FlowError::Error
                })?;
                let mut discont = discont;
                for buffer in outputs_of(&element, output, &labels, &mut discont) {
                    self.send(Ready::Buffer(buffer))?;
                }
                Ok(gst::FlowSuccess::Ok)
            }
        }
    }
}

//! A plan bound to the frames it runs on: the one value an engine runs.

use crate::kernels::Choice;
use crate::{Config, Error, FramePair, Plan};

/// A [`Plan`] and a [`FramePair`] of the plan's size, checked once: running
/// a job cannot fail ([`Engine::run`](crate::Engine::run)).
#[derive(Clone, Copy, Debug)]
pub struct Job<'a> {
    plan: &'a Plan,
    frames: FramePair<'a>,
    /// The kernel set its pass runs; set by the kernels that a run-time
    /// choice makes available (`kernels/`).
    pub(crate) kernels: Choice,
}

impl<'a> Job<'a> {
    /// Bind `frames` to `plan`; they must be of the plan's size.
    pub fn new(plan: &'a Plan, frames: FramePair<'a>) -> Result<Self, Error> {
        let size = (plan.config().width(), plan.config().height());
        let (prev, next) = (frames.prev(), frames.next());
        if (prev.width(), prev.height()) != size || (next.width(), next.height()) != size {
            return Err(Error::SizeMismatch);
        }
        Ok(Self {
            plan,
            frames,
            kernels: Choice::default(),
        })
    }

    /// The kernel set its pass runs.
    pub(crate) const fn kernels(&self) -> Choice {
        self.kernels
    }

    /// The plan.
    pub const fn plan(&self) -> &'a Plan {
        self.plan
    }

    /// The frames.
    pub const fn frames(&self) -> &FramePair<'a> {
        &self.frames
    }

    /// The plan's configuration.
    pub const fn config(&self) -> &'a Config {
        self.plan.config()
    }
}

impl Plan {
    /// Bind frames of this plan's size to it ([`Job::new`]).
    pub fn bind<'a>(&'a self, frames: FramePair<'a>) -> Result<Job<'a>, Error> {
        Job::new(self, frames)
    }
}

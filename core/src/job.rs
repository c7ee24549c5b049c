//! A plan bound to the frames it runs on: the one value an engine runs.

use crate::{Config, Error, FramePair, Plan};

/// Which kernels a job's pass runs: the portable ones, or on x86-64 with
/// an [`Avx2`](crate::Avx2) token the structure sums and tail in AVX2
/// lanes (`avx2`).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Kernels {
    #[cfg(target_arch = "x86_64")]
    pub(crate) avx2: Option<crate::Avx2>,
}

/// A [`Plan`] and a [`FramePair`] of the plan's size, checked once: running
/// a job cannot fail ([`Engine::run`](crate::Engine::run)).
#[derive(Clone, Copy, Debug)]
pub struct Job<'a> {
    plan: &'a Plan,
    frames: FramePair<'a>,
    kernels: Kernels,
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
            kernels: Kernels::default(),
        })
    }

    /// The same job, its structure sums and tail run in AVX2 lanes (the
    /// same bytes): for hosts that found AVX2 and FMA at run time.
    #[cfg(target_arch = "x86_64")]
    pub fn with_avx2(self, avx2: crate::Avx2) -> Self {
        Self {
            kernels: Kernels { avx2: Some(avx2) },
            ..self
        }
    }

    /// The kernels its pass runs.
    pub(crate) const fn kernels(&self) -> Kernels {
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

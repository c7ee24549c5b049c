//! The engine's memory: what one thread lends the core for its tiles.

use reynoldsflow_core::{MemorySize, Plan, SliceEngine};

use crate::HostError;

/// The host's engine memory: vectors grown to the widest tile asked for,
/// kept pair after pair, lent to the core as a [`SliceEngine`]. The one
/// place the host's engine is named (benches, tests and the element use it).
#[derive(Default)]
pub struct HostEngine {
    words: Vec<i32>,
    floats: Vec<f32>,
    halves: Vec<i16>,
    bytes: Vec<u8>,
}

impl HostEngine {
    /// Empty memory: the first engine asked for sizes it.
    pub fn new() -> Self {
        Self::default()
    }

    /// A core engine in this memory for every tile of `plan` in one window
    /// (the memory grows to the plan's tile width first).
    pub fn engine(&mut self, plan: &Plan) -> Result<SliceEngine<'_>, HostError> {
        let size = MemorySize::for_tile_width(plan.tile_width())
            .ok_or(HostError::Core(reynoldsflow_core::Error::FrameTooLarge))?;
        grow(&mut self.words, size.words, 0);
        grow(&mut self.floats, size.floats, 0.0);
        grow(&mut self.halves, size.halves, 0);
        grow(&mut self.bytes, size.bytes, 0);
        Ok(SliceEngine::new(
            &mut self.words,
            &mut self.floats,
            &mut self.halves,
            &mut self.bytes,
        )?)
    }
}

/// `buffer` at least `len` long (never shrunk: the engine reuses it).
fn grow<T: Clone>(buffer: &mut Vec<T>, len: usize, zero: T) {
    if buffer.len() < len {
        buffer.resize(len, zero);
    }
}

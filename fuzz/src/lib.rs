//! What the fuzz targets share: a reader that hands its bytes out in
//! awkward pieces, and the pixel limit they run under.

use std::io::{self, Read};

use reynoldsflow_host::limits::Limits;

/// A reader over `bytes` whose reads return 1 to 64 bytes at a time (a
/// pattern seeded by `chunking`), with an `Interrupted` error now and
/// then, as pipes and slow disks deliver them.
pub struct Chunked {
    bytes: Vec<u8>,
    at: usize,
    state: u32,
}

impl Chunked {
    /// Read `bytes` in pieces picked by `chunking`.
    pub fn new(bytes: Vec<u8>, chunking: u8) -> Self {
        Self {
            bytes,
            at: 0,
            state: u32::from(chunking) | 0x100,
        }
    }

    fn step(&mut self) -> u32 {
        // xorshift32: a fixed pattern per seed, so crashes reproduce.
        self.state ^= self.state << 13;
        self.state ^= self.state >> 17;
        self.state ^= self.state << 5;
        self.state
    }
}

impl Read for Chunked {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let r = self.step();
        if r % 16 == 0 {
            return Err(io::Error::new(io::ErrorKind::Interrupted, "fuzz"));
        }
        let n = buf
            .len()
            .min(1 + (r >> 8) as usize % 64)
            .min(self.bytes.len() - self.at);
        buf[..n].copy_from_slice(&self.bytes[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

/// A pixel limit of 2²⁰ for the readers: the same checks as the default
/// limit, but a header that passes them allocates megabytes, not the
/// default's 64 MiB, so the fuzzer keeps its pace.
pub fn small_limit() -> Limits {
    Limits::new(1 << 20)
}

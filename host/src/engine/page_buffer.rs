//! Buffers of megabytes in anonymous memory mappings that the kernel may
//! back with 2 MiB pages (Linux's transparent huge pages, asked for with
//! `madvise` where the system leaves them to each mapping).
//!
//! A worker's first pair touches every page of its buffers, and each 4 KiB
//! page is a fault: at 1280×720 the kept magnitudes of per-frame min–max
//! alone are 7.4 MB, 1 800 faults. Touching 8 MiB took 8.5 ms in 4 KiB
//! pages and 1.6 ms in 2 MiB ones on this project's machine (a VM, where a
//! fault is dear); a run of a short clip, and every thread of it, pays that
//! once. Where huge pages are off, the mapping behaves as ordinary memory.

use std::ops::{Deref, DerefMut};

use memmap2::{MmapMut, MmapOptions};

use crate::HostError;

/// Where a result's bytes go, resized by the one who fills it: a `Vec`, or
/// a [`PageBytes`] (the pipeline's stream payloads).
pub trait ByteBuffer {
    /// The buffer as `len` bytes, every one of which the caller overwrites
    /// (what they hold before is unspecified: zeros or earlier bytes).
    /// Fails only when the system refuses the memory.
    fn overwrite(&mut self, len: usize) -> Result<&mut [u8], HostError>;
}

impl ByteBuffer for Vec<u8> {
    fn overwrite(&mut self, len: usize) -> Result<&mut [u8], HostError> {
        // Free when the length is already `len` (a reused buffer).
        self.resize(len, 0);
        Ok(self)
    }
}

/// A byte buffer of varying length in one anonymous mapping (see the
/// module): the stream payloads of `run`, 2.8 MB a 1280×720 frame, a few
/// of them per worker.
#[derive(Default)]
pub(crate) struct PageBytes {
    buffer: PageBuffer,
    len: usize,
}

impl ByteBuffer for PageBytes {
    fn overwrite(&mut self, len: usize) -> Result<&mut [u8], HostError> {
        let bytes = self.buffer.bytes(len)?;
        self.len = len;
        Ok(bytes)
    }
}

impl Deref for PageBytes {
    type Target = [u8];

    fn deref(&self) -> &[u8] {
        self.buffer.room().get(..self.len).unwrap_or_default()
    }
}

impl DerefMut for PageBytes {
    fn deref_mut(&mut self) -> &mut [u8] {
        let len = self.len;
        self.buffer.room_mut().get_mut(..len).unwrap_or_default()
    }
}

/// Zero-initialised memory of at least a given length in one anonymous
/// mapping, grown by remapping (the contents do not survive growth: every
/// user overwrites them).
#[derive(Default)]
pub(crate) struct PageBuffer {
    /// The mapping and where its aligned room starts.
    map: Option<(MmapMut, usize)>,
}

impl PageBuffer {
    /// The first `len` bytes (zero when fresh, else what was last written),
    /// remapped when the room is shorter. Fails only when the system
    /// refuses the memory.
    pub(crate) fn bytes(&mut self, len: usize) -> Result<&mut [u8], HostError> {
        if self.room().len() < len {
            self.map = Some(map_anonymous(len)?);
        }
        Ok(&mut self.room_mut()[..len])
    }

    /// At least `len` `f32`s, as [`Self::bytes`].
    pub(crate) fn floats(&mut self, len: usize) -> Result<&mut [f32], HostError> {
        let bytes = len.checked_mul(size_of::<f32>()).ok_or_else(refused)?;
        // The room starts on a page, so it is aligned for `f32`.
        Ok(bytemuck::cast_slice_mut(self.bytes(bytes)?))
    }

    /// The whole aligned room (empty before the first mapping).
    fn room(&self) -> &[u8] {
        self.map.as_ref().map_or(&[], |(map, at)| &map[*at..])
    }

    fn room_mut(&mut self) -> &mut [u8] {
        self.map
            .as_mut()
            .map_or(&mut [], |(map, at)| &mut map[*at..])
    }
}

/// The error of memory the system refuses.
fn refused() -> HostError {
    HostError::io("anonymous memory", std::io::ErrorKind::OutOfMemory.into())
}

/// 2 MiB: the huge page of x86-64 and aarch64 (4 KiB granules).
const HUGE_PAGE: usize = 2 << 20;

/// A fresh anonymous mapping with room for `bytes` from a 2 MiB boundary,
/// whole huge pages, with the kernel asked to back it with them; and where
/// the room starts. (A huge page backs only an aligned 2 MiB of a mapping,
/// and mappings start on 4 KiB pages: a 2.8 MB one unaligned would get one
/// huge page at most.) The part before the boundary is never touched, so
/// it costs address space, not memory.
fn map_anonymous(bytes: usize) -> Result<(MmapMut, usize), HostError> {
    let room = bytes
        .max(1)
        .checked_next_multiple_of(HUGE_PAGE)
        .ok_or_else(refused)?;
    let map = MmapOptions::new()
        .len(room.checked_add(HUGE_PAGE).ok_or_else(refused)?)
        .map_anon()
        .map_err(|e| HostError::io("anonymous memory", e))?;
    #[cfg(target_os = "linux")]
    {
        // Advice only: a kernel without huge pages keeps 4 KiB ones.
        let _ = map.advise(memmap2::Advice::HugePage);
    }
    let start = map.as_ptr() as usize;
    let offset = start.next_multiple_of(HUGE_PAGE) - start;
    Ok((map, offset))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_take_the_length_asked_for() {
        let mut bytes = PageBytes::default();
        assert!(bytes.is_empty());
        bytes.overwrite(5).unwrap().copy_from_slice(b"hello");
        assert_eq!(&*bytes, b"hello");
        bytes.overwrite(2).unwrap();
        assert_eq!(&*bytes, b"he", "shorter within the mapping");
        let long = bytes.overwrite(5 << 20).unwrap();
        assert_eq!(long.len(), 5 << 20);
        long[(5 << 20) - 1] = 9;
        assert_eq!(bytes.last(), Some(&9));
        let mut vec = vec![1u8, 2, 3];
        assert_eq!(vec.overwrite(2).unwrap(), [1, 2]);
        assert_eq!(vec.overwrite(4).unwrap(), [1, 2, 0, 0]);
    }

    #[test]
    fn grows_keeps_its_length_and_starts_at_zero() {
        let mut buffer = PageBuffer::default();
        let floats = buffer.floats(3).unwrap();
        assert_eq!(floats, [0.0; 3]);
        floats[2] = 7.5;
        assert_eq!(buffer.floats(3).unwrap()[2], 7.5, "kept while it fits");
        let big = buffer.floats(3 << 20).unwrap();
        assert_eq!(big.len(), 3 << 20);
        assert!(big.iter().all(|&f| f == 0.0), "a new mapping is zero");
        assert_eq!(buffer.floats(0).unwrap().len(), 0);
    }
}

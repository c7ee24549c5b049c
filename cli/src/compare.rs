//! Recomputed frames against captured ones, byte by byte (`reynoldsflow
//! verify`). [`Comparison`] is the writer `run`'s pipeline streams its
//! RGB24 frames into, so what is compared is exactly what `run --out -`
//! would have written; each frame is set beside the capture's next one as
//! it arrives, and nothing of the sequence is held in memory.

use std::io::{self, Write};

use reynoldsflow_host::HostError;
use reynoldsflow_host::outputs::y4m_frame;

use crate::captured::{Captured, Layout};

/// One differing byte: where, and both values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Difference {
    /// Frame of the capture (from 0): result `frame`, of input frames
    /// `frame` and `frame + 1`.
    pub frame: usize,
    /// Column.
    pub x: usize,
    /// Row.
    pub y: usize,
    /// Channel, in the capture's [`Layout`].
    pub channel: usize,
    /// The recomputed byte.
    pub expected: u8,
    /// The captured byte.
    pub captured: u8,
}

impl Difference {
    /// By how much the bytes differ.
    pub fn amount(&self) -> u8 {
        self.expected.abs_diff(self.captured)
    }
}

/// What the frames compared so far hold. A pixel differs when any of its
/// channels does; "first" is in frame order, then row by row, then by
/// channel.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Tally {
    /// Frames compared.
    pub frames: usize,
    /// Pixels with some channel differing at all.
    pub pixels_differing: u64,
    /// Pixels with some channel differing by more than the tolerance.
    pub pixels_over_tolerance: u64,
    /// The largest difference of any byte.
    pub max_diff: u8,
    /// The first differing byte.
    pub first: Option<Difference>,
    /// The first byte differing by more than the tolerance.
    pub first_over: Option<Difference>,
}

impl Tally {
    /// Compare frame `index`: `expected` and `captured`, both in `layout`,
    /// `width` pixels to a row.
    pub fn add_frame(
        &mut self,
        index: usize,
        expected: &[u8],
        captured: &[u8],
        (width, layout): (usize, Layout),
        tolerance: u8,
    ) {
        assert_eq!(expected.len(), captured.len(), "frames of one size");
        self.frames += 1;
        // Nearly every frame of a good device is identical: one memcmp.
        if expected == captured {
            return;
        }
        let pixels = expected.len() / 3;
        for pixel in 0..pixels {
            let (mut differs, mut over) = (false, false);
            for channel in 0..3 {
                let i = layout.index(pixel, channel, pixels);
                let (e, c) = (expected[i], captured[i]);
                if e == c {
                    continue;
                }
                let diff = Difference {
                    frame: index,
                    x: pixel % width,
                    y: pixel / width,
                    channel,
                    expected: e,
                    captured: c,
                };
                differs = true;
                self.max_diff = self.max_diff.max(diff.amount());
                self.first.get_or_insert(diff);
                if diff.amount() > tolerance {
                    over = true;
                    self.first_over.get_or_insert(diff);
                }
            }
            self.pixels_differing += u64::from(differs);
            self.pixels_over_tolerance += u64::from(over);
        }
    }
}

/// What a whole comparison found.
#[derive(Debug)]
pub struct Outcome {
    /// The frames compared.
    pub tally: Tally,
    /// Frames the input gives (results of `run`): what the capture should hold.
    pub expected_frames: usize,
    /// Frames read from the capture (all of it, unless `error`).
    pub captured_frames: usize,
    /// The capture could not be read to its end: frame `captured_frames`
    /// failed.
    pub error: Option<HostError>,
}

impl Outcome {
    /// Whether the capture is the recomputed stream, within the tolerance.
    pub fn passed(&self) -> bool {
        self.error.is_none()
            && self.expected_frames == self.captured_frames
            && self.tally.pixels_over_tolerance == 0
    }
}

/// The writer the recomputed RGB24 stream goes into: it splits the stream
/// into frames and compares each with the capture's next frame.
pub struct Comparison<'a> {
    captured: &'a mut Captured,
    width: usize,
    tolerance: u8,
    /// The recomputed frame being received.
    expected: Vec<u8>,
    /// The capture's frame.
    got: Vec<u8>,
    /// Recomputed frames received.
    results: usize,
    /// The capture ended before the recomputed frames: they are counted
    /// (for the message), no longer compared.
    captured_ended: bool,
    error: Option<HostError>,
    tally: Tally,
}

impl<'a> Comparison<'a> {
    /// Compare against `captured`, frames `width` pixels wide, allowing
    /// each byte to differ by `tolerance`.
    pub fn new(captured: &'a mut Captured, width: usize, tolerance: u8) -> Self {
        Self {
            captured,
            width,
            tolerance,
            expected: Vec::new(),
            got: Vec::new(),
            results: 0,
            captured_ended: false,
            error: None,
            tally: Tally::default(),
        }
    }

    /// One whole recomputed frame has arrived. A capture that cannot be
    /// read is read no further (the error is kept), but the recomputed
    /// frames are still counted, so the report says how many there are.
    fn frame_received(&mut self) {
        let index = self.results;
        self.results += 1;
        if self.captured_ended || self.error.is_some() {
            return;
        }
        match self.captured.next_frame(&mut self.got) {
            Ok(true) => {
                let layout = self.captured.format().layout();
                // Y4M frames are compared as `run --format y4m` writes them:
                // the same conversion of the same RGB bytes.
                let converted;
                let expected = match layout {
                    Layout::Rgb => &self.expected[..],
                    Layout::Ycbcr444 => {
                        converted = y4m_frame(&self.expected);
                        &converted[b"FRAME\n".len()..]
                    }
                };
                let shape = (self.width, layout);
                self.tally
                    .add_frame(index, expected, &self.got, shape, self.tolerance);
            }
            Ok(false) => self.captured_ended = true,
            Err(e) => self.error = Some(e),
        }
    }

    /// After the last recomputed frame: read the capture to its end (its
    /// frames beyond the input's are counted, and a partial one is named).
    pub fn finish(mut self) -> Outcome {
        while self.error.is_none() && !self.captured_ended {
            match self.captured.next_frame(&mut self.got) {
                Ok(true) => {}
                Ok(false) => self.captured_ended = true,
                Err(e) => self.error = Some(e),
            }
        }
        Outcome {
            tally: self.tally,
            expected_frames: self.results,
            captured_frames: self.captured.frames_read(),
            error: self.error,
        }
    }
}

impl Write for Comparison<'_> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let frame = self.captured.frame_bytes();
        let mut rest = buf;
        while !rest.is_empty() {
            let take = (frame - self.expected.len()).min(rest.len());
            self.expected.extend_from_slice(&rest[..take]);
            rest = &rest[take..];
            if self.expected.len() == frame {
                self.frame_received();
                self.expected.clear();
            }
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tally_counts_pixels_and_finds_the_first_in_pixel_order() {
        // 2x2 frames. RGB: pixel 3 (x 1, y 1) channel B by 2; pixel 1 channel G by 1.
        let expected = [10u8; 12];
        let mut captured = expected;
        captured[3 * 3 + 2] = 12;
        captured[3 + 1] = 11;
        let mut tally = Tally::default();
        tally.add_frame(0, &expected, &expected, (2, Layout::Rgb), 0);
        tally.add_frame(1, &expected, &captured, (2, Layout::Rgb), 1);
        assert_eq!(tally.frames, 2);
        assert_eq!(
            (tally.pixels_differing, tally.pixels_over_tolerance),
            (2, 1)
        );
        assert_eq!(tally.max_diff, 2);
        let first = tally.first.unwrap();
        assert_eq!((first.frame, first.x, first.y, first.channel), (1, 1, 0, 1));
        let over = tally.first_over.unwrap();
        assert_eq!((over.x, over.y, over.channel, over.amount()), (1, 1, 2, 2));

        // Planar: byte 4 + 3 is Cb (plane 1) of pixel 3 (x 1, y 1).
        let mut captured = expected;
        captured[4 + 3] = 9;
        let mut tally = Tally::default();
        tally.add_frame(5, &expected, &captured, (2, Layout::Ycbcr444), 0);
        let first = tally.first.unwrap();
        assert_eq!((first.frame, first.x, first.y, first.channel), (5, 1, 1, 1));
        assert_eq!(tally.first_over, Some(first));
    }
}

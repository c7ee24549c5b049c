//! Frames in, pairs out: which frame pairs with which, and which label
//! each output carries, for every front end that gets frames one by one
//! (the GStreamer element, the ROS 2 node, Python's `Stream`). A label is
//! whatever the front end gives each output (a buffer's timestamps, a
//! message header, an index, nothing); the computation is a closure, so
//! the rules are tested alone.
//!
//! [`FirstFrame`] says what a stream's first frame, which has no pair of
//! its own, gives: with `drop` (the default) N frames give N − 1 outputs,
//! result n labelled with frame n, the pair's first (SPEC §5), as
//! `reynoldsflow run` labels it; `repeat` and `black` give one output per
//! frame, each labelled with its frame, the first a copy of result 0 or an
//! all-zero image. A stream of one frame has no result 0 to copy: with
//! `repeat` its frame gets the result of the frame paired with itself (no
//! motion), so every frame still gets its output.
//!
//! A stream restarts (its next frame is a first frame again) when the size
//! or the encoding changes, or a stamp goes back (a bag played again, a
//! camera restarted), and ends where the front end says ([`PairStream::end`]:
//! the end of the input, a gap in it, new caps): no pair spans a restart
//! or an end, which would be no motion of the scene.

use std::fmt;
use std::sync::Arc;

use crate::Gray;
pub use crate::settings::FirstFrame;

/// A frame's luma as a stream holds it: a [`Gray`], or an `Arc<Gray>` for
/// a front end that hands pairs to threads which compute them while the
/// stream goes on (the GStreamer element).
pub trait Luma {
    /// `(width, height)`.
    fn size(&self) -> (usize, usize);
}

impl Luma for Gray {
    fn size(&self) -> (usize, usize) {
        Gray::size(self)
    }
}

impl Luma for Arc<Gray> {
    fn size(&self) -> (usize, usize) {
        Gray::size(self)
    }
}

/// A frame as the stream sees it.
pub struct Frame<L, G = Gray> {
    /// Its luma.
    pub gray: G,
    /// The encoding it came in (a name, for messages): a new one restarts.
    pub encoding: &'static str,
    /// When it was taken, in nanoseconds, where known: an earlier stamp
    /// than the previous frame's restarts.
    pub stamp: Option<i128>,
    /// What its output carries.
    pub label: L,
}

/// Why a stream restarted.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Restart {
    /// A frame of another size.
    Size {
        /// The stream's size.
        from: (usize, usize),
        /// The new frame's.
        to: (usize, usize),
    },
    /// A frame in another encoding.
    Encoding {
        /// The stream's encoding.
        from: &'static str,
        /// The new frame's.
        to: &'static str,
    },
    /// A stamp earlier than the previous frame's (nanoseconds).
    StampBackwards {
        /// The previous frame's stamp.
        from: i128,
        /// The new frame's.
        to: i128,
    },
}

/// Nanoseconds as seconds with nine decimals.
fn seconds(ns: i128) -> String {
    let sign = if ns < 0 { "-" } else { "" };
    let ns = ns.unsigned_abs();
    format!("{sign}{}.{:09}", ns / 1_000_000_000, ns % 1_000_000_000)
}

impl fmt::Display for Restart {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Size { from, to } => write!(
                f,
                "the size changed from {}x{} to {}x{}",
                from.0, from.1, to.0, to.1
            ),
            Self::Encoding { from, to } => {
                write!(f, "the encoding changed from {from} to {to}")
            }
            Self::StampBackwards { from, to } => {
                write!(
                    f,
                    "the stamp went back from {} to {}",
                    seconds(*from),
                    seconds(*to)
                )
            }
        }
    }
}

/// One output, in stream order.
#[derive(Debug, PartialEq)]
pub enum Output<R, L> {
    /// `first-frame black`: an all-zero image of this size.
    Black {
        /// Frame width.
        width: usize,
        /// Frame height.
        height: usize,
        /// Its frame's label.
        label: L,
    },
    /// A pair's result, with the labels it goes out with, in order (two
    /// for the copy of `first-frame repeat`).
    Result {
        /// What the computation gave.
        result: R,
        /// One per output.
        labels: Vec<L>,
    },
}

/// What one frame gives.
#[derive(Debug, PartialEq)]
pub struct Step<R, L> {
    /// The stream restarted at this frame (it is a first frame again).
    pub restart: Option<Restart>,
    /// Its outputs, in order: the end of the stream before a restart
    /// ([`PairStream::end`]), then this frame's.
    pub outputs: Vec<Output<R, L>>,
}

/// The frame a pair starts with.
struct Prev<L, G> {
    gray: G,
    encoding: &'static str,
    stamp: Option<i128>,
    /// Its label until an output took it.
    label: Option<L>,
}

/// The pairing state of one stream.
pub struct PairStream<L, G = Gray> {
    first_frame: FirstFrame,
    prev: Option<Prev<L, G>>,
    /// The frame a pair no longer needs, for the front end to fill again.
    spare: Option<G>,
}

impl<L, G: Luma> PairStream<L, G> {
    /// A stream that has seen no frame.
    pub fn new(first_frame: FirstFrame) -> Self {
        Self {
            first_frame,
            prev: None,
            spare: None,
        }
    }

    /// What the first frame of each stream gives from now on.
    pub fn set_first_frame(&mut self, first_frame: FirstFrame) {
        self.first_frame = first_frame;
    }

    /// What the first frame of a stream gives.
    pub fn first_frame(&self) -> FirstFrame {
        self.first_frame
    }

    /// A frame to fill for the next [`Self::push`] (its memory reused):
    /// the one the last pair no longer needs, if any.
    pub fn take_spare(&mut self) -> Option<G> {
        self.spare.take()
    }

    /// Take `frame`: pair it with the previous one through `compute(prev,
    /// next)`, unless it starts a stream (the first, or after a restart or
    /// an end). A failed computation ends the stream (the next frame is a
    /// first frame) and is returned.
    pub fn push<R, E>(
        &mut self,
        frame: Frame<L, G>,
        mut compute: impl FnMut(&G, &G) -> Result<R, E>,
    ) -> Result<Step<R, L>, E> {
        let restart = self.prev.as_ref().and_then(|p| restart(p, &frame));
        let mut outputs = Vec::new();
        if restart.is_some() {
            outputs.extend(self.end(&mut compute)?);
        }
        let Some(mut prev) = self.prev.take() else {
            let label = match self.first_frame {
                FirstFrame::Black => {
                    let (width, height) = frame.gray.size();
                    outputs.push(Output::Black {
                        width,
                        height,
                        label: frame.label,
                    });
                    None
                }
                FirstFrame::Drop | FirstFrame::Repeat => Some(frame.label),
            };
            self.prev = Some(Prev {
                gray: frame.gray,
                encoding: frame.encoding,
                stamp: frame.stamp,
                label,
            });
            return Ok(Step { restart, outputs });
        };
        let result = compute(&prev.gray, &frame.gray)?;
        let mut labels = Vec::with_capacity(2);
        let next_label = match self.first_frame {
            FirstFrame::Drop => {
                labels.extend(prev.label.take());
                Some(frame.label)
            }
            FirstFrame::Repeat | FirstFrame::Black => {
                // A first frame of `repeat` still waits for its copy.
                labels.extend(prev.label.take());
                labels.push(frame.label);
                None
            }
        };
        outputs.push(Output::Result { result, labels });
        self.spare = Some(std::mem::replace(&mut prev.gray, frame.gray));
        prev.encoding = frame.encoding;
        prev.stamp = frame.stamp;
        prev.label = next_label;
        self.prev = Some(prev);
        Ok(Step {
            restart: None,
            outputs,
        })
    }

    /// The stream ends here (the end of the input, a gap, new caps): the
    /// output its last frame still owes (a lone first frame of `repeat`,
    /// given the result of the frame paired with itself), and the next
    /// frame is a first frame.
    pub fn end<R, E>(
        &mut self,
        mut compute: impl FnMut(&G, &G) -> Result<R, E>,
    ) -> Result<Option<Output<R, L>>, E> {
        let Some(mut prev) = self.prev.take() else {
            return Ok(None);
        };
        let owed = match (self.first_frame, prev.label.take()) {
            (FirstFrame::Repeat, Some(label)) => Some(Output::Result {
                result: compute(&prev.gray, &prev.gray)?,
                labels: vec![label],
            }),
            _ => None,
        };
        self.spare = Some(prev.gray);
        Ok(owed)
    }

    /// Forget the stream without an output (a flush: its data is
    /// discarded); the next frame is a first frame.
    pub fn reset(&mut self) {
        if let Some(prev) = self.prev.take() {
            self.spare = Some(prev.gray);
        }
    }
}

/// Why `next` cannot pair with `prev`, if it cannot.
fn restart<L, G: Luma>(prev: &Prev<L, G>, next: &Frame<L, G>) -> Option<Restart> {
    if prev.gray.size() != next.gray.size() {
        return Some(Restart::Size {
            from: prev.gray.size(),
            to: next.gray.size(),
        });
    }
    if prev.encoding != next.encoding {
        return Some(Restart::Encoding {
            from: prev.encoding,
            to: next.encoding,
        });
    }
    match (prev.stamp, next.stamp) {
        (Some(from), Some(to)) if to < from => Some(Restart::StampBackwards { from, to }),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(id: u8, width: usize, encoding: &'static str, sec: i128) -> Frame<String> {
        Frame {
            gray: Gray {
                width,
                height: 1,
                pixels: vec![id; width],
            },
            encoding,
            stamp: Some(sec * 1_000_000_000),
            label: format!("f{id}"),
        }
    }

    fn pair(a: &Gray, b: &Gray) -> Result<(u8, u8), ()> {
        Ok((a.pixels[0], b.pixels[0]))
    }

    /// The outputs as `prev next @ label`, `black@label`.
    fn describe(outputs: Vec<Output<(u8, u8), String>>, out: &mut Vec<String>) {
        for output in outputs {
            match output {
                Output::Black { label, .. } => out.push(format!("black@{label}")),
                Output::Result {
                    result: (a, b),
                    labels,
                } => out.extend(labels.iter().map(|l| format!("{a}{b}@{l}"))),
            }
        }
    }

    /// Push frames `(id, width, encoding, sec)`, then end: the outputs and
    /// the restarts.
    fn run(mode: FirstFrame, frames: &[(u8, usize, &'static str, i128)]) -> (Vec<String>, usize) {
        let mut stream = PairStream::new(mode);
        let (mut out, mut restarts) = (Vec::new(), 0);
        for &(id, w, e, sec) in frames {
            let step = stream.push(frame(id, w, e, sec), pair).unwrap();
            restarts += usize::from(step.restart.is_some());
            describe(step.outputs, &mut out);
        }
        describe(stream.end(pair).unwrap().into_iter().collect(), &mut out);
        (out, restarts)
    }

    const M: &str = "mono8";

    #[test]
    fn drop_gives_n_minus_1_outputs_labelled_with_the_first_frame() {
        let (out, restarts) = run(
            FirstFrame::Drop,
            &[(0, 4, M, 0), (1, 4, M, 1), (2, 4, M, 2)],
        );
        assert_eq!(out, ["01@f0", "12@f1"]);
        assert_eq!(restarts, 0);
        assert!(run(FirstFrame::Drop, &[(0, 4, M, 0)]).0.is_empty());
    }

    #[test]
    fn repeat_and_black_give_one_output_per_frame() {
        let frames = [(0, 4, M, 0), (1, 4, M, 1), (2, 4, M, 2)];
        assert_eq!(
            run(FirstFrame::Repeat, &frames).0,
            ["01@f0", "01@f1", "12@f2"]
        );
        assert_eq!(
            run(FirstFrame::Black, &frames).0,
            ["black@f0", "01@f1", "12@f2"]
        );
        // One frame: its own pair (no motion), or black.
        assert_eq!(run(FirstFrame::Repeat, &frames[..1]).0, ["00@f0"]);
        assert_eq!(run(FirstFrame::Black, &frames[..1]).0, ["black@f0"]);
    }

    #[test]
    fn size_encoding_and_stamps_going_back_restart_the_pair() {
        let frames = [
            (0, 4, M, 0),
            (1, 4, M, 1),
            (2, 6, M, 2), // new size
            (3, 6, M, 3),
            (4, 6, "bgr8", 4), // new encoding
            (5, 6, "bgr8", 5),
            (6, 6, "bgr8", 1), // back in time
            (7, 6, "bgr8", 1), // the same stamp is no step back
        ];
        let (out, restarts) = run(FirstFrame::Drop, &frames);
        assert_eq!(out, ["01@f0", "23@f2", "45@f4", "67@f6"]);
        assert_eq!(restarts, 3);
        // A restart is a first frame again for every mode.
        let (out, _) = run(FirstFrame::Black, &frames[..4]);
        assert_eq!(out, ["black@f0", "01@f1", "black@f2", "23@f3"]);
        // A lone frame before a restart still gets its output with repeat.
        let lone = [(0, 4, M, 0), (1, 6, M, 1), (2, 6, M, 2)];
        let (out, restarts) = run(FirstFrame::Repeat, &lone);
        assert_eq!(out, ["00@f0", "12@f1", "12@f2"]);
        assert_eq!(restarts, 1);
    }

    #[test]
    fn an_end_breaks_the_chain_and_a_reset_forgets() {
        let mut stream = PairStream::new(FirstFrame::Repeat);
        let mut out = Vec::new();
        for (id, sec) in [(0, 0), (1, 1)] {
            describe(
                stream.push(frame(id, 4, M, sec), pair).unwrap().outputs,
                &mut out,
            );
        }
        // A gap: nothing owed (frame 1 had its output), no pair (1, 2).
        assert!(stream.end(pair).unwrap().is_none());
        describe(
            stream.push(frame(2, 4, M, 2), pair).unwrap().outputs,
            &mut out,
        );
        describe(stream.end(pair).unwrap().into_iter().collect(), &mut out);
        assert_eq!(out, ["01@f0", "01@f1", "22@f2"]);
        // A flush: frame 3 is forgotten, owed nothing.
        stream.push(frame(3, 4, M, 3), pair).unwrap();
        stream.reset();
        assert!(stream.end(pair).unwrap().is_none());
        // Its memory comes back to be filled again.
        assert_eq!(stream.take_spare().unwrap().pixels, [3; 4]);
        assert!(stream.take_spare().is_none());
    }

    #[test]
    fn a_failed_pair_ends_the_stream() {
        let mut stream = PairStream::new(FirstFrame::Drop);
        stream.push(frame(0, 4, M, 0), pair).unwrap();
        let err = stream.push(frame(1, 4, M, 1), |_, _| Err::<(u8, u8), _>("refused"));
        assert_eq!(err.err(), Some("refused"));
        let step = stream.push(frame(2, 4, M, 2), pair).unwrap();
        assert!(step.outputs.is_empty(), "frame 2 starts a new stream");
        let step = stream.push(frame(3, 4, M, 3), pair).unwrap();
        let mut out = Vec::new();
        describe(step.outputs, &mut out);
        assert_eq!(out, ["23@f2"]);
    }

    #[test]
    fn labels_may_be_anything_and_stamps_absent() {
        let mut stream: PairStream<()> = PairStream::new(FirstFrame::Drop);
        let gray = |v| Gray::new(2, 1, vec![v; 2]).unwrap();
        let frame = |v| Frame {
            gray: gray(v),
            encoding: "gray",
            stamp: None,
            label: (),
        };
        assert!(stream.push(frame(1), pair).unwrap().outputs.is_empty());
        let step = stream.push(frame(2), pair).unwrap();
        assert_eq!(
            step.outputs,
            [Output::Result {
                result: (1, 2),
                labels: vec![()]
            }]
        );
    }

    #[test]
    fn restarts_say_what_changed() {
        let r = Restart::StampBackwards {
            from: 5_000_000_000,
            to: 4_000_000_005,
        };
        assert_eq!(
            r.to_string(),
            "the stamp went back from 5.000000000 to 4.000000005"
        );
        let r = Restart::Size {
            from: (4, 3),
            to: (8, 6),
        };
        assert_eq!(r.to_string(), "the size changed from 4x3 to 8x6");
        let r = Restart::Encoding {
            from: "mono8",
            to: "bgr8",
        };
        assert_eq!(r.to_string(), "the encoding changed from mono8 to bgr8");
    }
}

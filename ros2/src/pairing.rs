//! Frames to pairs: which frame pairs with which, and which header each
//! output carries. The rules are the GStreamer element's: with
//! `first-frame drop` (the default) N frames give N − 1 outputs, result n
//! labelled with frame n, the pair's first (SPEC §5), as `reynoldsflow run`
//! labels it; `repeat` and `black` give one output per frame, each labelled
//! with its frame, the first a copy of result 0 or an all-zero image.
//!
//! A stream restarts (its next frame is a first frame again) when the size
//! or the encoding changes, or a stamp goes backwards (a bag played again, a
//! camera restarted): a pair across such a change would be no motion of the
//! scene. Nothing here knows about DDS or the engine: the computation is a
//! closure, so the rules are tested alone.

use std::fmt;

use reynoldsflow_host::Gray;
pub use reynoldsflow_host::settings::FirstFrame;

use crate::luma::Encoding;
use crate::msg::{Header, Time};

/// A frame as the pairing sees it.
pub struct Frame {
    /// Its luma.
    pub gray: Gray,
    /// The encoding it came in.
    pub encoding: Encoding,
    /// Its header, given to the output it labels.
    pub header: Header,
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
        from: Encoding,
        /// The new frame's.
        to: Encoding,
    },
    /// A stamp earlier than the previous frame's.
    StampBackwards {
        /// The previous frame's stamp.
        from: Time,
        /// The new frame's.
        to: Time,
    },
}

impl fmt::Display for Restart {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Size { from, to } => write!(
                f,
                "the size changed from {}x{} to {}x{}",
                from.0, from.1, to.0, to.1
            ),
            Self::Encoding { from, to } => write!(
                f,
                "the encoding changed from {} to {}",
                from.name(),
                to.name()
            ),
            Self::StampBackwards { from, to } => {
                write!(f, "the stamp went back from {from} to {to}")
            }
        }
    }
}

/// What one frame gives.
#[derive(Debug, Default)]
pub struct Step<R> {
    /// The stream restarted at this frame (it is a first frame).
    pub restart: Option<Restart>,
    /// `first-frame black`: an all-zero image of the frame's size, with its header.
    pub black: Option<(usize, usize, Header)>,
    /// The pair's result and the headers it goes out with, in order (two
    /// for the copy of `first-frame repeat`).
    pub result: Option<(R, Vec<Header>)>,
}

/// The frame a pair starts with.
struct Prev {
    frame: Frame,
    /// `repeat`: this frame still waits for its output (a copy of the
    /// result of the pair it starts).
    awaits_copy: bool,
}

/// The pairing state of one input topic.
pub struct Pairing {
    first_frame: FirstFrame,
    prev: Option<Prev>,
}

impl Pairing {
    /// A stream that has seen no frame.
    pub fn new(first_frame: FirstFrame) -> Self {
        Self {
            first_frame,
            prev: None,
        }
    }

    /// Take `frame`: pair it with the previous one through `compute(prev,
    /// next)` unless it starts a stream. A failed computation ends the
    /// stream (the next frame is a first frame) and is returned.
    pub fn push<R, E>(
        &mut self,
        frame: Frame,
        compute: impl FnOnce(&Gray, &Gray) -> Result<R, E>,
    ) -> Result<Step<R>, E> {
        let restart = self.prev.as_ref().and_then(|p| restart(&p.frame, &frame));
        let prev = match self.prev.take() {
            Some(prev) if restart.is_none() => prev,
            _ => {
                let black = (self.first_frame == FirstFrame::Black)
                    .then(|| (frame.gray.width, frame.gray.height, frame.header.clone()));
                self.prev = Some(Prev {
                    frame,
                    awaits_copy: self.first_frame == FirstFrame::Repeat,
                });
                return Ok(Step {
                    restart,
                    black,
                    result: None,
                });
            }
        };
        let result = compute(&prev.frame.gray, &frame.gray)?;
        let mut headers = Vec::with_capacity(2);
        if prev.awaits_copy {
            headers.push(prev.frame.header.clone());
        }
        headers.push(match self.first_frame {
            FirstFrame::Drop => prev.frame.header,
            FirstFrame::Repeat | FirstFrame::Black => frame.header.clone(),
        });
        self.prev = Some(Prev {
            frame,
            awaits_copy: false,
        });
        Ok(Step {
            restart: None,
            black: None,
            result: Some((result, headers)),
        })
    }
}

/// Why `next` cannot pair with `prev`, if it cannot.
fn restart(prev: &Frame, next: &Frame) -> Option<Restart> {
    let size = |f: &Frame| (f.gray.width, f.gray.height);
    if size(prev) != size(next) {
        return Some(Restart::Size {
            from: size(prev),
            to: size(next),
        });
    }
    if prev.encoding != next.encoding {
        return Some(Restart::Encoding {
            from: prev.encoding,
            to: next.encoding,
        });
    }
    let (from, to) = (prev.header.stamp, next.header.stamp);
    (to < from).then_some(Restart::StampBackwards { from, to })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(id: u8, width: usize, encoding: Encoding, sec: i32) -> Frame {
        Frame {
            gray: Gray {
                width,
                height: 1,
                pixels: vec![id; width],
            },
            encoding,
            header: Header {
                stamp: Time { sec, nanosec: 0 },
                frame_id: format!("f{id}"),
            },
        }
    }

    /// Push frames `(id, width, encoding, sec)`; the outputs as
    /// `(prev id, next id, label)`, `black` for the first-frame image, and
    /// the restarts.
    fn run(mode: FirstFrame, frames: &[(u8, usize, Encoding, i32)]) -> (Vec<String>, usize) {
        let mut pairing = Pairing::new(mode);
        let (mut out, mut restarts) = (Vec::new(), 0);
        for &(id, w, e, sec) in frames {
            let step = pairing
                .push(frame(id, w, e, sec), |a, b| {
                    Ok::<_, ()>((a.pixels[0], b.pixels[0]))
                })
                .unwrap();
            restarts += usize::from(step.restart.is_some());
            if let Some((_, _, h)) = step.black {
                out.push(format!("black@{}", h.frame_id));
            }
            if let Some(((a, b), headers)) = step.result {
                out.extend(headers.iter().map(|h| format!("{a}{b}@{}", h.frame_id)));
            }
        }
        (out, restarts)
    }

    const M: Encoding = Encoding::Mono8;

    #[test]
    fn drop_gives_n_minus_1_outputs_labelled_with_the_first_frame() {
        let (out, restarts) = run(
            FirstFrame::Drop,
            &[(0, 4, M, 0), (1, 4, M, 1), (2, 4, M, 2)],
        );
        assert_eq!(out, ["01@f0", "12@f1"]);
        assert_eq!(restarts, 0);
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
    }

    #[test]
    fn size_encoding_and_stamps_going_back_restart_the_pair() {
        let frames = [
            (0, 4, M, 0),
            (1, 4, M, 1),
            (2, 6, M, 2), // new size
            (3, 6, M, 3),
            (4, 6, Encoding::Bgr8, 4), // new encoding
            (5, 6, Encoding::Bgr8, 5),
            (6, 6, Encoding::Bgr8, 1), // back in time
            (7, 6, Encoding::Bgr8, 1), // the same stamp is no step back
        ];
        let (out, restarts) = run(FirstFrame::Drop, &frames);
        assert_eq!(out, ["01@f0", "23@f2", "45@f4", "67@f6"]);
        assert_eq!(restarts, 3);
        // A restart is a first frame again for every mode.
        let (out, _) = run(FirstFrame::Black, &frames[..4]);
        assert_eq!(out, ["black@f0", "01@f1", "black@f2", "23@f3"]);
    }

    #[test]
    fn a_failed_pair_ends_the_stream() {
        let mut pairing = Pairing::new(FirstFrame::Drop);
        let ok = |a: &Gray, b: &Gray| Ok::<_, &str>((a.pixels[0], b.pixels[0]));
        pairing.push(frame(0, 4, M, 0), ok).unwrap();
        let err = pairing.push(frame(1, 4, M, 1), |_, _| Err::<(u8, u8), _>("refused"));
        assert_eq!(err.err(), Some("refused"));
        let step = pairing.push(frame(2, 4, M, 2), ok).unwrap();
        assert!(step.result.is_none(), "frame 2 starts a new stream");
        let step = pairing.push(frame(3, 4, M, 3), ok).unwrap();
        assert_eq!(step.result.map(|r| r.0), Some((2, 3)));
    }

    #[test]
    fn restarts_say_what_changed() {
        let r = Restart::StampBackwards {
            from: Time { sec: 5, nanosec: 0 },
            to: Time { sec: 4, nanosec: 5 },
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
    }
}

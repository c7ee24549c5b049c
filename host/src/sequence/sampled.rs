//! Which frames of an input make pairs, and at what size: `--step K` and
//! `--fps F` pick frames, `--resize WxH` and `--short-side N` resize the
//! frames picked (by [`reynoldsflow_cues::resample`], one integer
//! definition, docs/resample.md), all before any pair is formed. Pairs are
//! then consecutive picked frames: with `--step 2`, frames (0, 2), (2, 4), ….
//!
//! [`FramePlan::wrap`] puts a [`Sampled`] source in front of any
//! [`FrameSource`]; the Python package picks from its arrays with the same
//! [`Picker`] and resizes with the same [`FrameSize`] and resampler.

use reynoldsflow_cues::resample::{MAX_SIDE, Resize};

use super::{Frame, FrameSource};
use crate::limits::Limits;
use crate::settings::Setting;
use crate::{Gray, HostError};

/// A frame rate in frames per second, as an exact ratio `num / den`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rate {
    /// Numerator, at least 1.
    pub num: u32,
    /// Denominator, at least 1.
    pub den: u32,
}

impl Rate {
    /// The rate `num / den`, both at least 1.
    pub fn new(num: u32, den: u32) -> Option<Self> {
        (num > 0 && den > 0).then_some(Self { num, den })
    }

    /// As text: `10`, or `30000/1001`.
    pub fn text(self) -> String {
        if self.den == 1 {
            self.num.to_string()
        } else {
            format!("{}/{}", self.num, self.den)
        }
    }
}

/// Parse `--fps`: a positive decimal (`10`, `29.97`) or a ratio (`30000/1001`).
pub fn parse_rate(s: &str) -> Result<Rate, String> {
    let usage =
        "expected frames per second above 0, as a decimal or a ratio (e.g. 10, 29.97, 30000/1001)";
    let (num, den) = crate::settings::parse_ratio(s).map_err(|e| format!("{e}; {usage}"))?;
    Rate::new(num, den).ok_or_else(|| format!("{s} frames per second; {usage}"))
}

/// Which frames make pairs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Sampling {
    /// Every frame (no `--step` or `--fps`).
    #[default]
    Every,
    /// Frames `0, K, 2K, …` (`--step K`, K ≥ 1).
    Step(u64),
    /// Frames at this rate, from the input's own (`--fps F`).
    Fps(Rate),
}

/// What frames are resized to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameSize {
    /// `--resize WxH`: exactly this size.
    Exact {
        /// Columns.
        width: usize,
        /// Rows.
        height: usize,
    },
    /// `--short-side N`: the shorter side becomes `N` (even), the longer
    /// one keeps the aspect, rounded to the nearest even size.
    ShortSide(usize),
}

/// Parse `--resize WxH`: both sides 1 to 65536.
pub fn parse_resize(s: &str) -> Result<FrameSize, String> {
    let side = |v: &str| {
        v.trim()
            .parse::<usize>()
            .ok()
            .filter(|&n| (1..=MAX_SIDE).contains(&n))
    };
    match s.split_once(['x', 'X']).map(|(w, h)| (side(w), side(h))) {
        Some((Some(width), Some(height))) => Ok(FrameSize::Exact { width, height }),
        _ => Err(format!(
            "expected WxH with both sides 1 to {MAX_SIDE} (e.g. 320x240)"
        )),
    }
}

/// Parse `--short-side N`: even, 2 to 65536.
pub fn parse_short_side(s: &str) -> Result<FrameSize, String> {
    match s.trim().parse::<usize>() {
        Ok(n) if (2..=MAX_SIDE).contains(&n) && n % 2 == 0 => Ok(FrameSize::ShortSide(n)),
        _ => Err(format!(
            "expected an even number of pixels, 2 to {MAX_SIDE} (e.g. 224); both sides come out even"
        )),
    }
}

impl FrameSize {
    /// The size a `width × height` frame becomes.
    pub fn of(self, width: usize, height: usize) -> (usize, usize) {
        match self {
            FrameSize::Exact { width, height } => (width, height),
            FrameSize::ShortSide(n) => {
                let (short, long) = (width.min(height), width.max(height));
                // The nearest even size to long · n / short, halves up; at least 2.
                let pairs = (long as u128 * n as u128 + short as u128) / (2 * short as u128);
                let long = (2 * pairs).clamp(2, MAX_SIDE as u128) as usize;
                if width <= height {
                    (n, long)
                } else {
                    (long, n)
                }
            }
        }
    }

    /// As the flag gives it: `320x240`, or `short-side 224`.
    pub fn text(self) -> String {
        match self {
            FrameSize::Exact { width, height } => format!("{width}x{height}"),
            FrameSize::ShortSide(n) => format!("short-side {n}"),
        }
    }
}

/// Which frames are picked and how they are resized, before any pair.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FramePlan {
    /// Which frames.
    pub sampling: Sampling,
    /// Their size, when resized.
    pub size: Option<FrameSize>,
}

impl FramePlan {
    /// The plan of every front end's step / fps / size settings: every
    /// K-th frame if `step` is set, else `fps` frames per second if set,
    /// else every frame (front ends refuse both at once).
    pub fn new(step: Option<u64>, fps: Option<Rate>, size: Option<FrameSize>) -> Self {
        Self {
            sampling: match (step, fps) {
                (Some(k), _) => Sampling::Step(k),
                (None, Some(rate)) => Sampling::Fps(rate),
                (None, None) => Sampling::Every,
            },
            size,
        }
    }

    /// Every frame at its own size: the input as it is.
    pub fn is_identity(&self) -> bool {
        self.sampling == Sampling::Every && self.size.is_none()
    }

    /// Whether frames are skipped (`--step`, `--fps`): results are then
    /// named after both their frames, and records list the frames picked.
    pub fn picks(&self) -> bool {
        self.sampling != Sampling::Every
    }

    /// The plan as one canonical text (for completion markers and
    /// WebDataset settings); empty for the identity.
    pub fn describe(&self) -> String {
        let mut parts = Vec::new();
        match self.sampling {
            Sampling::Every => {}
            Sampling::Step(k) => parts.push(format!("step={k}")),
            Sampling::Fps(r) => parts.push(format!("fps={}", r.text())),
        }
        if let Some(size) = self.size {
            parts.push(format!("resize={}", size.text()));
        }
        parts.join(" ")
    }

    /// The picker of frames for an input at `rate`; `--fps` needs one, and
    /// its absence is an error naming `name`.
    pub fn picker(&self, rate: Option<(u32, u32)>, name: &str) -> Result<Picker, HostError> {
        Ok(match self.sampling {
            Sampling::Every => Picker::every(),
            Sampling::Step(k) => Picker::step(k),
            Sampling::Fps(target) => {
                let Some(source) = rate.and_then(|(n, d)| Rate::new(n, d)) else {
                    return Err(HostError::setting(
                        Setting::Fps,
                        format!(
                            "{} needs the input's frame rate, and {name} states none \
                             (frame folders, raw frames and Y4M without an F tag have none); pick every K-th frame instead",
                            target.text()
                        ),
                    ));
                };
                Picker::fps(source, target)
            }
        })
    }

    /// `source` with this plan applied (itself for the identity); `name`
    /// is the input's, for errors. No frame is resized to more than
    /// `limits` allow.
    pub fn wrap(
        &self,
        source: Box<dyn FrameSource>,
        name: &str,
        limits: Limits,
    ) -> Result<Box<dyn FrameSource>, HostError> {
        if self.is_identity() {
            return Ok(source);
        }
        Ok(Box::new(Sampled::new(source, self, name, limits)?))
    }
}

/// Picks frame indices: frame `j` is taken when it is the next of
/// `t(k) = ⌊k · a / b⌋` for `k = 0, 1, 2, …` (`a/b = K` for `--step K`;
/// the input's rate over `F` for `--fps F`, so frame `⌊k · R / F⌋` is the
/// one at or just before time `k / F`). A rate at or above the input's
/// takes every frame once.
#[derive(Clone, Debug)]
pub struct Picker {
    a: u128,
    b: u128,
    k: u128,
    next: u128,
}

impl Picker {
    /// Every frame.
    pub fn every() -> Self {
        Self::ratio(1, 1)
    }

    /// Frames `0, k, 2k, …` (`k ≥ 1`).
    pub fn step(k: u64) -> Self {
        Self::ratio(u128::from(k.max(1)), 1)
    }

    /// Frames at `target` frames per second from an input at `source`.
    pub fn fps(source: Rate, target: Rate) -> Self {
        // (source.num / source.den) / (target.num / target.den)
        Self::ratio(
            u128::from(source.num) * u128::from(target.den),
            u128::from(source.den) * u128::from(target.num),
        )
    }

    fn ratio(a: u128, b: u128) -> Self {
        Self {
            a,
            b,
            k: 0,
            next: 0,
        }
    }

    /// Whether frame `index` is taken; indices must come in order, from 0.
    pub fn take(&mut self, index: usize) -> bool {
        let j = index as u128;
        if j != self.next {
            return false;
        }
        // Past this frame: the next k whose frame comes later.
        while self.next <= j {
            self.k += 1;
            self.next = self.k * self.a / self.b;
        }
        true
    }

    /// The frames taken of `count`, in order.
    pub fn indices(mut self, count: usize) -> Vec<usize> {
        (0..count).filter(|&j| self.take(j)).collect()
    }

    /// How many of `count` frames are taken.
    pub fn count_of(&self, count: usize) -> usize {
        let n = count as u128;
        if self.a <= self.b {
            return count;
        }
        // k with ⌊k·a/b⌋ < n, i.e. k·a < n·b.
        (n * self.b).div_ceil(self.a) as usize
    }

    /// The rate of the frames taken from an input at `rate`.
    pub fn rate_of(&self, rate: (u32, u32)) -> Option<(u32, u32)> {
        if self.a <= self.b {
            return Some(rate);
        }
        let (num, den) = (u128::from(rate.0) * self.b, u128::from(rate.1) * self.a);
        let g = gcd(num, den).max(1);
        Some((u32::try_from(num / g).ok()?, u32::try_from(den / g).ok()?))
    }
}

fn gcd(mut a: u128, mut b: u128) -> u128 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// A frame resized to `size`, by the resampler of docs/resample.md, into
/// `out` (reusing its memory); `frame` itself when the size is its own.
/// A size over `limits` is refused.
pub fn resize_gray(
    frame: &Gray,
    size: FrameSize,
    limits: Limits,
    out: &mut Gray,
) -> Result<(), HostError> {
    let (w, h) = size.of(frame.width, frame.height);
    // The size asked for, not an input's: the resize is at fault.
    limits
        .check_frame_size(w, h)
        .map_err(|e| HostError::setting(Setting::Resize, e.to_string()))?;
    let resize = Resize::new(frame.width, frame.height, w, h)
        .map_err(|e| HostError::setting(Setting::Resize, e.to_string()))?;
    out.pixels.resize(w * h, 0);
    (out.width, out.height) = (w, h);
    resize
        .frame(&frame.pixels, &mut out.pixels)
        .map_err(|e| HostError::setting(Setting::Resize, e.to_string()))
}

/// A source with a [`FramePlan`] applied: the frames it picks, resized.
/// Each frame keeps its index and stem in the input.
pub struct Sampled {
    inner: Box<dyn FrameSource>,
    picker: Picker,
    size: Option<FrameSize>,
    /// Frames read from `inner` so far.
    read: usize,
    /// What a resized frame may be.
    limits: Limits,
    /// The resized frame's buffer, swapped with the frame read.
    spare: Gray,
}

impl Sampled {
    /// `inner` through `plan`, resized within `limits`; `name` is the
    /// input's, for errors.
    pub fn new(
        inner: Box<dyn FrameSource>,
        plan: &FramePlan,
        name: &str,
        limits: Limits,
    ) -> Result<Self, HostError> {
        let picker = plan.picker(inner.frame_rate(), name)?;
        Ok(Self {
            inner,
            picker,
            size: plan.size,
            read: 0,
            limits,
            spare: Gray {
                width: 0,
                height: 0,
                pixels: Vec::new(),
            },
        })
    }
}

impl FrameSource for Sampled {
    fn next_frame(&mut self) -> Result<Option<Frame>, HostError> {
        let mut frame = Frame::empty();
        Ok(self.next_frame_into(&mut frame)?.then_some(frame))
    }

    fn next_frame_into(&mut self, frame: &mut Frame) -> Result<bool, HostError> {
        loop {
            if !self.inner.next_frame_into(frame)? {
                return Ok(false);
            }
            let index = self.read;
            self.read += 1;
            if self.picker.take(index) {
                frame.index = index;
                break;
            }
        }
        if let Some(size) = self.size
            && size.of(frame.gray.width, frame.gray.height) != frame.gray.size()
        {
            resize_gray(&frame.gray, size, self.limits, &mut self.spare)?;
            std::mem::swap(&mut frame.gray, &mut self.spare);
        }
        Ok(true)
    }

    fn frame_count_hint(&self) -> Option<usize> {
        self.inner
            .frame_count_hint()
            .map(|n| self.picker.count_of(n))
    }

    fn frame_rate(&self) -> Option<(u32, u32)> {
        self.inner.frame_rate().and_then(|r| self.picker.rate_of(r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_and_fps_pick_the_frames_of_their_definition() {
        assert_eq!(Picker::step(2).indices(9), [0, 2, 4, 6, 8]);
        assert_eq!(Picker::step(3).indices(9), [0, 3, 6]);
        assert_eq!(Picker::every().indices(4), [0, 1, 2, 3]);
        let fps = |src: (u32, u32), dst: (u32, u32), n| {
            Picker::fps(
                Rate::new(src.0, src.1).unwrap(),
                Rate::new(dst.0, dst.1).unwrap(),
            )
            .indices(n)
        };
        assert_eq!(fps((30, 1), (10, 1), 10), [0, 3, 6, 9]);
        // 25 → 10: frames at 0, 2.5, 5, 7.5, … → 0, 2, 5, 7.
        assert_eq!(fps((25, 1), (10, 1), 10), [0, 2, 5, 7]);
        // NTSC to 10: 29.97 / 10 = 2.997 per sample.
        assert_eq!(fps((30000, 1001), (10, 1), 10), [0, 2, 5, 8]);
        // At or above the input's rate: every frame, once.
        assert_eq!(fps((10, 1), (30, 1), 4), [0, 1, 2, 3]);
        assert_eq!(fps((10, 1), (10, 1), 4), [0, 1, 2, 3]);
        for (p, n) in [
            (Picker::step(2), 9),
            (Picker::step(4), 10),
            (Picker::every(), 3),
        ] {
            assert_eq!(p.count_of(n), p.clone().indices(n).len());
        }
        let p = Picker::fps(Rate::new(25, 1).unwrap(), Rate::new(10, 1).unwrap());
        for n in 0..40 {
            assert_eq!(p.count_of(n), p.clone().indices(n).len(), "{n}");
        }
        assert_eq!(Picker::step(2).rate_of((30, 1)), Some((15, 1)));
        assert_eq!(p.rate_of((25, 1)), Some((10, 1)));
    }

    #[test]
    fn short_side_keeps_the_aspect_in_even_sizes() {
        let s = FrameSize::ShortSide(224);
        assert_eq!(s.of(1920, 1080), (398, 224));
        assert_eq!(s.of(1080, 1920), (224, 398));
        assert_eq!(s.of(320, 240), (298, 224));
        assert_eq!(s.of(224, 224), (224, 224));
        assert_eq!(FrameSize::ShortSide(2).of(1000, 1), (2000, 2));
        assert_eq!(FrameSize::ShortSide(120).of(160, 120), (160, 120));
        assert!(parse_short_side("223").is_err());
        assert!(parse_short_side("0").is_err());
        assert_eq!(parse_short_side("224"), Ok(s));
        assert_eq!(
            parse_resize("320x240"),
            Ok(FrameSize::Exact {
                width: 320,
                height: 240
            })
        );
        for bad in ["320", "0x2", "65537x2", "axb"] {
            assert!(parse_resize(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_rate("29.97"), Ok(Rate::new(2997, 100).unwrap()));
        assert_eq!(parse_rate("30000/1001").unwrap().text(), "30000/1001");
        for bad in ["0", "-1", "x", "1/0"] {
            assert!(parse_rate(bad).is_err(), "{bad}");
        }
    }
}

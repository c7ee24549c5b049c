"""The separability statistics of one channel map (no learning), and their
bootstrap over clips and seeds.

Windows (px, on the 160x120 frames):

- **detection statistic** D(p), the same at every pixel of every channel:
  |mean of the 3x3 window at p - mean of the ring between the 9x9 and the
  21x21 windows at p| (a local-contrast filter; a drone of 2-6 px fills
  the 3x3 window and stays inside the 9x9 guard);
- **SCR** of a drone frame: the target region T is the pixels whose
  centres lie within d/2 + 1 px of the drone's centre (d: its diameter;
  the extra pixel holds the motion channels' response at the drone's
  edge), the background B the pixels of the 21x21 window centred on the
  drone farther than d/2 + 4 px from it; SCR = |mean_T - mean_B| / std_B;
- **background suppression factor** (BSF) of a channel against the gray
  frame: each map scaled to unit standard deviation over its frame,
  BSF = std_B(gray) / std_B(channel);
- **Pd at a false-alarm rate Fa**: the threshold on a score map is the one
  that at most a fraction Fa of background pixels (every pixel of a
  drone-free frame; of a drone frame, those farther than d/2 + 11 px from
  the drone, beyond the reach of the statistic's 21x21 window centred on
  it) exceed, pooled over the test clips; a drone frame is detected
  when the score's maximum over T reaches it. Scores are binned on a log
  scale (64 bins per octave, 1.1 % apart) so the bootstrap can resample
  clips by summing histograms.
"""

from __future__ import annotations

import numpy as np

INNER, GUARD, OUTER = 3, 9, 21  # the detection statistic's windows (px)
T_EXTRA, B_GUARD = 1.0, 4.0  # T: within d/2 + 1 px; B: farther than d/2 + 4 px
FA_GUARD = OUTER // 2 + 1  # false-alarm pixels: farther than d/2 + 11 px
FAS = (1e-3, 1e-4, 1e-5)
UNIT, PER_OCTAVE, OCTAVES = 1e-4, 64, 26
NBINS = PER_OCTAVE * OCTAVES + 1
SCR_CAP = 1e3  # an SCR on a background with no spread at all


def box_mean(x: np.ndarray, k: int) -> np.ndarray:
    """Mean over the k x k window centred at every pixel (k odd), the
    frame mirrored at its border without repeating the edge (OpenCV's
    BORDER_REFLECT_101, numpy's 'reflect')."""
    import cv2

    return cv2.blur(np.asarray(x, np.float64), (k, k), borderType=cv2.BORDER_REFLECT_101)


def local_contrast(x: np.ndarray) -> np.ndarray:
    """D = |3x3 mean - mean of the ring between 9x9 and 21x21|."""
    outer, guard = box_mean(x, OUTER) * OUTER**2, box_mean(x, GUARD) * GUARD**2
    ring = (outer - guard) / (OUTER**2 - GUARD**2)
    return np.abs(box_mean(x, INNER) - ring)


def regions(shape: tuple, center: np.ndarray, diameter: float) -> tuple:
    """(T, B, far) boolean masks of a drone at `center` (x, y): T within
    d/2 + 1 px, B the 21x21 window's pixels farther than d/2 + 4 px, far
    every pixel farther than d/2 + 11 px (the false-alarm pixels)."""
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w]
    dist = np.hypot(xx - center[0], yy - center[1])
    r = diameter / 2
    target = dist <= r + T_EXTRA
    if not target.any():  # at least the pixel holding the centre
        target[int(np.clip(np.floor(center[1]), 0, h - 1)), int(np.clip(np.floor(center[0]), 0, w - 1))] = True
    half = OUTER // 2
    cx, cy = int(np.floor(center[0])), int(np.floor(center[1]))
    window = (np.abs(xx - cx) <= half) & (np.abs(yy - cy) <= half)
    return target, window & (dist > r + B_GUARD), dist > r + FA_GUARD


def scr(x: np.ndarray, target: np.ndarray, background: np.ndarray) -> tuple:
    """(SCR, std_B) of a map: |mean_T - mean_B| / std_B (capped at SCR_CAP
    where std_B is 0)."""
    b = x[background].astype(np.float64)
    sd = float(b.std())
    diff = abs(float(x[target].mean()) - float(b.mean()))
    if sd <= 0:
        return (SCR_CAP if diff > 0 else 0.0), 0.0
    return min(diff / sd, SCR_CAP), sd


def to_bins(s: np.ndarray) -> np.ndarray:
    """Scores -> log bins: 0 for s <= UNIT, then PER_OCTAVE per doubling."""
    s = np.asarray(s, np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        b = np.floor(PER_OCTAVE * np.log2(np.maximum(s, UNIT) / UNIT)) + 1
    b = np.where(s > UNIT, b, 0)
    return np.clip(np.nan_to_num(b, nan=0), 0, NBINS - 1).astype(np.int64)


def bin_floor(b: np.ndarray) -> np.ndarray:
    """The smallest score of each bin."""
    b = np.asarray(b, np.float64)
    return np.where(b > 0, UNIT * 2.0 ** ((b - 1) / PER_OCTAVE), 0.0)


def histogram(s: np.ndarray) -> np.ndarray:
    return np.bincount(to_bins(s).ravel(), minlength=NBINS)


def pd_at(background: np.ndarray, targets: np.ndarray, fas=FAS) -> np.ndarray:
    """Pd at each false-alarm rate from histograms (..., NBINS) of the
    background pixels' scores and of the drone frames' target scores (the
    leading axes are replicates): the threshold bin is the lowest b with at
    most Fa x (background pixels) in bins >= b; Pd is the fraction of target
    scores in bins >= that. Returns (..., len(fas)); NaN without drones."""
    bg = np.asarray(background, np.float64)
    tg = np.asarray(targets, np.float64)
    exceed = np.flip(np.cumsum(np.flip(bg, -1), -1), -1)  # pixels in bins >= b
    above = np.flip(np.cumsum(np.flip(tg, -1), -1), -1)
    n, m = bg.sum(-1, keepdims=True), tg.sum(-1)
    out = []
    for fa in fas:
        ok = exceed <= fa * n
        b = np.argmax(ok, axis=-1)  # the first (lowest) bin with few enough exceedances
        b = np.where(ok.any(-1), b, NBINS - 1)
        hit = np.take_along_axis(above, b[..., None], -1)[..., 0]
        with np.errstate(invalid="ignore", divide="ignore"):
            out.append(np.where(m > 0, hit / np.where(m > 0, m, 1), np.nan))
    return np.stack(out, -1)


def threshold_at(background: np.ndarray, fa: float) -> float:
    """The score threshold (its bin's floor) pd_at uses at one rate."""
    exceed = np.cumsum(background[::-1])[::-1]
    ok = exceed <= fa * background.sum()
    return float(bin_floor(np.argmax(ok) if ok.any() else NBINS - 1))


def fisher(targets: np.ndarray, background: np.ndarray) -> np.ndarray:
    """Fisher's linear discriminant of (n, C) target and (m, C) background
    feature vectors: w = (S_t + S_b)^-1 (mean_t - mean_b), unit length."""
    mt, mb = targets.mean(0), background.mean(0)
    cov = np.atleast_2d(np.cov(targets, rowvar=False)) + np.atleast_2d(np.cov(background, rowvar=False))
    cov += np.eye(len(mt)) * 1e-6 * max(float(np.trace(cov)), 1e-12)
    w = np.linalg.solve(cov, mt - mb)
    return w / max(float(np.linalg.norm(w)), 1e-12)


def resample(groups: list, reps: int, seed: int = 0) -> np.ndarray:
    """(reps + 1, clips) weights: row 0 all ones (the estimate), then
    bootstrap replicates that draw the seeds with replacement and, within
    each seed drawn, its clips with replacement. groups: the clip indices
    (columns) of each seed."""
    n = sum(len(g) for g in groups)
    rng = np.random.default_rng([seed, 59])
    w = np.zeros((reps + 1, n))
    w[0] = 1
    for r in range(1, reps + 1):
        for k in rng.integers(0, len(groups), len(groups)):
            g = np.asarray(groups[k])
            np.add.at(w[r], g[rng.integers(0, len(g), len(g))], 1)
    return w


def weighted_median(values: np.ndarray, clip: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(reps + 1,) medians of per-frame values under each row of clip
    weights (NaN values left out)."""
    ok = np.isfinite(values)
    v, c = values[ok], clip[ok]
    if not len(v):
        return np.full(len(weights), np.nan)
    order = np.argsort(v, kind="stable")
    v, c = v[order], c[order]
    cw = np.cumsum(weights[:, c], axis=1)
    total = cw[:, -1:]
    idx = np.array([np.searchsorted(row, t / 2) for row, t in zip(cw, total[:, 0])])
    med = v[np.clip(idx, 0, len(v) - 1)]
    return np.where(total[:, 0] > 0, med, np.nan)


def interval(values: np.ndarray) -> tuple:
    """(estimate, low, high): values[0] and the 2.5th-97.5th percentiles of
    the replicates values[1:]."""
    reps = values[1:][np.isfinite(values[1:])]
    if not len(reps) or not np.isfinite(values[0]):
        return float(values[0]), float("nan"), float("nan")
    lo, hi = np.percentile(reps, [2.5, 97.5])
    return float(values[0]), float(lo), float(hi)

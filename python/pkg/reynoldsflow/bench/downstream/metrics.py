"""Scores of heatmaps against the drone's centre.

- **located within 3 px**: over frames with a drone, the fraction whose
  strongest peak is within 3 px of the drone's centre;
- **AP**: average precision of the detections (local maxima over 7x7
  windows, the 5 strongest per frame) over all frames, a detection being
  true when within 3 px of a drone not yet matched in its frame; recall is
  over the drones (one per drone frame); all-point interpolation;
- **false positives per drone-free frame at a fixed recall**: the lowest
  score threshold at which the detections reach that recall over the drone
  frames, and the detections at or above it on drone-free frames, per
  drone-free frame (NaN when that recall is never reached).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

RADIUS = 3.0  # px
NMS = 7  # px window
PEAKS = 5  # per frame


@dataclass(frozen=True)
class Scores:
    located: float  # fraction of drone frames, [0, 1]
    ap: float  # [0, 1]
    fp_per_free_frame: float  # at the fixed recall; NaN: recall not reached
    drone_frames: int
    free_frames: int


def peaks(heat: np.ndarray, k: int = PEAKS, window: int = NMS) -> np.ndarray:
    """(N, H, W) maps -> (N, k, 3) float64 (x, y, score) of the k strongest
    local maxima (a pixel equal to the maximum of its window); score -inf
    pads frames with fewer."""
    n, h, w = heat.shape
    r = window // 2
    padded = np.pad(heat, ((0, 0), (r, r), (r, r)), constant_values=-np.inf)
    win = np.lib.stride_tricks.sliding_window_view(padded, (window, window), axis=(1, 2))
    is_peak = heat >= win.max(axis=(-1, -2))
    scores = np.where(is_peak, heat, -np.inf).reshape(n, -1)
    top = np.argsort(-scores, axis=1, kind="stable")[:, :k]
    s = np.take_along_axis(scores, top, axis=1)
    return np.stack([top % w, top // w, s], axis=-1).astype(np.float64)


def score(heat: np.ndarray, centers: np.ndarray, recall: float) -> Scores:
    """Scores of (N, H, W) maps against (N, 2) centres (NaN: drone-free)."""
    has = np.isfinite(centers[:, 0])
    n_drone, n_free = int(has.sum()), int((~has).sum())
    det = peaks(heat)
    # Located: the strongest peak of each drone frame.
    d_top = np.hypot(det[:, 0, 0] - centers[:, 0], det[:, 0, 1] - centers[:, 1])
    located = float(np.mean(d_top[has] <= RADIUS)) if n_drone else float("nan")
    # Detections, strongest first; true if within RADIUS of its frame's
    # drone and the drone was not matched by a stronger one.
    frame = np.repeat(np.arange(len(det)), det.shape[1])
    flat = det.reshape(-1, 3)
    keep = np.isfinite(flat[:, 2])
    frame, flat = frame[keep], flat[keep]
    order = np.argsort(-flat[:, 2], kind="stable")
    frame, flat = frame[order], flat[order]
    dist = np.hypot(flat[:, 0] - centers[frame, 0], flat[:, 1] - centers[frame, 1])
    close = np.nan_to_num(dist, nan=np.inf) <= RADIUS
    matched = np.zeros(len(centers), bool)
    tp = np.zeros(len(flat), bool)
    for j in np.flatnonzero(close):
        if not matched[frame[j]]:
            matched[frame[j]] = tp[j] = True
    ap = _average_precision(tp, n_drone)
    fp = _fp_at_recall(tp, flat[:, 2], ~has[frame], n_drone, n_free, recall)
    return Scores(located, ap, fp, n_drone, n_free)


def _average_precision(tp: np.ndarray, positives: int) -> float:
    if positives == 0:
        return float("nan")
    ctp = np.cumsum(tp)
    precision = ctp / np.arange(1, len(tp) + 1)
    recall = ctp / positives
    # All-point interpolation: precision made non-increasing, summed over
    # the recall steps (where a true detection arrives).
    precision = np.maximum.accumulate(precision[::-1])[::-1]
    return float(np.sum(precision[tp]) / positives)


def _fp_at_recall(tp, scores, on_free, positives, free_frames, recall) -> float:
    if positives == 0 or free_frames == 0:
        return float("nan")
    reached = np.flatnonzero(np.cumsum(tp) >= recall * positives)
    if len(reached) == 0:
        return float("nan")
    threshold = scores[reached[0]]
    return float(np.sum(on_free & (scores >= threshold)) / free_frames)

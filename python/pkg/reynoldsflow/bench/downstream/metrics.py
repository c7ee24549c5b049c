"""Scores of detections against the drone.

A detector gives scored points (the heatmap network: local maxima over
7x7 windows, the 5 strongest per frame) or scored boxes (YOLO). Over the
frames of a test set:

- **located within 3 px**: over frames with a drone, the fraction whose
  strongest detection (a box by its centre) is within 3 px of the drone's
  centre;
- **AP (3 px)**: average precision, a detection being true when within
  3 px of a drone not yet matched in its frame (strongest first); recall
  is over the drones (one per drone frame); all-point interpolation;
- **AP50, AP50-95** (boxes): the same with a true detection's box
  overlapping the drone's exact box by IoU >= 0.5, and the mean over IoU
  thresholds 0.50, 0.55, ..., 0.95, as COCO and the paper report them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

RADIUS = 3.0  # px
NMS = 7  # px window
PEAKS = 5  # per frame


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


IOU_THRESHOLDS = tuple(round(0.5 + 0.05 * k, 2) for k in range(10))
POINT_CRITERIA = ("3px",)
BOX_CRITERIA = ("3px",) + tuple(f"iou{t:.2f}" for t in IOU_THRESHOLDS)


@dataclass(frozen=True)
class Records:
    """The detections on a test set's frames: per detection its frame,
    score and whether it is a true detection under each criterion (matched
    greedily, strongest first, at most one per drone); per frame its clip
    and whether it holds a drone."""

    criteria: tuple
    frame: np.ndarray  # (D,) int
    score: np.ndarray  # (D,) float64
    hits: np.ndarray  # (D, K) bool
    clip: np.ndarray  # (F,) int, the clip of each frame
    drone: np.ndarray  # (F,) bool
    top_within: np.ndarray  # (F,) bool: the frame's strongest detection is within 3 px of its drone


def drone_boxes(centers: np.ndarray, diameters: np.ndarray) -> np.ndarray:
    """(N, 2) centres and (N,) diameters -> (N, 4) boxes (x0, y0, x1, y1)."""
    half = diameters[:, None] / 2
    return np.concatenate([centers - half, centers + half], axis=1)


def _iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise IoU of (D, 4) boxes."""
    w = np.clip(np.minimum(a[:, 2], b[:, 2]) - np.maximum(a[:, 0], b[:, 0]), 0, None)
    h = np.clip(np.minimum(a[:, 3], b[:, 3]) - np.maximum(a[:, 1], b[:, 1]), 0, None)
    inter = w * h
    area = lambda x: (x[:, 2] - x[:, 0]) * (x[:, 3] - x[:, 1])  # noqa: E731
    union = area(a) + area(b) - inter
    return np.where(union > 0, inter / np.where(union > 0, union, 1), 0.0)


def records(frame: np.ndarray, score: np.ndarray, where: np.ndarray, centers: np.ndarray,
            diameters: np.ndarray, clip: np.ndarray) -> Records:
    """Records of detections (frame index, score, where: (D, 2) points or
    (D, 4) boxes x0, y0, x1, y1) against each frame's drone (centre,
    diameter; NaN centre: none). Points are scored by the 3 px criterion
    only, boxes (by their centre) also by IoU at 0.50:0.05:0.95."""
    boxes = np.concatenate([where, where], axis=1) if where.shape[1] == 2 else where
    criteria = POINT_CRITERIA if where.shape[1] == 2 else BOX_CRITERIA
    order = np.lexsort((np.arange(len(score)), -score))
    frame, score, boxes = frame[order], score[order].astype(np.float64), boxes[order]
    gt = drone_boxes(centers, diameters)[frame]
    mid = (boxes[:, :2] + boxes[:, 2:]) / 2
    dist = np.nan_to_num(np.hypot(*(mid - centers[frame]).T), nan=np.inf)
    ok = [dist <= RADIUS]
    if criteria == BOX_CRITERIA:
        iou = np.nan_to_num(_iou(boxes, gt), nan=0.0)
        ok += [iou >= t - 1e-12 for t in IOU_THRESHOLDS]
    hits = np.zeros((len(score), len(criteria)), bool)
    for k, good in enumerate(ok):
        matched = np.zeros(len(centers), bool)
        for j in np.flatnonzero(good):
            if not matched[frame[j]]:
                matched[frame[j]] = hits[j, k] = True
    has = np.isfinite(centers[:, 0])
    top_within = np.zeros(len(centers), bool)
    first = np.unique(frame, return_index=True)[1]  # strongest detection of each frame
    top_within[frame[first]] = dist[first] <= RADIUS
    return Records(criteria, frame, score, hits, np.asarray(clip), has, top_within & has)


def ap_of(score: np.ndarray, hits: np.ndarray, positives: int) -> np.ndarray:
    """(K,) AP of (D,) scores and (D, K) hits (any order), all-point
    interpolation (precision made non-increasing, summed where a true
    detection arrives, over the positives), vectorised over K; NaN without
    positives."""
    if positives == 0:
        return np.full(hits.shape[1], np.nan)
    if not len(score):
        return np.zeros(hits.shape[1])
    h = hits[np.argsort(-score, kind="stable")]
    precision = np.cumsum(h, axis=0) / np.arange(1, len(h) + 1)[:, None]
    precision = np.maximum.accumulate(precision[::-1], axis=0)[::-1]
    return np.where(h, precision, 0.0).sum(axis=0) / positives


def summary(r: Records) -> dict:
    """located_3px, ap (3 px) and, for boxes, ap50 and ap50_95."""
    ap = ap_of(r.score, r.hits, int(r.drone.sum()))
    out = dict(located_3px=float(r.top_within.sum() / max(int(r.drone.sum()), 1)) if r.drone.any() else float("nan"),
               ap=float(ap[0]), ap50=float("nan"), ap50_95=float("nan"))
    if r.criteria == BOX_CRITERIA:
        out.update(ap50=float(ap[1]), ap50_95=float(np.mean(ap[1:])))
    return out

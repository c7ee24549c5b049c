"""One seed of one scene family: the training pass (each input's channel
scales and the linear combination of its channels, fitted on the seed's
training clips only) and the test pass (per-clip histograms of background
scores, per-drone-frame target scores, SCR and background spread)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List

import numpy as np

from ..downstream import run as downstream_run
from . import channels, measure

SAMPLE = 256  # background pixels sampled per training pair for the fits


@dataclass
class Result:
    family: str
    seed: int
    clips: int  # test clips
    frames: List[dict] = field(default_factory=list)  # per test drone frame: clip, diameter, contrast, speed
    scr: Dict[str, np.ndarray] = field(default_factory=dict)  # input -> (F, C) SCR per channel
    spread: Dict[str, np.ndarray] = field(default_factory=dict)  # input -> (F, C) std_B / frame std
    target: Dict[str, np.ndarray] = field(default_factory=dict)  # input -> (F, C + 1) score bins (channels, combination)
    hist: Dict[str, np.ndarray] = field(default_factory=dict)  # input -> (clips, C + 1, NBINS) background bins
    combination: Dict[str, tuple] = field(default_factory=dict)  # input -> (label, weights on the scaled channels)
    best: Dict[str, int] = field(default_factory=dict)  # input -> channel with the highest training median SCR


def _speed(clip, t: int) -> float:
    c = clip.centers
    return float(np.hypot(*(c[t + 1] - c[t]))) if t + 1 < len(c) else float("nan")


def _choose(tg: np.ndarray, bg: np.ndarray, names) -> tuple:
    """The linear combination of scaled channel scores with the highest
    training Pd at Fa 1e-3 (estimated from the samples), among each channel
    alone and Fisher's discriminant: (label, weights)."""
    cands = [(n, np.eye(len(names))[k]) for k, n in enumerate(names)]
    if len(names) > 1 and len(tg) > 1:
        cands.append(("fisher", measure.fisher(tg, bg)))
    best, score = cands[0], -1.0
    for label, w in cands:
        thr = np.quantile(bg @ w, 1 - 1e-3)
        pd = float(np.mean(tg @ w > thr))
        if pd > score + 1e-12:
            best, score = (label, w), pd
    return best


def run(family: str, seed: int, names: tuple, train_n: int, test_n: int, frames: int, factors: tuple,
        videos: tuple) -> Result:
    train, test = downstream_run.composites(family, seed, train_n, test_n, frames, factors, videos)
    rng = np.random.default_rng([seed, 59, 1])
    # Training pass: target and background samples of every channel's D, and SCR.
    tg = {n: [] for n in names}
    bg = {n: [] for n in names}
    scr_train = {n: [] for n in names}
    for clip in train:
        for t, m in enumerate(channels.maps(clip.frames, names)):
            has = bool(np.isfinite(clip.centers[t, 0]))
            for n in names:
                d = np.stack([measure.local_contrast(ch) for ch in m[n]])
                flat = d.reshape(len(d), -1)
                if has:
                    tmask, bmask, far = measure.regions(d.shape[1:], clip.centers[t], clip.diameter)
                    tg[n].append(d[:, tmask].max(1))
                    scr_train[n].append([measure.scr(ch, tmask, bmask)[0] for ch in m[n]])
                    pool = np.flatnonzero(far.ravel())
                else:
                    pool = np.arange(flat.shape[1])
                bg[n].append(flat[:, rng.choice(pool, SAMPLE, replace=False)].T)
    res = Result(family, seed, len(test))
    scale = {}
    for n in names:
        b = np.concatenate(bg[n])
        scale[n] = np.maximum(b.std(0), 1e-12)
        t = np.array(tg[n]) / scale[n] if tg[n] else np.zeros((0, len(scale[n])))
        res.combination[n] = _choose(t, b / scale[n], channels.NAMES[n])
        res.best[n] = int(np.argmax(np.median(np.array(scr_train[n]), 0))) if scr_train[n] else 0
    # Test pass.
    for n in names:
        c = len(channels.NAMES[n])
        res.hist[n] = np.zeros((len(test), c + 1, measure.NBINS), np.int32)
        res.scr[n], res.spread[n], res.target[n] = [], [], []
    for k, clip in enumerate(test):
        for t, m in enumerate(channels.maps(clip.frames, names)):
            has = bool(np.isfinite(clip.centers[t, 0]))
            if has:
                tmask, bmask, far = measure.regions(clip.frames.shape[1:], clip.centers[t], clip.diameter)
                res.frames.append(dict(clip=k, diameter=clip.diameter, contrast=clip.contrast,
                                       speed=_speed(clip, t)))
            for n in names:
                d = np.stack([measure.local_contrast(ch) for ch in m[n]]) / scale[n][:, None, None]
                s = np.concatenate([d, np.tensordot(res.combination[n][1], d, 1)[None]])
                pix = s[:, far] if has else s.reshape(len(s), -1)
                for j in range(len(s)):
                    res.hist[n][k, j] += measure.histogram(pix[j]).astype(np.int32)
                if has:
                    res.target[n].append(measure.to_bins(s[:, tmask].max(1)))
                    got = [measure.scr(ch, tmask, bmask) for ch in m[n]]
                    res.scr[n].append([g[0] for g in got])
                    res.spread[n].append([g[1] / max(float(ch.std()), 1e-12) for g, ch in zip(got, m[n])])
    for n in names:
        c = len(channels.NAMES[n])
        res.scr[n] = np.array(res.scr[n]).reshape(-1, c)
        res.spread[n] = np.array(res.spread[n]).reshape(-1, c)
        res.target[n] = np.array(res.target[n], np.int64).reshape(-1, c + 1)
    return res

"""Bootstrap intervals of AP and of paired differences between inputs.

An input's AP (for one scene family, detector and metric) is the mean over
seeds of the AP over that seed's test clips. Its 95 % interval is the
2.5th-97.5th percentile of that mean over bootstrap replicates that
resample the seeds with replacement and, within each seed drawn, its test
clips with replacement (a clip brings all its frames and their
detections). Every input sees the same clips per seed, so a paired
difference (representation - baseline) uses the same draws for both and
its interval comes from the replicate differences; it is *resolved* when
its interval excludes 0. Where seeds fall into strata by design (the real
scenes' test video, which rotates with the seed), the seeds are resampled
within each stratum.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from . import metrics

# The criteria columns (metrics.BOX_CRITERIA) a metric averages.
COLUMNS = {"ap": slice(0, 1), "ap50": slice(1, 2), "ap50_95": slice(1, 11)}


@dataclass(frozen=True)
class Interval:
    estimate: float
    low: float
    high: float

    @property
    def resolved(self) -> bool:
        return bool(np.isfinite(self.low) and (self.low > 0 or self.high < 0))


def _by_clip(r: metrics.Records) -> Tuple[list, np.ndarray]:
    """The detection indices of each clip and each clip's drone frames."""
    clip_of_det = r.clip[r.frame]
    clips = np.unique(r.clip)
    dets = [np.flatnonzero(clip_of_det == c) for c in clips]
    drones = np.array([int(r.drone[r.clip == c].sum()) for c in clips])
    return dets, drones


def _value(r: metrics.Records, idx: np.ndarray, positives: int, metric: str) -> float:
    columns = COLUMNS[metric]
    return float(np.mean(metrics.ap_of(r.score[idx], r.hits[idx][:, columns], positives)))


def replicates(per_seed: Dict[object, Dict[int, metrics.Records]], metric: str, reps: int,
               seed: int = 0, strata: Optional[Dict[int, object]] = None) -> Dict[object, np.ndarray]:
    """(reps + 1,) values per input: the point estimate first, then the
    bootstrap replicates. per_seed: input -> {seed: Records}, the same seeds
    and the same clips (in count) for every input. strata: seed -> stratum
    (e.g. the seed's test videos); each replicate resamples the seeds
    within each stratum, keeping every stratum's count of seeds, so the
    spread between strata (fixed by the design) is not in the interval.
    Without it, all seeds are one stratum."""
    inputs = list(per_seed)
    seeds = sorted(per_seed[inputs[0]])
    groups: Dict[object, list] = {}
    for s in seeds:
        groups.setdefault(None if strata is None else strata[s], []).append(s)
    rng = np.random.default_rng([seed, 4])
    split = {i: {s: _by_clip(per_seed[i][s]) for s in seeds} for i in inputs}
    n_clips = {s: len(split[inputs[0]][s][0]) for s in seeds}
    draws = [[(s, np.arange(n_clips[s])) for s in seeds]]
    for _ in range(reps):
        chosen = [g[k] for g in groups.values() for k in rng.choice(len(g), size=len(g), replace=True)]
        draws.append([(s, rng.integers(0, n_clips[s], n_clips[s])) for s in chosen])
    out = {}
    for i in inputs:
        values = np.empty(len(draws))
        for d, draw in enumerate(draws):
            per = []
            for s, clips in draw:
                dets, drones = split[i][s]
                idx = np.concatenate([dets[c] for c in clips]) if len(clips) else np.array([], int)
                per.append(_value(per_seed[i][s], idx, int(drones[clips].sum()), metric))
            values[d] = np.nanmean(per) if np.isfinite(per).any() else np.nan
        out[i] = values
    return out


def interval(values: np.ndarray) -> Interval:
    """The point estimate (values[0]) and the 95 % percentile interval of
    the replicates (values[1:])."""
    reps = values[1:][np.isfinite(values[1:])]
    if not len(reps) or not np.isfinite(values[0]):
        return Interval(float(values[0]), float("nan"), float("nan"))
    lo, hi = np.percentile(reps, [2.5, 97.5])
    return Interval(float(values[0]), float(lo), float(hi))


def paired(values: Dict[object, np.ndarray], reference: object, baselines: Sequence[object]) -> Dict[object, Interval]:
    """reference - baseline over the same replicates, per baseline."""
    return {b: interval(values[reference] - values[b]) for b in baselines if b != reference}

"""Composited patches: 2-frame clips of PATCH x PATCH px, each with its own
background (a generated sky, or a crop of a real video at the benchmark's
160x120 scale), drone path, diameter and contrast; a quarter without a
drone. The inputs of each patch's pair are the downstream benchmark's
(``downstream.inputs``), computed on the patch."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from ..downstream import backgrounds, inputs, scenes

PATCH = 64
PARTS = {"train": 0, "val": 1, "test": 2}


@dataclass(frozen=True)
class Pool:
    x: dict  # input name -> (N, PATCH, PATCH, C) uint8
    centers: np.ndarray  # (N, 2), NaN without a drone
    diameters: np.ndarray  # (N,)
    contrasts: np.ndarray  # (N,)


def make(family: str, seed: int, part: str, n: int, names: Sequence[str], sizes: tuple, contrasts: tuple,
         factors: tuple, videos: tuple) -> Pool:
    """n patches of one part (train, val, test) of a family and seed. Sky:
    training and validation patches switch each factor on with probability
    0.6, test patches have them all. Real: training and validation patches
    from the seed's training videos, test patches from its test videos."""
    rng = np.random.default_rng([seed, 590, PARTS[part]])
    free = max(1, int(round(n * 0.25)))
    clips = []
    if family == "real":
        train_v, test_v = backgrounds.split(videos, seed)
        chosen = test_v if part == "test" else train_v
        vids = [backgrounds.load(Path(p), scenes.WIDTH, scenes.HEIGHT, 2) for p in chosen]
    for i in range(n):
        drone = i < n - free
        if family == "sky":
            on = factors if part == "test" else [f for f in factors if rng.random() < 0.6]
            clips.append(scenes.make_clip(rng, on, 2, drone, PATCH, PATCH, sizes, contrasts))
        else:
            clips.append(backgrounds.make_clip(rng, vids[i % len(vids)], 2, drone, PATCH, PATCH, sizes, contrasts))
    frames = np.stack([c.frames for c in clips])  # (n, 2, P, P)
    x = {}
    for name in names:
        make_input = inputs.BY_NAME[name].make
        x[name] = np.concatenate([make_input(f) for f in frames])
    return Pool(x, np.stack([c.centers[0] for c in clips]), np.array([c.diameter for c in clips]),
                np.array([c.contrast for c in clips]))

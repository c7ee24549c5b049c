"""What the detector sees: one image per frame pair (frames t, t + 1).

Every input of pair t is aligned with frame t (the frame the ground truth
of that pair refers to, and the gray channel of the representation). The
representation is computed by this package (``reynoldsflow.represent_clip``
and ``reynoldsflow.fields``, the same values as the command line), never
reimplemented here; the classical flows are OpenCV's (``flow``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Dict, Sequence

import numpy as np

import reynoldsflow as rf

from . import flow


@dataclass(frozen=True)
class Input:
    name: str
    description: str
    make: Callable[[np.ndarray], np.ndarray] = field(repr=False)
    """(T, H, W) uint8 clip -> (T - 1, H, W, C) uint8"""


def _gray(frames: np.ndarray) -> np.ndarray:
    return frames[:-1, :, :, None]


def _diff(frames: np.ndarray) -> np.ndarray:
    f = frames.astype(np.int16)
    return np.abs(f[1:] - f[:-1]).astype(np.uint8)[..., None]


def _rf(channels=None, **options) -> Callable[[np.ndarray], np.ndarray]:
    def make(frames: np.ndarray) -> np.ndarray:
        rep = rf.represent_clip(frames, threads=1, **options)
        return rep if channels is None else np.ascontiguousarray(rep[..., channels])

    return make


def _rf_hsv(frames: np.ndarray) -> np.ndarray:
    """v_R of each pair (this package's fields) coded as the flows are."""
    return np.stack([flow.hsv(rf.fields(frames[t], frames[t + 1])["v_R"]) for t in range(len(frames) - 1)])


# The paper's comparison (Table 3's rows that can be computed here, plus
# frame difference): what `python -m reynoldsflow.bench.downstream` trains
# by default.
PAPER = (
    Input("gray", "the frame t alone", _gray),
    Input("diff", "|f(t+1) - f(t)| (not in the paper)", _diff),
    Input("farneback", "Farneback flow (OpenCV), HSV-coded", flow.coded("farneback")),
    Input("tvl1", "TV-L1 flow (opencv-contrib), HSV-coded", flow.coded("tvl1")),
    Input("dis", "DIS flow (OpenCV, preset medium), HSV-coded", flow.coded("dis")),
    Input("deepflow", "DeepFlow (opencv-contrib), HSV-coded", flow.coded("deepflow")),
    Input("pcaflow", "PCAFlow (opencv-contrib), HSV-coded", flow.coded("pcaflow")),
    Input("rf", "ReynoldsFlow [|v_d|, |v_c|, f(t)], per-frame min-max, s = 1/255, λ = 1e-4", _rf()),
    Input("rf dc0", "ablation [|v_d|, 0, f(t)] (variant dc0)", _rf(variant="dc0")),
    Input("rf cd", "ablation [|v_c|, |v_d|, f(t)] (variant cd)", _rf(variant="cd")),
    Input("rf hsv", "ablation: v_R (this package's fields) HSV-coded as the flows", _rf_hsv),
)
REPRESENTATION = "rf"

# Settings of the representation, by name only (--inputs): each changes one
# setting of the default (per-frame min-max, s = 1/255, λ = 1e-4, variant
# "dc"); a smaller s comes with λ scaled by s² (as `reynoldsflow eval`
# does), which keeps λ's weight against the structure tensor and the
# engine's Λ4 = 65536·λ/s² unchanged.
SETTINGS = (
    Input("diff+gray", "[|f(t+1) - f(t)|, f(t)]", lambda f: np.concatenate([_diff(f), _gray(f)], axis=-1)),
    Input("rf-nogray", "[|v_d|, |v_c|] of rf, without the gray channel", _rf(channels=[0, 1])),
    Input("rf s=1/2550", "rf with s 10x smaller (λ = 1e-6)", _rf(intensity_scale=(1, 2550), lam=1e-6)),
    Input("rf s=1/25500", "rf with s 100x smaller (λ = 1e-8)", _rf(intensity_scale=(1, 25500), lam=1e-8)),
    Input("rf λ=1e-2", "rf with λ = 1e-2", _rf(lam=1e-2)),
    Input("rf λ=1e-6", "rf with λ = 1e-6", _rf(lam=1e-6)),
    Input("rf fixed(8,32)", "rf with fixed gains k_d = 8, k_c = 32 instead of min-max", _rf(scale=(8.0, 32.0))),
    Input("rf wheel", "variant hsv: this package's Middlebury colour wheel of v_R", _rf(variant="hsv")),
)
INPUTS = PAPER + SETTINGS
BY_NAME: Dict[str, Input] = {i.name: i for i in INPUTS}


def select(names: Sequence[str] | None) -> tuple:
    """The inputs named (the paper's comparison, PAPER, by default), in
    INPUTS order."""
    if not names:
        return PAPER
    unknown = [n for n in names if n not in BY_NAME]
    if unknown:
        raise ValueError(f"unknown inputs {unknown}; known: {', '.join(BY_NAME)}")
    return tuple(i for i in INPUTS if i.name in set(names))


def three_channels(data: np.ndarray) -> np.ndarray:
    """(N, H, W, C) uint8 with C in 1..3 -> (N, H, W, 3): one channel
    repeated, a missing third channel zero (what an RGB detector takes)."""
    c = data.shape[-1]
    if c == 3:
        return data
    if c == 1:
        return np.repeat(data, 3, axis=-1)
    return np.concatenate([data, np.zeros(data.shape[:-1] + (3 - c,), np.uint8)], axis=-1)

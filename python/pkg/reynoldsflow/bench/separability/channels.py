"""The channels of every input the downstream benchmark has, as float maps
aligned with frame t of each pair (t, t + 1).

Inputs whose image a detector sees are taken from the benchmark's own
``inputs`` (byte for byte what it trains on): ``gray``, ``diff``, the HSV
images of the five OpenCV flows, ``rf`` and its ablations, and the
representation's settings. Two more kinds are measured here only:

- ``<flow> |w|``: the flow's length in px per frame, unscaled (the flow
  "as magnitude"), from the same OpenCV call the HSV image codes;
- ``rf fields``: the package's float fields |v_d|, |v_c| and |v_R| before
  any scaling to 8 bits.

A constant channel (``rf dc0``'s zero channel) is left out.
"""

from __future__ import annotations

from typing import Dict, List, Sequence, Tuple

import numpy as np

import reynoldsflow as rf

from ..downstream import flow, inputs

RF_NAMES = ("|v_d|", "|v_c|", "f")
NAMES: Dict[str, Tuple[str, ...]] = {
    "gray": ("f",),
    "diff": ("|Δf|",),
    **{m: ("R", "G", "B") for m in flow.METHODS},
    **{f"{m} |w|": ("|w|",) for m in flow.METHODS},
    "rf": RF_NAMES,
    "rf dc0": ("|v_d|", "f"),
    "rf cd": ("|v_c|", "|v_d|", "f"),
    "rf hsv": ("R", "G", "B"),
    "rf fields": ("|v_d|", "|v_c|", "|v_R|"),
    "rf fixed(8,32)": RF_NAMES,
    "rf s=1/25500": RF_NAMES,
    "rf λ=1e-2": RF_NAMES,
}
# The study's inputs, in its tables' order: the benchmark's comparison, the
# flows as magnitudes, the unscaled fields and three settings.
DEFAULT = ("gray", "diff") + flow.METHODS + tuple(f"{m} |w|" for m in flow.METHODS) + (
    "rf", "rf dc0", "rf cd", "rf hsv", "rf fields", "rf fixed(8,32)", "rf s=1/25500", "rf λ=1e-2")
REFERENCE = "rf"


def select(names: Sequence[str] | None) -> Tuple[str, ...]:
    """The inputs named (DEFAULT when none), always with gray (the SCR
    gain's reference) and rf (the paired differences' reference)."""
    if not names:
        return DEFAULT
    unknown = [n for n in names if n not in NAMES]
    if unknown:
        raise ValueError(f"unknown inputs {unknown}; known: {', '.join(NAMES)}")
    want = set(names) | {"gray", REFERENCE}
    return tuple(n for n in NAMES if n in want)


def maps(frames: np.ndarray, names: Sequence[str]) -> List[Dict[str, np.ndarray]]:
    """Per pair of a (T, H, W) uint8 clip: input name -> (C, H, W) float32
    channels (NAMES[name] in order)."""
    out: List[Dict[str, np.ndarray]] = [dict() for _ in range(len(frames) - 1)]

    def put(name: str, data: np.ndarray, keep=None) -> None:
        for t in range(len(out)):
            d = data[t] if keep is None else data[t][..., keep]
            out[t][name] = np.ascontiguousarray(np.moveaxis(d.astype(np.float32), -1, 0))

    raw = {}
    for m in flow.METHODS:
        if m in names or f"{m} |w|" in names:
            calc = flow.raw(m)
            raw[m] = [calc(frames[t], frames[t + 1]) for t in range(len(out))]
    for name in names:
        if name in flow.METHODS:
            put(name, np.stack([flow.hsv(w) for w in raw[name]]))
        elif name.endswith(" |w|"):
            put(name, np.stack([np.hypot(w[..., 0], w[..., 1])[..., None] for w in raw[name[:-4]]]))
        elif name == "rf dc0":
            put(name, inputs.BY_NAME[name].make(frames), keep=[0, 2])
        elif name == "rf fields":
            per = []
            for t in range(len(out)):
                f = rf.fields(frames[t], frames[t + 1])
                per.append(np.stack([np.hypot(*np.moveaxis(f[k], -1, 0)) for k in ("v_d", "v_c", "v_R")], -1))
            put(name, np.stack(per))
        else:
            put(name, inputs.BY_NAME[name].make(frames))
    return out

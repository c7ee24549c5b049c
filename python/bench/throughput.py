"""Throughput of represent_clip against the command line on the same frames.

    target/python/venv/bin/python python/bench/throughput.py [--frames 60] [--size 640x480]

(scripts/test-python makes that environment; REYNOLDSFLOW_BIN, default
target/release/reynoldsflow, is the CLI.) The CLI reads the frames as raw
gray and streams RGB24 to a pipe (`run --raw WxH --out -`), so neither side
pays for image files; both use every core. Runs alternate, side by side in
one process, and the medians' ratio is printed: a bench, not a test.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import reynoldsflow as rf


def moving_clip(t: int, w: int, h: int, seed: int = 7) -> np.ndarray:
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    grain = np.random.default_rng(seed).integers(-6, 7, size=(h, w))
    frames = []
    for i in range(t):
        xs, ys = x - 1.5 * i, y - 0.5 * i
        base = 128 + 60 * np.sin(xs / 5.0) * np.cos(ys / 7.0) + 30 * np.sin((xs + ys) / 11.0)
        frames.append(np.clip(base + grain, 0, 255).astype(np.uint8))
    return np.stack(frames)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--frames", type=int, default=60)
    p.add_argument("--size", default="640x480")
    p.add_argument("--rounds", type=int, default=5)
    args = p.parse_args()
    w, h = map(int, args.size.split("x"))
    root = Path(__file__).resolve().parents[2]
    cli = os.environ.get("REYNOLDSFLOW_BIN", str(root / "target" / "release" / "reynoldsflow"))
    frames = moving_clip(args.frames, w, h)
    with tempfile.TemporaryDirectory() as tmp:
        raw = Path(tmp) / "frames.gray"
        raw.write_bytes(frames.tobytes())
        cmd = [cli, "run", str(raw), "--raw", f"{w}x{h}", "--out", "-", "--format", "rgb24"]

        def run_cli() -> bytes:
            return subprocess.run(cmd, check=True, capture_output=True).stdout

        # Same bytes first, so the two sides do the same work.
        assert run_cli() == rf.represent_clip(frames).tobytes(), "CLI and represent_clip differ"
        cli_s, py_s = [], []
        for _ in range(args.rounds):
            t0 = time.perf_counter()
            run_cli()
            cli_s.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            rf.represent_clip(frames)
            py_s.append(time.perf_counter() - t0)
    pairs = args.frames - 1
    cli_rate, py_rate = pairs / statistics.median(cli_s), pairs / statistics.median(py_s)
    print(f"{pairs} pairs of {w}x{h}, {os.cpu_count()} cores, median of {args.rounds} alternating runs:")
    print(f"  reynoldsflow run --raw ... --out -   {cli_rate:8.1f} pairs/s")
    print(f"  reynoldsflow.represent_clip          {py_rate:8.1f} pairs/s")
    print(f"  represent_clip / CLI = {py_rate / cli_rate:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The GPU check of reynoldsflow.torch.represent_batch: on a CUDA machine
with the wheel installed, from the repository root,

    python python/bench/gpu_check.py

1. compares represent_batch on CUDA with the Rust core
   (reynoldsflow.represent and reynoldsflow.fields on the CPU) on the
   golden pairs (tests/vectors, and the float32 planes of
   tests/golden/*/fields.bin), on 1 000 generated pairs up to 160x120 and
   on the 64 pairs of 640x480 that step 4 times, at both parameter sets,
   both scalings and the three variants: RGB byte for byte, v_c and v_d
   bit for bit;
2. checks CUDA's torch.sqrt, and represent_batch's root, against the
   correctly rounded root on the CPU (NumPy's) on every non-negative finite
   float32 bit pattern (2^31 - 2^23 of them, in chunks);
3. checks 1e8 CUDA divisions against the CPU's, drawn from the tail's
   ranges (v_d's unit over det in [Λ4², 2^62], 255 over min-max ranges
   from 1e-9 px);
4. checks its CUDA memory against the documented bound, and times
   represent_batch on CUDA at batches of 1, 16 and 64 pairs of
   640x480 against the CPU core (represent_clip, one thread and every
   core), in pairs per second, each timed batch's bytes compared with the
   core's;

printing torch's, CUDA's, the driver's and the GPU's names first. Exits 0
when everything is equal, 1 on any difference, 2 where there is no CUDA
device (with that message). Made to finish in well under 5 minutes on one
H100.

``--cpu-timings`` runs only step 4 with represent_batch on the CPU, and
``--cpu-sqrt`` only step 2 on the CPU (no CUDA needed for either): the
figures of docs/python.md "On the GPU". ``--rehearse`` runs steps 1-3 on
the CPU, smaller: the tests' run of this script's own code.
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import NoReturn

REPO = Path(__file__).resolve().parents[2]


def refuse(message: str) -> NoReturn:
    print(f"gpu_check: {message}", file=sys.stderr)
    sys.exit(2)


try:
    import numpy as np
    import torch

    import reynoldsflow as rf
    from reynoldsflow.torch import represent_batch
except ImportError as e:
    refuse(f"needs numpy, torch and the reynoldsflow wheel: {e}")

PARAMS = [{}, {"intensity_scale": 1 / 1024, "lam": 1e-6}]
IMAGES = [
    {"scale": "minmax", "variant": "dc"},
    {"scale": (8, 32), "variant": "dc0"},
    {"scale": "minmax", "variant": "cd"},
    {"scale": "fixed:0.5,2", "variant": "dc"},
]
SIZES = [(1, 1), (1, 13), (11, 1), (5, 7), (16, 16), (31, 23), (48, 64), (97, 61), (120, 160), (2, 3)]

# Where represent_batch runs: "cuda", or the CPU for --rehearse.
DEVICE = "cuda"


class Failures:
    """Differences found, printed as they come."""

    def __init__(self) -> None:
        self.count = 0

    def check(self, ok: bool, what: str) -> None:
        if not ok:
            self.count += 1
            if self.count <= 20:
                print(f"  DIFFERENT: {what}", flush=True)


def versions() -> None:
    try:
        smi = subprocess.run(
            ["nvidia-smi", "--query-gpu=driver_version", "--format=csv,noheader"],
            capture_output=True, text=True, timeout=30,
        ).stdout.strip().splitlines()
    except (OSError, subprocess.SubprocessError):
        smi = []
    print(f"torch {torch.__version__}, CUDA {torch.version.cuda}, driver {smi[0] if smi else 'unknown'}, "
          f"GPU {torch.cuda.get_device_name(0)}, reynoldsflow {rf.__version__}", flush=True)


def read_pgm(path: Path) -> np.ndarray:
    """A binary 8-bit PGM (tests/vectors' frames)."""
    data = path.read_bytes()
    fields, pos = [], 2
    while len(fields) < 3:
        while data[pos:pos + 1].isspace():
            pos += 1
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(int(data[pos:end]))
        pos = end
    w, h, _ = fields
    return np.frombuffer(data[pos + 1:pos + 1 + w * h], np.uint8).reshape(h, w).copy()


def bits(a) -> np.ndarray:
    return np.asarray(a, dtype=np.float32).view(np.int32)


def compare_batch(f0: np.ndarray, f1: np.ndarray, what: str, fails: Failures) -> None:
    """Every setting of PARAMS × IMAGES on DEVICE against the CPU core, for
    (B, H, W) pairs."""
    t0, t1 = torch.from_numpy(f0).to(DEVICE), torch.from_numpy(f1).to(DEVICE)
    for params in PARAMS:
        for image in IMAGES:
            rgb, fields = represent_batch(t0, t1, fields=True, **params, **image)
            rgb = rgb.cpu().numpy()
            for i in range(len(f0)):
                want = rf.represent(f0[i], f1[i], layout="chw", **params, **image)
                fails.check(np.array_equal(rgb[i], want), f"{what} pair {i} RGB {params} {image}")
        fields = {k: v.cpu().numpy() for k, v in fields.items()}
        for i in range(len(f0)):
            want = rf.fields(f0[i], f1[i], **params)
            for k in ("v_c", "v_d"):
                same = np.array_equal(bits(fields[k][i]), bits(np.moveaxis(want[k], -1, 0)))
                fails.check(same, f"{what} pair {i} {k} {params}")


def check_golden(fails: Failures) -> int:
    cases = sorted(p.name for p in (REPO / "tests" / "golden").iterdir() if p.is_dir())
    for case in cases:
        v = REPO / "tests" / "vectors" / case
        f0, f1 = read_pgm(v / "f0.pgm")[None], read_pgm(v / "f1.pgm")[None]
        compare_batch(f0, f1, case, fails)
        h, w = f0.shape[1:]
        planes = np.frombuffer((REPO / "tests" / "golden" / case / "fields.bin").read_bytes(), "<f4")
        _, got = represent_batch(torch.from_numpy(f0).to(DEVICE), torch.from_numpy(f1).to(DEVICE), fields=True)
        got = torch.cat([got["v_c"][0], got["v_d"][0], got["m_c"], got["m_d"]]).cpu().numpy()
        fails.check(np.array_equal(bits(got), bits(planes.reshape(6, h, w))), f"{case} fields.bin")
    return len(cases)


def generated(kind: int, h: int, w: int, rng: np.random.Generator):
    """Random, small changes, 0/255 checkerboards, steps, flat, ramps, saturated."""
    y, x = np.mgrid[0:h, 0:w]
    if kind == 0:
        return rng.integers(0, 256, (2, h, w), dtype=np.uint8)
    if kind == 1:
        f0 = rng.integers(0, 256, (h, w))
        return f0.astype(np.uint8), np.clip(f0 + rng.integers(-2, 3, (h, w)), 0, 255).astype(np.uint8)
    if kind == 2:
        k = int(rng.integers(1, 4))
        board = ((x // k + y // k) % 2 * 255).astype(np.uint8)
        return board, np.roll(board, 1, axis=1)
    if kind == 3:
        at = int(rng.integers(0, w + 1))
        return ((x >= at) * 255).astype(np.uint8), ((x >= at + 1) * 255).astype(np.uint8)
    if kind == 4:
        v = int(rng.integers(0, 255))
        return np.full((h, w), v, np.uint8), np.full((h, w), v + 1, np.uint8)
    if kind == 5:
        gx, gy = rng.uniform(-9, 9, 2)
        ramp = lambda s: np.clip(128 + gx * (x - s) + gy * y, 0, 255).astype(np.uint8)
        return ramp(0), ramp(1)
    return (rng.integers(0, 2, (2, h, w)) * 255).astype(np.uint8)


def check_generated(fails: Failures, count: int = 1000) -> int:
    rng = np.random.default_rng(2026)
    per_size = math.ceil(count / len(SIZES))
    for h, w in SIZES:
        pairs = [generated(i % 7, h, w, rng) for i in range(per_size)]
        f0, f1 = np.stack([p for p, _ in pairs]), np.stack([n for _, n in pairs])
        compare_batch(f0, f1, f"{w}x{h}", fails)
    return per_size * len(SIZES)


def check_sqrt(fails: Failures, device: str = "cuda", end: int = 0x7F800000) -> int:
    """On every non-negative finite float32, against IEEE's correctly
    rounded root (NumPy's: the CPU's sqrt instruction): represent_batch's
    root (``_torch_core._sqrt``) must be equal; ``torch.sqrt`` is counted,
    and must be equal on CUDA (on the CPU, MKL's is not, by one ulp)."""
    from reynoldsflow._torch_core import _sqrt

    step = min(end, 1 << 25)
    raw = 0
    for start in range(0, end, step):
        pattern = np.arange(start, min(end, start + step), dtype=np.int32)
        want = np.sqrt(pattern.view(np.float32)).view(np.int32)
        x = torch.from_numpy(pattern).to(device).view(torch.float32)
        got = _sqrt(x).view(torch.int32).cpu().numpy()
        fails.check(np.array_equal(got, want), f"represent_batch's sqrt on {device}: patterns from {start:#x}")
        raw += int(np.count_nonzero(torch.sqrt(x).view(torch.int32).cpu().numpy() != want))
    print(f"  torch.sqrt on {device}: {raw} of {end} patterns not correctly rounded", flush=True)
    if device == "cuda":
        fails.check(raw == 0, f"CUDA torch.sqrt: {raw} patterns")
    return end


def check_divisions(fails: Failures, total: int = 100_000_000) -> int:
    """CUDA's a / b (tensor by tensor) against the CPU's: numerators the
    tail's units v_d (both parameter sets) and 255, denominators float32
    bit patterns uniform over det's range [1, 2^62] or over min-max ranges
    [1e-9, 2^20]."""
    from reynoldsflow._core_params import checked_settings, core_constants

    units = [core_constants(checked_settings("gpu_check", p)).v_d for p in PARAMS] + [255.0]
    as_bits = lambda x: int(np.array(x, np.float32).view(np.int32))
    spans = [(as_bits(1.0), as_bits(2.0**62)), (as_bits(1e-9), as_bits(2.0**20))]
    g = torch.Generator(device=DEVICE).manual_seed(49)
    chunk, done = min(total, 10_000_000), 0
    while done < total:
        n = min(chunk, total - done)
        lo, hi = spans[done // chunk % 2]
        den = torch.randint(lo, hi, (n,), device=DEVICE, generator=g, dtype=torch.int32).view(torch.float32)
        pick = torch.randint(0, len(units), (n,), device=DEVICE, generator=g)
        num = torch.tensor(units, device=DEVICE)[pick]
        got = torch.div(num, den).cpu()
        want = torch.div(num.cpu(), den.cpu())
        differ = int((got.view(torch.int32) != want.view(torch.int32)).count_nonzero())
        fails.check(differ == 0, f"division: {differ} of {n}")
        done += n
    return total


def check_memory(fails: Failures) -> int:
    """represent_batch's CUDA memory against its bound: one 640x480 pair
    (fields too) within WORKING_BYTES_PER_PIXEL of its padded frames, and
    16 pairs within the default budget plus their results."""
    from reynoldsflow import _torch_batch, _torch_core

    frames = torch.from_numpy(moving_clip(17, 640, 480)).cuda()

    def peak(b: int, fields: bool) -> int:
        torch.cuda.synchronize()
        torch.cuda.reset_peak_memory_stats()
        before = torch.cuda.memory_allocated()
        result = represent_batch(frames[:b], frames[1:b + 1], fields=fields)
        torch.cuda.synchronize()
        del result
        return torch.cuda.max_memory_allocated() - before

    one = peak(1, True) / ((480 + 14) * (640 + 14))
    print(f"  one pair: {one:.0f} bytes a padded pixel (bound {_torch_core.WORKING_BYTES_PER_PIXEL})", flush=True)
    fails.check(one <= _torch_core.WORKING_BYTES_PER_PIXEL, f"one pair takes {one:.0f} bytes a padded pixel")
    sixteen = peak(16, False)
    bound = _torch_batch.DEFAULT_MEMORY_BUDGET + 16 * 3 * 480 * 640
    print(f"  16 pairs: {sixteen / 2**20:.0f} MiB (bound {bound / 2**20:.0f} MiB)", flush=True)
    fails.check(sixteen <= bound, f"16 pairs take {sixteen} bytes")
    return 17


def check_timed_frames(fails: Failures, pairs: int = 64) -> int:
    """The frames step 4 times (640x480, moving), ``pairs`` of them in one
    batch, at every setting, against the core (as check_generated)."""
    frames = moving_clip(pairs + 1, 640, 480)
    compare_batch(frames[:-1], frames[1:], "640x480", fails)
    return pairs


def moving_clip(t: int, w: int, h: int) -> np.ndarray:
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    grain = np.random.default_rng(7).integers(-6, 7, size=(h, w))
    frames = []
    for i in range(t):
        xs, ys = x - 1.5 * i, y - 0.5 * i
        base = 128 + 60 * np.sin(xs / 5.0) * np.cos(ys / 7.0) + 30 * np.sin((xs + ys) / 11.0)
        frames.append(np.clip(base + grain, 0, 255).astype(np.uint8))
    return np.stack(frames)


def timings(device: str, fails: Failures, rounds: int = 3) -> None:
    """Pairs per second at 640x480: represent_batch on ``device`` (CUDA:
    batches of 1, 16 and 64; the CPU: batches of 1 and 16 on one torch
    thread, and 16 on every core) against the CPU core (one thread, every
    core), interleaved, medians; the ratio to the core on every core.
    Every timed batch's bytes are compared with the core's (after its
    timing)."""
    frames = moving_clip(65, 640, 480)
    core = torch.from_numpy(rf.represent_clip(frames, layout="chw"))
    t = torch.from_numpy(frames).to(device)
    sync = torch.cuda.synchronize if device == "cuda" else (lambda: None)
    cores = os.cpu_count() or 1

    def torch_rate(b: int, threads: int) -> float:
        before = torch.get_num_threads()
        torch.set_num_threads(threads)
        try:
            start = time.perf_counter()
            got = represent_batch(t[:b], t[1:b + 1])
            sync()
            rate = b / (time.perf_counter() - start)
        finally:
            torch.set_num_threads(before)
        fails.check(torch.equal(got.cpu(), core[:b]), f"timed 640x480 batch of {b} on {device}")
        return rate

    def core_rate(threads: int) -> float:
        start = time.perf_counter()
        rf.represent_clip(frames, threads=threads, layout="chw")
        return 64 / (time.perf_counter() - start)

    if device == "cuda":
        cases = [(b, torch.get_num_threads()) for b in (1, 16, 64)]
    else:
        cases = [(1, 1), (16, 1), (16, cores)]
    runs = {f"represent_batch {device}, batch {b}"
            + ("" if device == "cuda" else f", {n} torch thread{'s' * (n > 1)}"):
            (lambda b=b, n=n: torch_rate(b, n)) for b, n in cases}
    runs["core, 1 thread"] = lambda: core_rate(1)
    runs[f"core, {cores} threads"] = lambda: core_rate(cores)
    for run in runs.values():  # warm up
        run()
    rates = {name: [] for name in runs}
    for _ in range(rounds):
        for name, run in runs.items():
            rates[name].append(run())
    every = sorted(rates[f"core, {cores} threads"])[rounds // 2]
    print(f"640x480 pairs/s (median of {rounds}; ratio to the core on {cores} threads):")
    for name, r in rates.items():
        median = sorted(r)[rounds // 2]
        print(f"  {name:<48} {median:9.1f}   {median / every:6.3f}", flush=True)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cpu-timings", action="store_true", help="only the timings, represent_batch on the CPU")
    p.add_argument("--cpu-sqrt", action="store_true", help="only the square roots, on the CPU")
    p.add_argument("--rehearse", action="store_true",
                   help="the CUDA path's comparisons on the CPU, smaller (tests this script; checks no GPU)")
    args = p.parse_args()
    if args.cpu_sqrt:
        fails = Failures()
        started = time.perf_counter()
        n = check_sqrt(fails, "cpu")
        print(f"sqrt patterns: {n}, {'equal' if fails.count == 0 else 'DIFFERENT'} "
              f"({time.perf_counter() - started:.0f} s)")
        return 0 if fails.count == 0 else 1
    if args.cpu_timings:
        print(f"torch {torch.__version__}, reynoldsflow {rf.__version__}, {os.cpu_count()} CPUs, "
              f"torch threads {torch.get_num_threads()}")
        fails = Failures()
        timings("cpu", fails)
        print(f"timed batches: {'equal' if fails.count == 0 else 'DIFFERENT'}")
        return 0 if fails.count == 0 else 1
    global DEVICE
    if args.rehearse:
        # The steps below on the CPU, smaller: a test of this script where
        # there is no GPU, not a check of one.
        DEVICE = "cpu"
        steps = [("golden pairs", check_golden), ("generated pairs", lambda f: check_generated(f, 70)),
                 ("640x480 pairs", lambda f: check_timed_frames(f, 2)),
                 ("sqrt patterns", lambda f: check_sqrt(f, "cpu", 1 << 22)),
                 ("divisions", lambda f: check_divisions(f, 1_000_000))]
    elif not torch.cuda.is_available():
        refuse("no CUDA device (torch.cuda.is_available() is False); run it on a machine with an "
               "NVIDIA GPU and a CUDA build of torch (--cpu-timings times the CPU path only)")
    else:
        versions()
        steps = [("golden pairs", check_golden), ("generated pairs", check_generated),
                 ("640x480 pairs", check_timed_frames), ("sqrt patterns", check_sqrt), ("divisions", check_divisions),
                 ("memory, frames", check_memory)]
    fails = Failures()
    started = time.perf_counter()
    for name, step in steps:
        before = fails.count
        n = step(fails)
        print(f"{name}: {n}, {'equal' if fails.count == before else 'DIFFERENT'} "
              f"({time.perf_counter() - started:.0f} s)", flush=True)
    if not args.rehearse:
        before = fails.count
        timings("cuda", fails)
        print(f"timed batches: {'equal' if fails.count == before else 'DIFFERENT'}", flush=True)
    print(f"total {time.perf_counter() - started:.0f} s; "
          f"{'every value equal' if fails.count == 0 else f'{fails.count} differences'}")
    return 0 if fails.count == 0 else 1


if __name__ == "__main__":
    sys.exit(main())

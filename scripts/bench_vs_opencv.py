#!/usr/bin/env python3
"""Side-by-side timing: OpenCV DIS optical flow (PRESET_ULTRAFAST) against
the reynoldsflow fixed engine, on the same PGM frame pairs, in one run,
interleaved A/B/A/B. Run it through scripts/bench-vs-opencv, which makes the
virtual environment and builds our timing binary (host/benches/pair_timing.rs).

Each round times a block of DIS calls in this process (frames loaded once,
only `calc` timed) and a block of ours in a fresh `pair_timing` process
(frames loaded once, only the computation timed); per configuration the
report gives the median ms per pair over all calls, and the ratio
DIS ms / ours ms (> 1: ours is faster) from those medians, with the range
of the per-round ratios.

Configurations:
  1 thread   DIS with cv2.setNumThreads(1)  vs  ours serial (`represent`,
             Engine<142> strips, one engine pass; and the two-pass per-frame
             min-max)
  all cores  DIS with OpenCV's default threads  vs  ours parallel
             (`represent_parallel`, 2 threads)
  dispatch   ours compiled for the baseline (SSE2) vs ours as dispatched at
             run time (AVX2 where the CPU has it), one thread, one pass
  scaling    ours parallel 1 thread vs 2 threads at 1280x720

With --cli (the `reynoldsflow` binary), also what a user runs, on a Y4M
sequence of SEQ_FRAMES textured moving frames (target/bench-frames/), in
--run-rounds interleaved rounds; per round one `reynoldsflow run SEQ.y4m
--out - --format rgb24 --threads N` process (wall time from start to exit:
start-up, reading, computing and writing all included) divided by its pairs:
  run 1t       DIS ultrafast 1 thread on the same consecutive pairs (frames
               in memory, only `calc` timed)  vs  `run --threads 1`, default
               scaling (per-frame min-max), 640x480
  run scaling  `run --threads 1` vs `run --threads 2` at 1280x720
  run ceiling  one `run --threads 1` process vs two of them at once (ms per
               pair of the pair of processes: wall time over both's pairs),
               1280x720: the throughput two cores give this work as
               independent processes, the ceiling of `run scaling`
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

import cv2
import numpy as np


def textured_pair(w, h, seed=7):
    """A textured pair with motion: multi-scale smoothed noise plus a few
    hard-edged shapes; frame 1 is frame 0 under a small rotation, zoom and
    a (1.6, 0.8) px translation (bilinear), each with its own sensor noise."""
    rng = np.random.default_rng(seed)
    pad = 32
    big = np.zeros((h + 2 * pad, w + 2 * pad), np.float64)
    for cell, weight in [(64, 0.45), (16, 0.3), (5, 0.17), (1.5, 0.08)]:
        small = rng.random((int((h + 2 * pad) / cell) + 2, int((w + 2 * pad) / cell) + 2))
        big += weight * cv2.resize(small, (w + 2 * pad, h + 2 * pad), interpolation=cv2.INTER_CUBIC)
    img = 30 + 190 * (big - big.min()) / (big.max() - big.min())
    for _ in range(12):
        x, y = rng.integers(0, w + 2 * pad), rng.integers(0, h + 2 * pad)
        r = int(rng.integers(8, max(9, min(w, h) // 8)))
        cv2.circle(img, (int(x), int(y)), r, float(rng.integers(0, 255)), -1, cv2.LINE_AA)
    center = ((w + 2 * pad) / 2, (h + 2 * pad) / 2)
    m = cv2.getRotationMatrix2D(center, 0.4, 1.005)
    m[:, 2] += (1.6, 0.8)
    moved = cv2.warpAffine(img, m, (w + 2 * pad, h + 2 * pad), flags=cv2.INTER_LINEAR,
                           borderMode=cv2.BORDER_REFLECT)
    frames = []
    for k, f in enumerate([img, moved]):
        noise = np.random.default_rng(seed * 10 + k).normal(0, 1.0, f.shape)
        frames.append(np.clip(f + noise, 0, 255)[pad:pad + h, pad:pad + w].round().astype(np.uint8))
    return frames


def write_pgm(path, img):
    h, w = img.shape
    with open(path, "wb") as f:
        f.write(b"P5\n%d %d\n255\n" % (w, h))
        f.write(np.ascontiguousarray(img).tobytes())


def read_pgm(path):
    with open(path, "rb") as f:
        data = f.read()
    fields, at = [], 0
    while len(fields) < 4:
        while data[at:at + 1].isspace():
            at += 1
        if data[at:at + 1] == b"#":
            at = data.index(b"\n", at)
            continue
        start = at
        while not data[at:at + 1].isspace():
            at += 1
        fields.append(data[start:at])
    assert fields[0] == b"P5" and fields[3] == b"255", path
    w, h = int(fields[1]), int(fields[2])
    return np.frombuffer(data, np.uint8, w * h, at + 1).reshape(h, w)


def time_dis(prev, nxt, threads, seconds, min_iters, warmup=3):
    cv2.setNumThreads(threads)
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST)
    flow = None
    for _ in range(warmup):
        flow = dis.calc(prev, nxt, None)
    times = []
    start = time.perf_counter()
    while len(times) < min_iters or time.perf_counter() - start < seconds:
        t = time.perf_counter()
        flow = dis.calc(prev, nxt, None)
        times.append((time.perf_counter() - t) * 1e3)
    return times, flow


SEQ_FRAMES = 31


def textured_sequence(w, h, frames, seed=11):
    """`frames` frames of a textured scene panning by (1.6, 0.8) px and
    turning by 0.1 degree per frame, each with its own sensor noise."""
    rng = np.random.default_rng(seed)
    base = textured_pair(w + 128, h + 128, seed)[0].astype(np.float64)
    center = ((w + 128) / 2, (h + 128) / 2)
    out = []
    for t in range(frames):
        m = cv2.getRotationMatrix2D(center, 0.1 * t, 1.0)
        m[:, 2] += (1.6 * t - 64, 0.8 * t - 64)
        f = cv2.warpAffine(base, m, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
        out.append(np.clip(f + rng.normal(0, 1.0, f.shape), 0, 255).round().astype(np.uint8))
    return out


def write_y4m(path, frames):
    h, w = frames[0].shape
    with open(path, "wb") as f:
        f.write(b"YUV4MPEG2 W%d H%d F25:1 Ip A1:1 Cmono\n" % (w, h))
        for frame in frames:
            f.write(b"FRAME\n")
            f.write(np.ascontiguousarray(frame).tobytes())


def time_dis_sequence(frames, threads, seconds, min_iters):
    """ms per pair of DIS over the sequence's consecutive pairs."""
    cv2.setNumThreads(threads)
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST)
    dis.calc(frames[0], frames[1], None)
    times = []
    start = time.perf_counter()
    while len(times) < min_iters or time.perf_counter() - start < seconds:
        for prev, nxt in zip(frames, frames[1:]):
            t = time.perf_counter()
            dis.calc(prev, nxt, None)
            times.append((time.perf_counter() - t) * 1e3)
    return times


def time_run(cli, y4m, pairs, threads, seconds, processes=1, min_runs=2):
    """ms per pair of whole `reynoldsflow run` processes streaming RGB24 to
    /dev/null, one figure per round: `processes` of them started together,
    wall time until all exit over all their pairs."""
    cmd = [cli, "run", y4m, "--out", "-", "--format", "rgb24", "--threads", str(threads)]
    times = []
    start = time.perf_counter()
    while len(times) < min_runs or time.perf_counter() - start < seconds:
        t = time.perf_counter()
        procs = [subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                 for _ in range(processes)]
        codes = [p.wait() for p in procs]
        if any(codes):
            raise subprocess.CalledProcessError(max(codes), cmd)
        times.append((time.perf_counter() - t) * 1e3 / (processes * pairs))
    return times


def time_ours(binary, paths, mode, threads, seconds, min_iters):
    out = subprocess.run(
        [binary, "--prev", paths[0], "--next", paths[1], "--mode", mode,
         "--threads", str(threads), "--seconds", str(seconds), "--min-iters", str(min_iters)],
        check=True, capture_output=True, text=True)
    line = [ln for ln in out.stdout.splitlines() if ln.startswith("{")][-1]
    return json.loads(line)["ms"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ours", required=True, help="path of the pair_timing binary")
    ap.add_argument("--frames", default="target/bench-frames")
    ap.add_argument("--rounds", type=int, default=4, help="A/B rounds per configuration")
    ap.add_argument("--seconds", type=float, default=0.6, help="minimum time of one block")
    ap.add_argument("--sizes", default="640x480,1280x720")
    ap.add_argument("--cli", help="path of the reynoldsflow binary: also time `reynoldsflow run`")
    ap.add_argument("--run-rounds", type=int, default=6, help="A/B rounds of the `run` rows")
    ap.add_argument("--only-run", action="store_true", help="time the `run` rows only")
    args = ap.parse_args()
    os.makedirs(args.frames, exist_ok=True)
    cores = os.cpu_count()
    default_threads = cv2.getNumThreads()
    print(f"OpenCV {cv2.__version__}, numpy {np.__version__}, {cores} cores, "
          f"OpenCV default threads {default_threads}; {args.rounds} interleaved A/B rounds, "
          f">= {args.seconds} s per block")

    results = []  # (label, size, a_name, a_times, b_name, b_times, round_ratios)

    def ab(label, size, a, b, rounds=None):
        """Rounds of A then B; a, b = (name, fn returning a list of ms)."""
        a_all, b_all, ratios = [], [], []
        for _ in range(rounds or args.rounds):
            ta = a[1]()
            tb = b[1]()
            a_all += ta
            b_all += tb
            ratios.append(statistics.median(ta) / statistics.median(tb))
        results.append((label, size, a[0], a_all, b[0], b_all, ratios))
        ma, mb = statistics.median(a_all), statistics.median(b_all)
        print(f"  {label:<10} {size:>9}  {a[0]:<26} {ma:9.3f} ms   {b[0]:<30} {mb:9.3f} ms   "
              f"A/B = {ma / mb:6.3f}  (rounds {min(ratios):.3f}..{max(ratios):.3f})", flush=True)

    for size in args.sizes.split(","):
        w, h = map(int, size.split("x"))
        paths = [os.path.join(args.frames, f"textured_{w}x{h}_{k}.pgm") for k in (0, 1)]
        for path, img in zip(paths, textured_pair(w, h)):
            write_pgm(path, img)
        prev, nxt = (read_pgm(p) for p in paths)
        _, flow = time_dis(prev, nxt, 1, 0.0, 1, warmup=0)
        mag = np.hypot(flow[..., 0], flow[..., 1])
        print(f"{size}: {paths[0]}, {paths[1]}; DIS flow: median |v| {np.median(mag):.2f} px, "
              f"mean v ({flow[..., 0].mean():.2f}, {flow[..., 1].mean():.2f}) px")
        s, n = args.seconds, 10

        def dis(threads):
            return lambda: time_dis(prev, nxt, threads, s, n)[0]

        def ours(mode, threads):
            return lambda: time_ours(args.ours, paths, mode, threads, s, n)

        if args.cli:
            seq = textured_sequence(w, h, SEQ_FRAMES)
            y4m = os.path.join(args.frames, f"textured_{w}x{h}_{SEQ_FRAMES}.y4m")
            write_y4m(y4m, seq)
            pairs = SEQ_FRAMES - 1

            def run(threads, processes=1):
                return lambda: time_run(args.cli, y4m, pairs, threads, s, processes)

            if (w, h) == (640, 480):
                ab("run 1t", size, ("DIS ultrafast 1t", lambda: time_dis_sequence(seq, 1, s, n)),
                   ("reynoldsflow run --threads 1", run(1)), args.run_rounds)
            if (w, h) == (1280, 720):
                ab("run scale", size, ("reynoldsflow run --threads 1", run(1)),
                   (f"reynoldsflow run --threads {cores}", run(cores)), args.run_rounds)
                ab("run ceil", size, ("reynoldsflow run --threads 1", run(1)),
                   ("two of them at once", run(1, processes=2)),
                   args.run_rounds)
        if args.only_run:
            continue

        ab("1 thread", size, ("DIS ultrafast 1t", dis(1)), ("ours serial 1t (1 pass)", ours("serial", 1)))
        ab("1 thread", size, ("DIS ultrafast 1t", dis(1)),
           ("ours serial 1t (min-max, 2 p.)", ours("serial-minmax", 1)))
        ab("dispatch", size, ("ours portable 1t", ours("serial-portable", 1)),
           ("ours serial 1t (1 pass)", ours("serial", 1)))
        ab("all cores", size, (f"DIS ultrafast {default_threads}t", dis(default_threads)),
           (f"ours parallel {cores}t", ours("parallel", cores)))
        if (w, h) == (1280, 720):
            ab("scaling", size, ("ours parallel 1t", ours("parallel", 1)),
               (f"ours parallel {cores}t", ours("parallel", cores)))

    print("\nSummary (median ms per pair; ratio = A ms / B ms, > 1 means B is faster):")
    for label, size, an, at, bn, bt, ratios in results:
        ma, mb = statistics.median(at), statistics.median(bt)
        print(f"  {size:>9} {label:<10} {an} {ma:.3f} ms | {bn} {mb:.3f} ms | ratio {ma / mb:.3f} "
              f"[{min(ratios):.3f}, {max(ratios):.3f}]  (n = {len(at)}, {len(bt)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())

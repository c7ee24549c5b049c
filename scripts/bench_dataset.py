#!/usr/bin/env python3
"""What writing files costs `reynoldsflow run` and `dataset`: side-by-side
timings in one run, interleaved round by round. Run it through
scripts/bench-dataset, which builds the tool and the virtual environment.

1. One thread, a 640x480 H.264 clip (made with ffmpeg unless --clip): pairs
   per second of whole `reynoldsflow run CLIP --threads 1` processes (wall
   time from start to exit over the clip's pairs), each output beside the
   same round's `--out - --format rgb24 > /dev/null` (decode + engine):
   PNG at each --png-compression, JPEG (quality 95) at 4:4:4 and 4:2:0;
   with --baseline BIN, the same rows of another build of the tool; and the
   OpenCV script a user would write instead (decode, DIS ultrafast, HSV
   image, cv2.imwrite PNG), in this process. Bytes per file for each.
2. Encoder CPU per frame: this tool's PNG and JPEG (4:4:4, 4:2:0) as the
   CPU each row of 1 spends beyond the same round's rgb24 run, beside
   `cv2.imwrite` JPEG (quality 95, 4:4:4 and 4:2:0) and PNG writing the same
   results (this tool's PNGs, decoded first) to files.
3. The JPEG files' mean absolute difference from the PNGs' bytes (the
   representation), quality 95, over every result of the clip.
4. `reynoldsflow dataset` on a tree of --items clips cut from the clip, at
   1 thread and at all cores (--force: every item made each time), PNG and
   JPEG; with --baseline, the other build's beside it.

Medians over --rounds rounds; the ratios in brackets are the per-round
range. Other processes on the machine slow every row alike within a round:
compare ratios, and read `uptime` (printed first and last).
"""

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import time

import cv2
import numpy as np


def make_clip(path, frames):
    """A 640x480 H.264 clip of a slowly zooming Mandelbrot set with sensor-
    like noise: texture and motion everywhere, as in real footage."""
    subprocess.run(
        ["ffmpeg", "-v", "error", "-y", "-f", "lavfi", "-i",
         "mandelbrot=s=640x480:rate=25:maxiter=256,noise=alls=6:allf=t",
         "-frames:v", str(frames), "-c:v", "libx264", "-crf", "20",
         "-pix_fmt", "yuv420p", path],
        check=True)


def count_frames(path):
    cap = cv2.VideoCapture(path)
    n = 0
    while cap.read()[0]:
        n += 1
    return n


def make_tree(clip, tree, items, frames, total):
    """`items` H.264 clips of `frames` frames each, cut from `clip` (of
    `total` frames; around again when it is too short), in two sub-folders."""
    shutil.rmtree(tree, ignore_errors=True)
    for i in range(items):
        start = i * frames % max(1, total - frames + 1)
        sub = os.path.join(tree, f"part{i % 2}")
        os.makedirs(sub, exist_ok=True)
        subprocess.run(
            ["ffmpeg", "-v", "error", "-y", "-i", clip, "-vf",
             f"select='between(n,{start},{start + frames - 1})',setpts=N/25/TB",
             "-frames:v", str(frames), "-c:v", "libx264", "-crf", "20", "-pix_fmt", "yuv420p",
             os.path.join(sub, f"clip{i:02}.mp4")],
            check=True)


def cpu_seconds(who):
    """User + system seconds of this process (RUSAGE_SELF) or of its
    finished children (RUSAGE_CHILDREN) so far."""
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def timed(cmd, out_dir=None, stdout=subprocess.DEVNULL):
    """Wall seconds of one process, and its CPU seconds (its own and its
    children's: ffmpeg's decoding included); `out_dir` is emptied first
    (not timed)."""
    if out_dir:
        shutil.rmtree(out_dir, ignore_errors=True)
    cpu, t = cpu_seconds(resource.RUSAGE_CHILDREN), time.perf_counter()
    subprocess.run(cmd, stdout=stdout, stderr=subprocess.DEVNULL, check=True)
    return time.perf_counter() - t, cpu_seconds(resource.RUSAGE_CHILDREN) - cpu


def files_of(folder, ext):
    paths = []
    for dirpath, _, names in os.walk(folder):
        paths += [os.path.join(dirpath, n) for n in names if n.endswith(ext)]
    return sorted(paths)


def bytes_per_file(folder, ext, first=None):
    files = files_of(folder, ext)[:first]
    return sum(os.path.getsize(f) for f in files) / max(len(files), 1)


def opencv_script(clip, out_dir):
    """What a user would write instead: decode, DIS ultrafast on gray
    frames, the colour-wheel image of the flow, cv2.imwrite PNG."""
    shutil.rmtree(out_dir, ignore_errors=True)
    os.makedirs(out_dir)
    cpu, t = cpu_seconds(resource.RUSAGE_SELF), time.perf_counter()
    cap = cv2.VideoCapture(clip)
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST)
    ok, frame = cap.read()
    prev = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
    hsv = np.zeros(frame.shape, np.uint8)
    hsv[..., 1] = 255
    n = 0
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        gray = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        flow = dis.calc(prev, gray, None)
        mag, ang = cv2.cartToPolar(flow[..., 0], flow[..., 1])
        hsv[..., 0] = ang * (90 / np.pi)
        hsv[..., 2] = cv2.normalize(mag, None, 0, 255, cv2.NORM_MINMAX)
        cv2.imwrite(os.path.join(out_dir, f"{n:06}.png"), cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR))
        prev, n = gray, n + 1
    return time.perf_counter() - t, cpu_seconds(resource.RUSAGE_SELF) - cpu


def imwrite_cpu(images, out_dir, ext, params):
    """CPU seconds of `cv2.imwrite` writing each of `images` (BGR arrays,
    decoded beforehand) to a file of `out_dir`."""
    shutil.rmtree(out_dir, ignore_errors=True)
    os.makedirs(out_dir)
    cpu = cpu_seconds(resource.RUSAGE_SELF)
    for n, image in enumerate(images):
        cv2.imwrite(os.path.join(out_dir, f"{n:06}.{ext}"), image, params)
    return cpu_seconds(resource.RUSAGE_SELF) - cpu


def summary(values):
    return statistics.median(values), min(values), max(values)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cli", required=True, help="the reynoldsflow binary")
    ap.add_argument("--baseline", help="another reynoldsflow binary, timed beside it")
    ap.add_argument("--work", required=True, help="folder for the clip, tree and outputs")
    ap.add_argument("--clip", help="a video to use instead of the generated clip")
    ap.add_argument("--frames", type=int, default=100, help="frames of the generated clip")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--items", type=int, default=8, help="clips in the dataset tree")
    ap.add_argument("--item-frames", type=int, default=25)
    args = ap.parse_args()
    cv2.setNumThreads(1)
    os.makedirs(args.work, exist_ok=True)
    print("uptime:", subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())
    clip = args.clip
    if not clip:
        clip = os.path.join(args.work, "clip.mp4")
        make_clip(clip, args.frames)
    pairs = count_frames(clip) - 1
    out = lambda name: os.path.join(args.work, name)

    # 1. One thread, each output beside rgb24 to /dev/null.
    def run_row(binary, flags, name):
        cmd = [binary, "run", clip, "--threads", "1", "--out", out(name)] + flags
        return lambda: timed(cmd, out(name))
    # zlib's levels are an order of magnitude slower: timed on the first frames only.
    slow = min(pairs, 24)
    null = open(os.devnull, "wb")
    rows = [("`--out - --format rgb24` to /dev/null (decode + engine)", None,
             lambda: timed([args.cli, "run", clip, "--threads", "1", "--out", "-", "--format", "rgb24"], stdout=null)),
            ("`--out DIR` (PNG, `--png-compression fast`, the default)", ("png", "png-fast"),
             run_row(args.cli, [], "png-fast")),
            (f"`--out DIR --png-compression default` (first {slow} pairs)", ("png", "png-default"),
             run_row(args.cli, ["--png-compression", "default", "--max-frames", str(slow + 1)], "png-default")),
            (f"`--out DIR --png-compression best` (first {slow} pairs)", ("png", "png-best"),
             run_row(args.cli, ["--png-compression", "best", "--max-frames", str(slow + 1)], "png-best")),
            ("`--out DIR --image-format jpg` (4:4:4, the default)", ("jpg", "jpg-444"),
             run_row(args.cli, ["--image-format", "jpg"], "jpg-444")),
            ("`--out DIR --image-format jpg --jpeg-subsampling 420`", ("jpg", "jpg-420"),
             run_row(args.cli, ["--image-format", "jpg", "--jpeg-subsampling", "420"], "jpg-420"))]
    if args.baseline:
        rows += [("baseline: `--format rgb24` to /dev/null", None,
                  lambda: timed([args.baseline, "run", clip, "--threads", "1", "--out", "-", "--format", "rgb24"], stdout=null)),
                 ("baseline: `--out DIR` (PNG)", ("png", "base-png"), run_row(args.baseline, [], "base-png")),
                 ("baseline: `--out DIR --image-format jpg`", ("jpg", "base-jpg"),
                  run_row(args.baseline, ["--image-format", "jpg"], "base-jpg"))]
    rows.append(("OpenCV script (decode, DIS ultrafast, HSV image, `cv2.imwrite` PNG)", ("png", "opencv"),
                 lambda: opencv_script(clip, out("opencv"))))
    base_ref = next((i for i, r in enumerate(rows) if r[0].startswith("baseline")), 0)
    seconds = [[] for _ in rows]
    cpus = [[] for _ in rows]
    for _ in range(args.rounds):
        for i, (_, _, fn) in enumerate(rows):
            wall, cpu = fn()
            seconds[i].append(wall)
            cpus[i].append(cpu)
    print(f"\n### `reynoldsflow run --threads 1`, {pairs} pairs of a 640x480 H.264 clip, {args.rounds} rounds\n")
    print("| output | pairs/s | of the same round's rgb24 run | CPU ms per pair | bytes per file |")
    print("|---|---:|---:|---:|---:|")
    for i, (label, files, _) in enumerate(rows):
        n = slow if "first" in label else pairs
        rate = n / statistics.median(seconds[i])
        # Each row against the rgb24 run of its own build (this tool's, or
        # the baseline's), per pair.
        ref = base_ref if label.startswith("baseline") else 0
        ratios = [seconds[ref][r] / pairs / (seconds[i][r] / n) for r in range(args.rounds)]
        mid, lo, hi = summary(ratios)
        size = f"{bytes_per_file(out(files[1]), files[0]) / 1024:.0f} KiB" if files else "–"
        ratio = f"{mid:.2f} [{lo:.2f}, {hi:.2f}]" if not label.startswith("OpenCV") else "–"
        cpu = 1000 * statistics.median(cpus[i]) / n
        print(f"| {label} | {rate:.0f} | {ratio} | {cpu:.2f} | {size} |")

    # 2. The encoders alone, per frame: this tool's as the CPU its `--out DIR`
    # run spends beyond the same round's rgb24 run (encoding and writing the
    # file), beside cv2.imwrite writing the same results (this tool's PNGs,
    # decoded first) to files.
    print(f"\n### Encoder CPU per frame (640x480 results of the clip, {args.rounds} rounds)\n")
    print("| encoder | CPU ms per frame | bytes per file |")
    print("|---|---:|---:|")
    for i, (label, files, _) in enumerate(rows):
        if not files or "first" in label or label.startswith("OpenCV"):
            continue
        ref = base_ref if label.startswith("baseline") else 0
        extra = [cpus[i][r] - cpus[ref][r] for r in range(args.rounds)]
        size = bytes_per_file(out(files[1]), files[0]) / 1024
        print(f"| reynoldsflow {label} | {1000 * statistics.median(extra) / pairs:.2f} | {size:.0f} KiB |")
    images = [cv2.imread(png, cv2.IMREAD_COLOR) for png in files_of(out("png-fast"), ".png")]
    for label, name, ext, params in [
            ("`cv2.imwrite` JPEG quality 95, 4:4:4", "cv-jpg-444", "jpg",
             [cv2.IMWRITE_JPEG_QUALITY, 95, cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444]),
            ("`cv2.imwrite` JPEG quality 95, 4:2:0", "cv-jpg-420", "jpg",
             [cv2.IMWRITE_JPEG_QUALITY, 95, cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_420]),
            ("`cv2.imwrite` PNG (OpenCV's default compression)", "cv-png", "png", [])]:
        cpu = statistics.median(imwrite_cpu(images, out(name), ext, params) for _ in range(args.rounds))
        size = bytes_per_file(out(name), "." + ext) / 1024
        print(f"| {label} | {1000 * cpu / len(images):.2f} | {size:.0f} KiB |")

    sizes = ", ".join(f"{level} {bytes_per_file(out('png-' + level), '.png', slow) / 1024:.0f} KiB"
                      for level in ["fast", "default", "best"])
    print(f"\nPNG bytes per file over the same first {slow} results: {sizes}")

    # 3. JPEG error against the representation.
    print("\n### JPEG (quality 95) against the PNGs' bytes, every result of the clip\n")
    pngs = files_of(out("png-fast"), ".png")
    for name in ["jpg-444", "jpg-420"]:
        total, count = 0.0, 0
        for png in pngs:
            jpg = os.path.join(out(name), os.path.basename(png)[:-4] + ".jpg")
            a = cv2.imread(png, cv2.IMREAD_COLOR).astype(np.int16)
            b = cv2.imread(jpg, cv2.IMREAD_COLOR).astype(np.int16)
            total += float(np.abs(a - b).sum())
            count += a.size
        print(f"- {name[4:]}: mean absolute difference {total / count:.2f} levels of 255")

    # 4. dataset on a tree, 1 thread and all cores.
    tree = out("tree")
    make_tree(clip, tree, args.items, args.item_frames, pairs + 1)
    tree_pairs = args.items * (args.item_frames - 1)
    cores = os.cpu_count() or 1
    builds = [("this build", args.cli)] + ([("baseline", args.baseline)] if args.baseline else [])
    cases = []
    for build, binary in builds:
        for fmt, flags in [("png", []), ("jpg", ["--image-format", "jpg"])]:
            for threads in [1, cores]:
                dst = out(f"ds-{build.split()[0]}-{fmt}-{threads}")
                cmd = [binary, "dataset", tree, dst, "--force", "--threads", str(threads)] + flags
                cases.append((build, fmt, threads, dst, (lambda c=cmd, d=dst: timed(c, d))))
    ds_seconds = [[] for _ in cases]
    for _ in range(args.rounds):
        for i, case in enumerate(cases):
            ds_seconds[i].append(case[4]()[0])
    print(f"\n### `reynoldsflow dataset`, {args.items} H.264 clips of {args.item_frames} frames "
          f"({tree_pairs} pairs), {args.rounds} rounds\n")
    print(f"| build | images | threads | pairs/s | of this build's 1 thread | of the baseline's | bytes per file |")
    print("|---|---|---:|---:|---:|---:|---:|")
    index = {(b, f, t): i for i, (b, f, t, _, _) in enumerate(cases)}
    for i, (build, fmt, threads, dst, _) in enumerate(cases):
        one = ds_seconds[index[(build, fmt, 1)]]
        mid, lo, hi = summary([one[r] / ds_seconds[i][r] for r in range(args.rounds)])
        vs_base = "–"
        if args.baseline and build == "this build":
            base = ds_seconds[index[("baseline", fmt, threads)]]
            bm, bl, bh = summary([base[r] / ds_seconds[i][r] for r in range(args.rounds)])
            vs_base = f"{bm:.2f} [{bl:.2f}, {bh:.2f}]"
        rate = tree_pairs / statistics.median(ds_seconds[i])
        size = bytes_per_file(dst, "." + fmt) / 1024
        print(f"| {build} | {fmt} | {threads} | {rate:.0f} | {mid:.2f} [{lo:.2f}, {hi:.2f}] | {vs_base} | {size:.0f} KiB |")
    print("\nuptime:", subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())


if __name__ == "__main__":
    sys.exit(main())

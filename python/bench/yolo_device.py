"""The YOLO11n table on one GPU: the downstream benchmark's YOLO detector
at the paper's input size (640, the 160x120 frames letterboxed up) for the
inputs that matter most -- gray, frame difference, the best classical flow
on these composites (TV-L1, the paper's best; Farneback, the best in the
separability study's HSV images) and the representation -- on both scene
families, sized to finish within 10 minutes of one H100. From the
repository root, with the wheel and python/requirements-test.txt installed:

    python python/bench/yolo_device.py --out DIR        # on the GPU machine
    python python/bench/yolo_device.py --out DIR --dry  # print the command only
    python python/bench/yolo_device.py --out DIR --smoke  # a tiny CPU run of the same path

It runs ``python -m reynoldsflow.bench.downstream --detectors yolo --device
cuda --imgsz 640`` with more clips and frames than the CPU run (see SIZE;
YOLO11n from scratch, offline, as that benchmark documents) and writes its
report.md, results.csv, intervals.csv and plot.png into DIR. Exits 2 where
there is no CUDA device (except --dry and --smoke).
"""

from __future__ import annotations

import argparse
import shlex
import subprocess
import sys

INPUTS = ("gray", "diff", "farneback", "tvl1", "rf")
# 5 seeds x 2 families x 5 inputs = 50 trainings of 30 epochs over 32
# clips x 12 frames (352 training images of 640 px); an H100 trains
# YOLO11n at ~1500 images/s at 640, so ~10 s a training plus data, well
# inside 10 minutes.
SIZE = dict(seeds=5, train_clips=32, test_clips=16, frames=12, epochs=30, yolo_batch=32)
SMOKE = dict(seeds=1, train_clips=4, test_clips=3, frames=4, epochs=1, yolo_batch=8)


def command(out: str, smoke: bool) -> list:
    size = SMOKE if smoke else SIZE
    argv = [sys.executable, "-m", "reynoldsflow.bench.downstream", "--out", out, "--detectors", "yolo",
            "--inputs", ",".join(INPUTS), "--device", "cpu" if smoke else "cuda", "--imgsz", "160" if smoke else "640"]
    for key, value in size.items():
        argv += ["--" + key.replace("_", "-"), str(value)]
    return argv


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True)
    p.add_argument("--dry", action="store_true", help="print the command, run nothing")
    p.add_argument("--smoke", action="store_true", help="a tiny run of the same path on the CPU")
    a = p.parse_args(argv)
    cmd = command(a.out, a.smoke)
    print(" ".join(shlex.quote(x) for x in cmd), flush=True)
    if a.dry:
        return 0
    if not a.smoke:
        import torch

        if not torch.cuda.is_available():
            print("yolo_device.py: no CUDA device (torch.cuda.is_available() is False)", file=sys.stderr)
            return 2
        print(f"yolo_device.py: {torch.cuda.get_device_name(0)}, torch {torch.__version__}", file=sys.stderr)
    return subprocess.run(cmd).returncode


if __name__ == "__main__":
    sys.exit(main())

"""Pairs per second through reynoldsflow.torch's IterableDataset in a
DataLoader against represent_clip on the same frames.

    target/python/venv/bin/python python/bench/torch_loader.py [--clips 96] [--frames 11] [--size 320x240] [--workers 2]

The clips are Y4M files in a temporary folder (the dataset reads and
decodes them; represent_clip gets the frames as arrays, every core). One
epoch of the DataLoader (batch_size=None, fresh workers each epoch, as a
training loop without persistent_workers starts them) alternates with one
represent_clip call per clip; the medians' ratio is printed. Items go to
workers by the hash of `reynoldsflow dataset --shard`, so a worker's share
is not exactly half: the split is printed too. A bench, not a test.
"""

import argparse
import statistics
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

from torch.utils.data import DataLoader

import reynoldsflow as rf
from reynoldsflow.torch import ReynoldsFlowDataset
# The moving texture of the other bench (this folder is on sys.path when
# a bench runs as a script).
from throughput import moving_clip


def write_y4m(path: Path, frames) -> None:
    t, h, w = frames.shape
    with open(path, "wb") as f:
        f.write(b"YUV4MPEG2 W%d H%d F30:1 Ip A1:1 Cmono\n" % (w, h))
        for frame in frames:
            f.write(b"FRAME\n" + frame.tobytes())


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--clips", type=int, default=96)
    p.add_argument("--frames", type=int, default=11)
    p.add_argument("--size", default="320x240")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--rounds", type=int, default=5)
    args = p.parse_args()
    w, h = map(int, args.size.split("x"))
    clips = [moving_clip(args.frames, w, h, seed) for seed in range(args.clips)]
    pairs = args.clips * (args.frames - 1)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for i, c in enumerate(clips):
            write_y4m(root / f"clip{i:04d}.y4m", c)
        dataset = ReynoldsFlowDataset(root)

        def loader_epoch() -> Counter:
            per_source = Counter()
            for _rep, meta in DataLoader(dataset, batch_size=None, num_workers=args.workers):
                per_source[meta["source"]] += 1
            return per_source

        def clip_calls() -> int:
            return sum(len(rf.represent_clip(c)) for c in clips)

        # The same work on both sides, and every pair once.
        got = loader_epoch()
        assert sum(got.values()) == pairs == clip_calls(), (sum(got.values()), pairs)
        shares = [sum(1 for _p, _r in rf.dataset_items(root, shard=(i, args.workers)))
                  for i in range(args.workers)]
        loader_s, clip_s = [], []
        for _ in range(args.rounds):
            t0 = time.perf_counter()
            loader_epoch()
            t1 = time.perf_counter()
            clip_calls()
            t2 = time.perf_counter()
            loader_s.append(t1 - t0)
            clip_s.append(t2 - t1)
    loader_rate = pairs / statistics.median(loader_s)
    clip_rate = pairs / statistics.median(clip_s)
    print(f"{args.clips} clips x {args.frames} frames, {w}x{h}: {pairs} pairs; "
          f"clips per worker (hash split): {shares}")
    print(f"represent_clip (every core): {clip_rate:.0f} pairs/s")
    print(f"DataLoader, {args.workers} workers: {loader_rate:.0f} pairs/s")
    print(f"dataloader_vs_represent_clip={loader_rate / clip_rate:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

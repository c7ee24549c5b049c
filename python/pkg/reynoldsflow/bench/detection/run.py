"""The command: python -m reynoldsflow.bench.detection --out DIR [--quick]
[--calibrate] [--seeds N] [--real-seeds N] [--backgrounds DIR] ...

One job per (scene family, seed) in worker processes: the seed's training,
validation and test patches with every input computed on them, then one
early-stopped training per input and detection on the test patches. The
evaluation's seeds are EVAL_SEED0, EVAL_SEED0 + 1, ... (--seeds of them for
the generated skies, --real-seeds for the real footage), apart from the
calibration's. The main process bootstraps AP (3 px) over seeds and test
patches and the paired differences rf - input (``downstream.stats``; on
real footage the seeds are resampled within each test video, which rotates
with the seed) and writes report.md, results.csv, curves.csv, intervals.csv
and plot.png.

``--calibrate`` runs the gray input alone on CALIBRATION_SEEDS over the
contrast ladder, from the rung in CALIBRATED towards harder or easier ones
until gray's AP lies in [0.2, 0.7], and writes calibration.md: the rung
found is what CALIBRATED holds.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import csv
import io
import math
import multiprocessing
import os
import shlex
import sys
import time
from pathlib import Path

import numpy as np

from ..downstream import backgrounds, metrics, scenes, stats
from ..downstream import run as downstream_run
from ..downstream.report import FAMILY_LABELS, atomic_write
from . import patches, train

FAMILIES = ("sky", "real")
SIZES = (2.0, 6.0)  # the drone's diameter range (px), both families
# Contrast ranges (gray levels), easiest first: the calibration's ladder.
LADDER = ((48.0, 192.0), (32.0, 128.0), (24.0, 96.0), (16.0, 64.0), (10.0, 40.0), (6.0, 24.0), (4.0, 16.0),
          (3.0, 12.0), (2.0, 8.0))
# Written by --calibrate (docs/downstream/detection/calibration.md): the
# contrast range per family at which gray's AP lies in [0.2, 0.7].
CALIBRATED = {"sky": (16.0, 64.0), "real": (24.0, 96.0)}
CALIBRATION_SEEDS = (100, 101, 102, 103)
# The evaluation's first seed: its seeds had never been run when the
# difficulty, the training and the stopping rule were fixed.
EVAL_SEED0 = 1000
GRAY_RANGE = (0.2, 0.7)
# The inputs that matter most, sized to fit the full run in 40 minutes of this
# 2-core machine (docs/evaluation.md: what was left out and why).
DEFAULT_INPUTS = ("gray", "diff", "farneback", "rf")
REFERENCE = "rf"
# Real footage: 9 seeds, 3 per test video of the 3 default videos (docs/evaluation.md: why).
DEFAULT = dict(seeds=5, real_seeds=9, train=3000, val=400, test=2000, max_steps=3000, every=50, bootstrap=1000)
QUICK = dict(seeds=1, real_seeds=1, train=16, val=8, test=12, max_steps=20, every=10, bootstrap=50)
HELP = dict(seeds="seeds of the generated skies (each: its own patches, crops and initial weights)",
            real_seeds="seeds of the real footage (a multiple of its number of test-video folds keeps them balanced)",
            train="training patches per seed",
            val="validation patches per seed (early stopping)", test="test patches per seed",
            max_steps="most training steps", every="steps between validation measurements (AP and loss)",
            bootstrap="bootstrap replicates of the intervals")


def _args(argv):
    p = argparse.ArgumentParser(prog="python -m reynoldsflow.bench.detection",
                                description="A detector benchmark sized to resolve (see the package's doc).")
    p.add_argument("--out", required=True, type=Path, help="folder for the outputs")
    p.add_argument("--quick", action="store_true", help="CI-sized run (figures mean nothing)")
    p.add_argument("--calibrate", action="store_true", help="calibrate the difficulty on gray only")
    for key, value in DEFAULT.items():
        p.add_argument("--" + key.replace("_", "-"), type=int, default=None,
                       help=f"{HELP[key]} (default {value}, --quick {QUICK[key]})")
    p.add_argument("--inputs", help="comma-separated inputs (default: " + ", ".join(DEFAULT_INPUTS) + ")")
    p.add_argument("--families", default=",".join(FAMILIES), help="sky (generated), real (videos)")
    p.add_argument("--backgrounds", type=Path, help="folder of videos for the real scenes")
    p.add_argument("--factors", default=",".join(scenes.FACTORS), help="nuisance factors of the sky scenes")
    p.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1), help="jobs in parallel")
    a = p.parse_args(argv)
    for key, value in (QUICK if a.quick else DEFAULT).items():
        if getattr(a, key) is None:
            setattr(a, key, value)
        if getattr(a, key) < 1:
            p.error(f"--{key.replace('_', '-')} must be at least 1")
    if a.train < 4 or a.val < 2 or a.test < 4:
        p.error("--train must be at least 4, --val at least 2 and --test at least 4 patches")
    return a


def seeds_of(a, family: str) -> list:
    """The evaluation's seeds of a family."""
    return list(range(EVAL_SEED0, EVAL_SEED0 + (a.real_seeds if family == "real" else a.seeds)))


def _job(family, seed, names, contrasts, a_sizes, factors, videos):
    """One family and seed: every input trained and tested. Returns
    (rows, curves, {input: Records})."""
    import torch

    torch.set_num_threads(1)
    n_train, n_val, n_test, max_steps, every = a_sizes
    pools = {part: patches.make(family, seed, part, n, names, SIZES, contrasts, factors, videos)
             for part, n in (("train", n_train), ("val", n_val), ("test", n_test))}
    tr, va, te = pools["train"], pools["val"], pools["test"]
    rows, curves, recs = [], [], {}
    for name in names:
        model, norm, curve = train.fit(tr.x[name], tr.centers, va.x[name], va.centers, va.diameters, seed,
                                       max_steps, every)
        recs[name] = r = train.detect(model, norm, te.x[name], te.centers, te.diameters)
        s = metrics.summary(r)
        rows.append(dict(family=family, input=name, seed=seed, ap=s["ap"], located_3px=s["located_3px"],
                         best_step=curve.best_step, stopped_at=curve.stopped_at,
                         val_ap_best=max(curve.val_ap), train_seconds=round(curve.seconds, 1),
                         contrast=f"{contrasts[0]:g}-{contrasts[1]:g}"))
        curves += [dict(family=family, input=name, seed=seed, step=st, train_loss=tl, val_loss=vl, val_ap=va_)
                   for st, tl, vl, va_ in zip(curve.steps, curve.train_loss, curve.val_loss, curve.val_ap)]
    return rows, curves, recs


def _run_jobs(jobs, a, start):
    out = {}
    ctx = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(max_workers=a.workers, mp_context=ctx) as pool:
        futures = {pool.submit(_job, *j): j[:2] for j in jobs}
        for fut in concurrent.futures.as_completed(futures):
            fam, seed = futures[fut]
            try:
                out[(fam, seed)] = got = fut.result()
            except BaseException:
                for other in futures:
                    other.cancel()
                print(f"{fam} seed {seed}: failed", file=sys.stderr, flush=True)
                raise
            print(f"{fam} seed {seed}: " + ", ".join(f"{r['input']} AP {r['ap']:.2f} (step {r['best_step']})"
                                                   for r in got[0]) + f" [{time.perf_counter() - start:.0f} s]",
                  file=sys.stderr, flush=True)
    return out


def _rows_csv(rows) -> bytes:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    return buf.getvalue().encode()


def _cell(iv, signed=False) -> str:
    f = "{:+.2f}" if signed else "{:.2f}"
    if not math.isfinite(iv.estimate):
        return "n/r"
    if not math.isfinite(iv.low):
        return f.format(iv.estimate)
    return f"{f.format(iv.estimate)} [{f.format(iv.low)}, {f.format(iv.high)}]"


def _verdict(iv) -> str:
    return "n/r" if not math.isfinite(iv.low) else "beats" if iv.low > 0 else "loses" if iv.high < 0 else "tie"


def _calibrate(a, factors, videos, start) -> int:
    sizes = (a.train, a.val, a.test, a.max_steps, a.every)
    lines = ["# Difficulty calibration of the detection benchmark (gray input only)", "",
             f"Command: `{a.command}`.", "",
             f"Gray's AP (3 px) over seeds {', '.join(map(str, CALIBRATION_SEEDS))} (apart from the evaluation's "
             f"seeds, which start at {EVAL_SEED0}), drone diameter {SIZES[0]:g}-{SIZES[1]:g} px, per contrast range "
             "(gray levels) tried, "
             f"from CALIBRATED towards harder (AP > {GRAY_RANGE[1]}) or easier (AP < {GRAY_RANGE[0]}) rungs of "
             f"the ladder {', '.join(f'{lo:g}-{hi:g}' for lo, hi in LADDER)}; sizes: {a.train} training, "
             f"{a.val} validation and {a.test} test patches per seed; training as the full run's (validation every "
             f"{a.every} steps; {train.REGIME}; at most {a.max_steps} steps).", "",
             "| family | contrast | gray AP (mean over seeds) | per seed | best step / stopped at (per seed) |",
             "|---|---|---:|---|---|"]
    chosen, rows = {}, {f: [] for f in a.families}
    rung = {f: LADDER.index(CALIBRATED[f]) if CALIBRATED[f] in LADDER else 2 for f in a.families}
    seen = {f: set() for f in a.families}
    while rung:  # the families still walking, each one rung per round, their seeds' jobs together
        jobs = [(f, s, ("gray",), LADDER[k], sizes, factors, videos) for f, k in rung.items()
                for s in CALIBRATION_SEEDS]
        got = _run_jobs(jobs, a, start)
        for fam, k in list(rung.items()):
            seen[fam].add(k)
            rs = [got[(fam, s)][0][0] for s in CALIBRATION_SEEDS]
            aps = [r["ap"] for r in rs]
            ap = float(np.mean(aps))
            lo, hi = LADDER[k]
            rows[fam].append(f"| {fam} | {lo:g}-{hi:g} | {ap:.2f} | " + ", ".join(f"{x:.2f}" for x in aps) + " | "
                             + ", ".join(f"{r['best_step']}/{r['stopped_at']}" for r in rs) + " |")
            step = 1 if ap > GRAY_RANGE[1] else -1 if ap < GRAY_RANGE[0] else 0
            if step == 0 or not 0 <= k + step < len(LADDER) or k + step in seen[fam]:
                chosen[fam] = (LADDER[k], ap)
                del rung[fam]
            else:
                rung[fam] = k + step
    lines += [r for f in a.families for r in rows[f]]
    lines += [""] + [f"- {FAMILY_LABELS[f]}: contrast {c[0]:g}-{c[1]:g} gray levels (gray AP {ap:.2f}"
                     + ("" if GRAY_RANGE[0] <= ap <= GRAY_RANGE[1] else ", outside [0.2, 0.7]: the ladder's end")
                     + ")" for f in a.families for c, ap in [chosen[f]]]
    lines += ["", f"Wall time {time.perf_counter() - start:.0f} s; workers {a.workers}; cpus {os.cpu_count()}; load "
              "average (1, 5, 15 min) at start " + "{:.1f}, {:.1f}, {:.1f}".format(*a.load_start) + ", at end "
              + "{:.1f}, {:.1f}, {:.1f}".format(*os.getloadavg()) + "."]
    a.out.mkdir(parents=True, exist_ok=True)
    atomic_write(a.out / "calibration.md", ("\n".join(lines) + "\n").encode())
    print("\n".join(lines))
    return 0


def main(argv=None) -> int:
    a = _args(argv)
    start = time.perf_counter()
    a.load_start = os.getloadavg()
    a.command = "python -m reynoldsflow.bench.detection " + " ".join(shlex.quote(x) for x in (argv or sys.argv[1:]))
    names = tuple(n for n in (a.inputs.split(",") if a.inputs else DEFAULT_INPUTS) if n)
    from ..downstream import inputs as inputs_mod

    unknown = [n for n in names if n not in inputs_mod.BY_NAME]
    if unknown:
        print(f"python -m reynoldsflow.bench.detection: --inputs: unknown {unknown}", file=sys.stderr)
        return 2
    if REFERENCE not in names:
        names = names + (REFERENCE,)
    a.families = [f for f in a.families.split(",") if f]
    factors = tuple(f for f in a.factors.split(",") if f)
    if set(a.families) - set(FAMILIES) or not a.families or set(factors) - set(scenes.FACTORS):
        print("python -m reynoldsflow.bench.detection: --families or --factors: unknown names", file=sys.stderr)
        return 2
    videos = ()
    if "real" in a.families:
        try:
            videos = tuple(str(p) for p in downstream_run._videos(a))
            for p in videos:
                backgrounds.load(Path(p), scenes.WIDTH, scenes.HEIGHT, 2)
            backgrounds.split(videos, 0)
        except backgrounds.BackgroundError as e:
            print(f"python -m reynoldsflow.bench.detection: {e}", file=sys.stderr)
            return 2
    if a.calibrate:
        return _calibrate(a, factors, videos, start)
    sizes = (a.train, a.val, a.test, a.max_steps, a.every)
    jobs = [(fam, s, names, CALIBRATED[fam], sizes, factors, videos) for fam in a.families for s in seeds_of(a, fam)]
    got = _run_jobs(jobs, a, start)
    tests = {s: "+".join(Path(p).name for p in backgrounds.split(videos, s)[1]) for s in seeds_of(a, "real")} \
        if "real" in a.families else {}
    rows = [dict(r, test_videos=tests[r["seed"]] if r["family"] == "real" else "") for j in jobs
            for r in got[j[:2]][0]]
    curves = [c for j in jobs for c in got[j[:2]][1]]
    intervals, lines = {}, []
    for fam in a.families:
        per_seed = {n: {s: got[(fam, s)][2][n] for s in seeds_of(a, fam)} for n in names}
        values = stats.replicates(per_seed, "ap", a.bootstrap, strata=tests if fam == "real" else None)
        intervals[fam] = ({n: stats.interval(values[n]) for n in names},
                          stats.paired(values, REFERENCE, [n for n in names if n != REFERENCE]))
    seconds = time.perf_counter() - start
    t = os.times()  # the worker processes have ended: their time is the children's
    cpu = t.user + t.system + t.children_user + t.children_system
    strata_counts = {v: sum(1 for x in tests.values() if x == v) for v in dict.fromkeys(tests.values())}
    fams = a.families
    head = ["| input | " + " | ".join(f"{FAMILY_LABELS[f]}: AP (3 px)" for f in fams) + " |",
            "|---|" + "---:|" * len(fams)]
    head += [f"| {n} | " + " | ".join(_cell(intervals[f][0][n]) for f in fams) + " |" for n in names]
    paired = [f"| {REFERENCE} − input | " + " | ".join(FAMILY_LABELS[f] for f in fams) + " |",
              "|---|" + "---:|" * len(fams)]
    paired += [f"| {n} | " + " | ".join(f"{_cell(intervals[f][1][n], True)} {_verdict(intervals[f][1][n])}"
                                        for f in fams) + " |" for n in names if n != REFERENCE]
    half = {f: np.nanmedian([(iv.high - iv.low) / 2 for iv in intervals[f][0].values()]) for f in fams}
    half_d = {f: np.nanmedian([(iv.high - iv.low) / 2 for iv in intervals[f][1].values()]) for f in fams}
    steps = ["| family | input | best step (per seed) | stopped at (per seed) | training s (mean) |",
             "|---|---|---|---|---:|"]
    for f in fams:
        for n in names:
            rs = [r for r in rows if r["family"] == f and r["input"] == n]
            steps.append(f"| {f} | {n} | {', '.join(str(r['best_step']) for r in rs)} | "
                         f"{', '.join(str(r['stopped_at']) for r in rs)} | "
                         f"{np.mean([r['train_seconds'] for r in rs]):.0f} |")
    md = ["# Detection benchmark sized to resolve", "", f"Command: `{a.command}` ({seconds:.0f} s).", "",
          "Settings: seeds " + "; ".join(
              f"{f} {len(seeds_of(a, f))} ({seeds_of(a, f)[0]}-{seeds_of(a, f)[-1]}"
              + ("; test video " + ", ".join(f"{v} for {n}" for v, n in strata_counts.items())
                 + "; the bootstrap resamples the seeds within each test video" if f == "real" else "") + ")"
              for f in fams)
          + f"; per seed and family {a.train} training, {a.val} validation and {a.test} "
          f"test patches of {patches.PATCH}x{patches.PATCH} px (a quarter without a drone); drone diameter "
          f"{SIZES[0]:g}-{SIZES[1]:g} px; contrast (calibrated on gray, --calibrate) "
          + ", ".join(f"{f} {CALIBRATED[f][0]:g}-{CALIBRATED[f][1]:g}" for f in fams)
          + f" gray levels; training: crops of {train.CROP} px, {train.BATCH} per step, validation every "
          f"{a.every} steps; {train.REGIME}; at most {a.max_steps} steps; "
          f"bootstrap {a.bootstrap}; workers {a.workers}; cpus {os.cpu_count()}; CPU time {cpu:.0f} s; load "
          "average (1, 5, 15 min) at start " + "{:.1f}, {:.1f}, {:.1f}".format(*a.load_start) + ", at end "
          + "{:.1f}, {:.1f}, {:.1f}".format(*os.getloadavg()) + ".", "",
          "## AP (3 px), mean over seeds, bootstrap 95 % interval over seeds and test patches", ""] + head + [
          "", "Median half-width of the intervals: " + ", ".join(f"{f} {half[f]:.3f} (AP), {half_d[f]:.3f} "
                                                                 f"(paired differences)" for f in fams) + ".",
          "", "## Paired differences (same seeds and patches; beats / loses: the interval excludes 0)", ""] + paired
    md += ["", "## Training: the step of the best validation AP and the step it stopped at", ""] + steps
    a.out.mkdir(parents=True, exist_ok=True)
    atomic_write(a.out / "results.csv", _rows_csv(rows))
    atomic_write(a.out / "curves.csv", _rows_csv(curves))
    iv_rows = [dict(family=f, kind=k, input=n, estimate=iv.estimate, low=iv.low, high=iv.high,
                    resolved=iv.resolved if k == "paired" else "")
               for f in fams for k, d in zip(("ap", "paired"), intervals[f]) for n, iv in d.items()]
    atomic_write(a.out / "intervals.csv", _rows_csv(iv_rows))
    atomic_write(a.out / "report.md", ("\n".join(md) + "\n").encode())
    _plot(a.out / "plot.png", fams, names, intervals, curves)
    print("\n".join(head))
    print(f"\n{seconds:.0f} s; wrote {a.out / 'report.md'}, results.csv, curves.csv, intervals.csv, plot.png",
          file=sys.stderr)
    return 0


def _plot(path, fams, names, intervals, curves) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, len(fams), figsize=(5.5 * len(fams), 8), squeeze=False)
    y = np.arange(len(names))
    for k, f in enumerate(fams):
        ivs = [intervals[f][0][n] for n in names]
        est = np.array([iv.estimate for iv in ivs])
        err = [np.nan_to_num(est - [iv.low for iv in ivs]), np.nan_to_num([iv.high for iv in ivs] - est)]
        ax = axes[0][k]
        ax.barh(y, np.nan_to_num(est), xerr=err, capsize=2,
                color=["#c44e52" if n == REFERENCE else "#4c72b0" for n in names])
        ax.set_yticks(y, names, fontsize=8)
        ax.invert_yaxis()
        ax.set_xlim(0, 1)
        ax.set_title(f"{FAMILY_LABELS[f]}: AP (3 px)", fontsize=9)
        ax = axes[1][k]
        for n in names:
            cs = [c for c in curves if c["family"] == f and c["input"] == n and c["seed"] == EVAL_SEED0]
            ax.plot([c["step"] for c in cs], [c["val_ap"] for c in cs], label=n,
                    lw=2 if n == REFERENCE else 1)
        ax.set_xlabel("step")
        ax.set_ylabel(f"validation AP (3 px), seed {EVAL_SEED0}")
        ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    plt.close(fig)
    atomic_write(path, buf.getvalue())

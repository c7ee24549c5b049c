"""The detector benchmark sized to resolve (python -m
reynoldsflow.bench.detection): its --quick run's structure (every input
trained on both families and every seed, the validation curve, every
interval and paired difference computed -- not its figures), the
calibration's mode, and the committed calibration matching the constants
the benchmark runs with."""

import csv
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import run_bench_quick

from reynoldsflow.bench.detection import patches, run


def _csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("detection")
    return out, run_bench_quick("detection", out, threads=1, timeout=900)


def test_quick_trains_every_input_on_both_families_and_every_seed(quick):
    out, stdout = quick
    assert sorted(p.name for p in out.iterdir()) == ["curves.csv", "intervals.csv", "plot.png", "report.md",
                                                     "results.csv"]
    rows = _csv(out / "results.csv")
    got = {(r["family"], r["input"], r["seed"]) for r in rows}
    seeds = {"sky": run.QUICK["seeds"], "real": run.QUICK["real_seeds"]}
    assert got == {(f, n, str(s)) for f in run.FAMILIES for n in run.DEFAULT_INPUTS
                   for s in range(run.EVAL_SEED0, run.EVAL_SEED0 + seeds[f])} and len(rows) == len(got)
    assert all(bool(r["test_videos"]) == (r["family"] == "real") for r in rows)
    for r in rows:
        assert 0 <= float(r["ap"]) <= 1 and 0 < int(r["best_step"]) <= int(r["stopped_at"]) <= run.QUICK["max_steps"]
    curves = _csv(out / "curves.csv")
    for f, n, s in got:
        steps = [int(c["step"]) for c in curves if (c["family"], c["input"], c["seed"]) == (f, n, s)]
        assert steps and steps == sorted(steps) and all(x % run.QUICK["every"] == 0 or x == run.QUICK["max_steps"]
                                                        for x in steps)
    ivs = _csv(out / "intervals.csv")
    for f in run.FAMILIES:
        for n in run.DEFAULT_INPUTS:
            r = next(i for i in ivs if (i["family"], i["kind"], i["input"]) == (f, "ap", n))
            assert 0 <= float(r["low"]) <= float(r["estimate"]) <= float(r["high"]) <= 1, r
            if n != run.REFERENCE:
                p = next(i for i in ivs if (i["family"], i["kind"], i["input"]) == (f, "paired", n))
                assert math.isfinite(float(p["low"])) and float(p["low"]) <= float(p["high"])
                assert p["resolved"] in ("True", "False")
    text = (out / "report.md").read_text()
    assert stdout.strip().startswith("| input | generated skies: AP (3 px) | real footage: AP (3 px) |")
    assert stdout.strip() in text and "Median half-width" in text
    for n in run.DEFAULT_INPUTS:
        assert re.search(rf"^\| {re.escape(n)} \| [0-9.]+ \[", text, re.M), n


def test_calibration_walks_the_ladder_on_gray_only(tmp_path):
    res = subprocess.run([sys.executable, "-m", "reynoldsflow.bench.detection", "--out", str(tmp_path), "--quick",
                          "--calibrate", "--families", "sky"], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
    text = (tmp_path / "calibration.md").read_text()
    tried = re.findall(r"^\| sky \| ([0-9.]+)-([0-9.]+) \| ([0-9.]+) \|", text, re.M)
    assert tried and (float(tried[0][0]), float(tried[0][1])) == run.CALIBRATED["sky"]
    for lo, hi, ap in tried[:-1]:  # every rung but the last was outside the range
        assert not run.GRAY_RANGE[0] <= float(ap) <= run.GRAY_RANGE[1]
    assert "Gray's AP" in text


def test_committed_calibration_is_what_the_benchmark_runs_with():
    root = Path(os.environ["REYNOLDSFLOW_REPO"])
    text = (root / "docs" / "downstream" / "detection" / "calibration.md").read_text()
    command = re.search(r"Command: `([^`]+)`", text).group(1)
    assert command.startswith("python -m reynoldsflow.bench.detection --out docs/downstream/detection --calibrate")
    for fam, label in (("sky", "generated skies"), ("real", "real footage")):
        lo, hi = run.CALIBRATED[fam]
        assert f"- {label}: contrast {lo:g}-{hi:g} gray levels" in text


def test_patches_are_distinct_and_hold_their_drone():
    pool = patches.make("sky", 0, "train", 8, ("gray", "rf"), run.SIZES, (20.0, 30.0), ("noise",), ())
    assert pool.x["gray"].shape == (8, patches.PATCH, patches.PATCH, 1)
    assert pool.x["rf"].shape == (8, patches.PATCH, patches.PATCH, 3)
    assert np.isnan(pool.centers[-2:]).all() and np.isfinite(pool.centers[:6]).all()
    assert all(20 <= c <= 30 for c in pool.contrasts[:6]) and all(2 <= d <= 6 for d in pool.diameters[:6])
    assert len({pool.x["gray"][i].tobytes() for i in range(8)}) == 8


def test_docs_carry_the_committed_run():
    """docs/evaluation.md's detection table is the committed run's
    (docs/downstream/detection/report.md), whose command, the defaults, is
    named beside it; gray's AP there lies in the calibration's range on both
    families."""
    root = Path(os.environ["REYNOLDSFLOW_REPO"])
    rep = (root / "docs" / "downstream" / "detection" / "report.md").read_text()
    command = re.search(r"Command: `([^`]+)`", rep).group(1)
    assert command == "python -m reynoldsflow.bench.detection --out docs/downstream/detection"  # the defaults
    # Its seeds: the defaults' count per family, from EVAL_SEED0 on (never run when the rules were fixed).
    results = _csv(root / "docs" / "downstream" / "detection" / "results.csv")
    for fam, key in (("sky", "seeds"), ("real", "real_seeds")):
        seeds = {int(r["seed"]) for r in results if r["family"] == fam}
        assert seeds == set(range(run.EVAL_SEED0, run.EVAL_SEED0 + run.DEFAULT[key])), (fam, sorted(seeds))
        assert not seeds & set(run.CALIBRATION_SEEDS)
    gray = re.search(r"^\| gray \| ([0-9.]+) \[[^|]*\| ([0-9.]+) \[", rep, re.M)
    assert all(run.GRAY_RANGE[0] <= float(x) <= run.GRAY_RANGE[1] for x in gray.groups()), gray.group(0)
    docs = (root / "docs" / "evaluation.md").read_text()
    assert command in " ".join(docs.split())

    def rows(text):
        lines = text.splitlines()
        start = next(i for i, l in enumerate(lines) if l.startswith("| input | generated skies: AP (3 px)"))
        out = []
        for line in lines[start + 2 :]:
            if not line.startswith("|"):
                break
            out.append(line)
        return out

    assert rows(docs) == rows(rep) and len(rows(rep)) >= 4

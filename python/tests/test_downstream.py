"""The downstream detector benchmark (python -m reynoldsflow.bench.downstream):
its --quick run's outputs and structure (not its accuracy figures, which a
CI-sized run cannot give), the README's table against the inputs the
command produces, and the pieces the figures rest on: deterministic scenes
and metrics that score known heatmaps as they should."""

import csv
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from reynoldsflow.bench.downstream import inputs, metrics, report, scenes
from reynoldsflow.bench.downstream.run import CONTRAST_BINS, QUICK

# A table cell: "mean ± sd" over the seeds, "(k/n)" when only k of n seeds
# reached the recall, or n/r when none did.
CELL = re.compile(r" (\d+\.\d+ ± \d+\.\d+( \(\d+/\d+\))?|\d+\.\d+ \(1/\d+\)|n/r) ")


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("downstream")
    env = dict(os.environ, OMP_NUM_THREADS="2")
    res = subprocess.run([sys.executable, "-m", "reynoldsflow.bench.downstream", "--out", str(out), "--quick"],
                         capture_output=True, text=True, env=env, timeout=900)
    assert res.returncode == 0, res.stderr
    return out, res.stdout


def _rows(out):
    with open(out / "results.csv", newline="") as f:
        reader = csv.DictReader(f)
        return reader.fieldnames, list(reader)


def _table_rows(text: str, header_start: str) -> list:
    """First cells of the markdown table whose header starts with header_start."""
    lines = text.splitlines()
    start = next(i for i, l in enumerate(lines) if l.startswith(header_start))
    names = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        names.append(line.split("|")[1].strip())
    return names


def test_quick_writes_every_file_and_no_temporary(quick):
    out, _ = quick
    assert sorted(p.name for p in out.iterdir()) == ["plot.png", "report.md", "results.csv"]
    assert (out / "plot.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_quick_csv_has_every_input_seed_and_subset(quick):
    out, _ = quick
    columns, rows = _rows(out)
    assert tuple(columns) == report.COLUMNS
    subsets = list(scenes.test_subsets(scenes.FACTORS)) + [f"all, contrast {lo}-{hi}" for lo, hi in CONTRAST_BINS]
    expected = {(i.name, str(s), sub) for i in inputs.INPUTS for s in range(QUICK["seeds"]) for sub in subsets}
    got = [(r["input"], r["seed"], r["subset"]) for r in rows]
    assert len(got) == len(set(got)) and set(got) == expected
    for r in rows:
        for key in ("located_3px", "ap"):
            v = float(r[key])
            assert math.isnan(v) or 0 <= v <= 1, r
        # A contrast bin may hold no drone clip in a small run; the factor
        # subsets always hold both kinds of clip.
        assert int(r["free_frames"]) > 0, r
        if not r["subset"].startswith("all, contrast"):
            assert int(r["drone_frames"]) > 0, r


def test_quick_trained_every_input(quick):
    """Every input and seed ran the whole budget and its loss went down."""
    out, _ = quick
    _, rows = _rows(out)
    trainings = {(r["input"], r["seed"]): r for r in rows}
    assert len(trainings) == len(inputs.INPUTS) * QUICK["seeds"]
    for key, r in trainings.items():
        assert int(r["train_steps"]) == QUICK["steps"], key
        assert float(r["loss_last"]) < float(r["loss_first"]), (key, r["loss_first"], r["loss_last"])
        assert float(r["train_seconds"]) > 0, key


def test_quick_report_tables(quick):
    out, stdout = quick
    text = (out / "report.md").read_text()
    names = [i.name for i in inputs.INPUTS]
    assert _table_rows(text, "| input | located ≤ 3 px") == names
    assert _table_rows(text, "| input | steps") == names
    assert _table_rows(text, "| input | none |") == names
    # The table printed is the report's headline table.
    printed = stdout.strip().splitlines()
    assert printed[0].startswith("| input | located ≤ 3 px") and "\n".join(printed) in text
    # Every cell of the headline table is "mean ± sd" (two seeds) or n/r.
    for line in printed[2 : 2 + len(names)]:
        for cell in line.split("|")[2:-1]:
            assert CELL.fullmatch(cell), line


def test_readme_table_lists_the_inputs_the_command_produces():
    root = Path(os.environ["REYNOLDSFLOW_REPO"])
    text = (root / "docs" / "evaluation.md").read_text()
    section = text.split("## Downstream detection", 1)[1].split("\n## ", 1)[0]
    assert "python -m reynoldsflow.bench.downstream" in section
    header = report.main_table([], [], 0.5)[0]
    assert header in section, "the README's table header differs from the command's"
    names = [i.name for i in inputs.INPUTS]
    assert _table_rows(section, header) == names
    rows = [l for l in section.splitlines() if l.startswith("| ") and l.split("|")[1].strip() in names]
    for line in rows:
        for cell in line.split("|")[2:-1]:
            assert CELL.fullmatch(cell), f"a README cell without its spread: {line}"


def test_scenes_are_deterministic_and_factors_switch():
    a = scenes.test_clips(3, 2, 5, scenes.FACTORS)
    b = scenes.test_clips(3, 2, 5, scenes.FACTORS)
    for name in a:
        for x, y in zip(a[name], b[name]):
            assert np.array_equal(x.frames, y.frames) and np.array_equal(x.centers, y.centers, equal_nan=True)
    plain, clouds = a["none"][0], a["clouds"][0]
    assert plain.frames.shape == (5, scenes.HEIGHT, scenes.WIDTH) and plain.frames.dtype == np.uint8
    # A plain sky is one level but the drone (no noise, no gradient).
    assert len(np.unique(plain.frames[0])) < 12 and len(np.unique(clouds.frames[0])) > 20
    assert a["none"][-1].contrast == 0 and np.isnan(a["none"][-1].centers).all()
    assert 10 <= plain.contrast <= 40 and np.isfinite(plain.centers).all()
    with pytest.raises(ValueError):
        scenes.make_clip(np.random.default_rng(0), ["fog"], 3)


def test_drone_is_drawn_at_its_ground_truth():
    clip = scenes.make_clip(np.random.default_rng(5), (), 4)
    for frame, (x, y) in zip(clip.frames, clip.centers):
        sky = np.median(frame)
        dev = np.abs(frame.astype(float) - sky)
        iy, ix = np.unravel_index(np.argmax(dev), dev.shape)
        assert np.hypot(ix - x, iy - y) <= 2.0 and dev.max() >= 5


def test_metrics_on_known_heatmaps():
    centers = np.array([[20.3, 30.6], [50.0, 10.0], [np.nan, np.nan], [np.nan, np.nan]])
    heat = np.zeros((4, 60, 80))
    perfect = heat.copy()
    perfect[0, 31, 20] = perfect[1, 10, 50] = 0.9
    s = metrics.score(perfect, centers, recall=0.5)
    assert (s.located, s.ap, s.fp_per_free_frame, s.drone_frames, s.free_frames) == (1.0, 1.0, 0.0, 2, 2)
    # A miss (frame 1) and a false peak on each drone-free frame, all three
    # stronger than the one hit: AP = precision 1/4 at the first of 2 drones.
    wrong = heat.copy()
    wrong[0, 31, 20] = 0.5
    wrong[1, 40, 70] = 0.9
    wrong[2, 5, 5] = wrong[3, 50, 60] = 0.8
    s = metrics.score(wrong, centers, recall=0.5)
    assert s.located == 0.5
    assert s.fp_per_free_frame == 1.0
    assert math.isclose(s.ap, 0.5 * (1 / 4), rel_tol=1e-12)
    assert math.isnan(metrics.score(wrong, centers, recall=1.0).fp_per_free_frame)

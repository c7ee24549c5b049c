"""The downstream detector benchmark (python -m reynoldsflow.bench.downstream):
its --quick run's outputs and structure (not its accuracy figures, which a
CI-sized run cannot give: every input trained with both detectors on both
scene families, the tables, the paired intervals), the docs' table against
the inputs the command produces, and the pieces the figures rest on:
deterministic scenes, metrics and intervals that score known detections as
they should, the flow coding, and YOLO11n trained without touching the
network. Background folders are in test_downstream_backgrounds.py."""

import csv
import json
import math
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from conftest import run_bench_quick

from reynoldsflow.bench.downstream import flow, inputs, metrics, report, run, scenes, stats

QUICK = run.QUICK
FILES = ["intervals.csv", "plot.png", "report.md", "results.csv"]
# A table cell: "estimate [low, high]" (or "n/r"), signed in the paired table,
# followed there by the verdict.
NUM = r"[+-]?\d+\.\d\d"
CELL = re.compile(rf" ({NUM} \[{NUM}, {NUM}\]|n/r) ")
PAIRED = re.compile(rf" ({NUM} \[{NUM}, {NUM}\]|n/r) (beats|tie|loses|n/r) ")


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("downstream")
    return out, run_bench_quick("downstream", out, threads=2, timeout=900)


def _rows(path):
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        return reader.fieldnames, list(reader)


def _table_rows(text: str, header_start: str) -> list:
    """Rows (lists of cells) of the markdown table whose header starts with
    header_start."""
    lines = text.splitlines()
    start = next(i for i, l in enumerate(lines) if l.startswith(header_start))
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        rows.append([c for c in line.split("|")[1:-1]])
    return rows


PAPER = [i.name for i in inputs.PAPER]
BASELINES = [n for n in PAPER if n != inputs.REPRESENTATION]


def test_quick_writes_every_file_and_no_temporary(quick):
    out, _ = quick
    assert sorted(p.name for p in out.iterdir()) == FILES
    assert (out / "plot.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_quick_trained_every_input_with_both_detectors_on_both_families(quick):
    out, _ = quick
    columns, rows = _rows(out / "results.csv")
    assert tuple(columns) == report.COLUMNS
    expected = {(f, d, i, str(s)) for f in run.FAMILIES for d in run.DETECTORS for i in PAPER
                for s in range(QUICK["seeds"])}
    got = [(r["family"], r["detector"], r["input"], r["seed"]) for r in rows]
    assert len(got) == len(set(got)) and set(got) == expected
    yolo_batches = -(-QUICK["train_clips"] * (QUICK["frames"] - 1) // QUICK["yolo_batch"]) * QUICK["epochs"]
    for r in rows:
        key = (r["family"], r["detector"], r["input"])
        assert int(r["train_steps"]) == (QUICK["steps"] if r["detector"] == "heatmap" else yolo_batches), key
        assert math.isfinite(float(r["loss_first"])) and math.isfinite(float(r["loss_last"])), key
        assert float(r["train_seconds"]) > 0, key
        # The heatmap network's budget is enough for its loss to fall on every input.
        if r["detector"] == "heatmap":
            assert float(r["loss_last"]) < float(r["loss_first"]), key
        for metric in ("located_3px", "ap", "ap50", "ap50_95"):
            v = float(r[metric])
            assert math.isnan(v) or 0 <= v <= 1, (key, metric)
        # Points have no box: AP50 is YOLO's alone.
        assert math.isnan(float(r["ap50"])) == (r["detector"] == "heatmap"), key
        assert int(r["drone_frames"]) > 0 and int(r["free_frames"]) > 0, key


def test_quick_paired_intervals_are_computed(quick):
    out, _ = quick
    _, rows = _rows(out / "intervals.csv")
    columns = [(f, d, m) for f in run.FAMILIES for d in run.DETECTORS for m in report.SCORED[d]]
    for kind, names in (("input", PAPER), ("paired", BASELINES)):
        got = {(r["family"], r["detector"], r["metric"], r["input"]): r for r in rows if r["kind"] == kind}
        assert set(got) == {c + (n,) for c in columns for n in names}, kind
        for key, r in got.items():
            est, lo, hi = float(r["estimate"]), float(r["low"]), float(r["high"])
            assert all(map(math.isfinite, (est, lo, hi))) and lo <= hi, (kind, key)
            if kind == "paired":
                assert r["resolved"] == str(int(lo > 0 or hi < 0)), key


def test_quick_report_tables(quick):
    out, stdout = quick
    text = (out / "report.md").read_text()
    main = _table_rows(text, "| input | generated skies")
    assert [r[0].strip() for r in main] == PAPER
    for r in main:
        assert len(r) == 1 + 6 and all(CELL.fullmatch(c) for c in r[1:]), r
    paired = _table_rows(text, f"| {inputs.REPRESENTATION} − baseline")
    assert [r[0].strip() for r in paired] == BASELINES
    for r in paired:
        assert all(PAIRED.fullmatch(c) for c in r[1:]), r
    # One verdict line per column, naming every baseline once.
    verdicts = [l for l in text.splitlines() if l.startswith("- ") and f"`{inputs.REPRESENTATION}` beats" in l]
    assert len(verdicts) == 6
    for line in verdicts:
        assert sorted(re.findall(r"`([^`]+)`", line)[1:]) == sorted(BASELINES), line
    # The table printed is the report's headline table.
    printed = stdout.strip()
    assert printed.startswith("| input | generated skies") and printed in text


def test_docs_table_lists_the_inputs_the_command_produces():
    root = Path(os.environ["REYNOLDSFLOW_REPO"])
    text = (root / "docs" / "evaluation.md").read_text()
    section = text.split("## Downstream detection", 1)[1].split("\n## ", 1)[0]
    assert "python -m reynoldsflow.bench.downstream" in section
    rows = _table_rows(section, "| input | generated skies")
    assert [r[0].strip() for r in rows] == PAPER
    for r in rows:
        assert all(CELL.fullmatch(c) for c in r[1:]), f"a docs cell without its interval: {r}"


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
    assert a["none"][-1].contrast == 0 and a["none"][-1].diameter == 0 and np.isnan(a["none"][-1].centers).all()
    assert 10 <= plain.contrast <= 40 and 2 <= plain.diameter <= 5 and np.isfinite(plain.centers).all()
    with pytest.raises(ValueError):
        scenes.make_clip(np.random.default_rng(0), ["fog"], 3)


def test_drone_is_drawn_at_its_ground_truth():
    clip = scenes.make_clip(np.random.default_rng(5), (), 4)
    for frame, (x, y) in zip(clip.frames, clip.centers):
        sky = np.median(frame)
        dev = np.abs(frame.astype(float) - sky)
        iy, ix = np.unravel_index(np.argmax(dev), dev.shape)
        assert np.hypot(ix - x, iy - y) <= 2.0 and dev.max() >= 5


CENTERS = np.array([[20.3, 30.6], [50.0, 10.0], [np.nan, np.nan], [np.nan, np.nan]])
DIAMETERS = np.array([4.0, 4.0, 0.0, 0.0])
CLIPS = np.array([0, 0, 1, 1])


def test_point_metrics_on_known_detections():
    # One peak per frame at the drone: located and AP 1; points have no AP50.
    heat = np.zeros((4, 60, 80))
    heat[0, 31, 20] = heat[1, 10, 50] = 0.9
    found = metrics.peaks(heat, k=1)
    keep = np.isfinite(found[..., 2]) & (found[..., 2] > 0)
    r = metrics.records(np.nonzero(keep)[0], found[keep][:, 2], found[keep][:, :2], CENTERS, DIAMETERS, CLIPS)
    s = metrics.summary(r)
    assert (s["located_3px"], s["ap"]) == (1.0, 1.0) and math.isnan(s["ap50"])
    # A miss (frame 1) and a false detection on each drone-free frame, all
    # three stronger than the one hit: AP = precision 1/4 at the first of 2 drones.
    frame = np.array([0, 1, 2, 3])
    score = np.array([0.5, 0.9, 0.8, 0.8])
    where = np.array([[20.0, 31.0], [70.0, 40.0], [5.0, 5.0], [60.0, 50.0]])
    s = metrics.summary(metrics.records(frame, score, where, CENTERS, DIAMETERS, CLIPS))
    assert s["located_3px"] == 0.5 and math.isclose(s["ap"], 0.5 * (1 / 4), rel_tol=1e-12)


def test_box_metrics_on_known_detections():
    exact = metrics.drone_boxes(CENTERS[:2], DIAMETERS[:2])
    s = metrics.summary(metrics.records(np.array([0, 1]), np.array([0.9, 0.8]), exact, CENTERS, DIAMETERS, CLIPS))
    assert (s["ap"], s["ap50"], s["ap50_95"], s["located_3px"]) == (1.0, 1.0, 1.0, 1.0)
    # Shifted by 1 px of a 4 px box: IoU 12/20 = 0.6, true at 0.50, 0.55 and
    # 0.60 only. A weaker exact box on drone 0 is a duplicate where the
    # shifted one matched, and the match from IoU 0.65 on (COCO's greedy
    # matching): there, precision 1/3 at recall 1/2, AP 1/6.
    shifted = exact + np.array([1.0, 0.0, 1.0, 0.0])
    boxes = np.concatenate([shifted, exact[:1]])
    r = metrics.records(np.array([0, 1, 0]), np.array([0.9, 0.8, 0.1]), boxes, CENTERS, DIAMETERS, CLIPS)
    assert r.hits[:, 1:].sum(axis=0).tolist() == [2, 2, 2] + [1] * 7
    assert r.hits[2, 1:4].tolist() == [False] * 3 and r.hits[2, 4:].all()
    s = metrics.summary(r)
    assert s["ap50"] == 1.0 and math.isclose(s["ap50_95"], (3 + 7 / 6) / 10, rel_tol=1e-12)


def _records(hit_frames, clips=6, seed_offset=0):
    """Records of 2-frame clips (frame 0 with a drone, frame 1 without), one
    detection per drone frame, true on the frames in hit_frames."""
    n = 2 * clips
    centers = np.full((n, 2), np.nan)
    centers[::2] = [30.0, 30.0]
    frame = np.arange(0, n, 2)
    where = np.where(np.isin(frame, hit_frames)[:, None], [30.0, 30.0], [90.0, 90.0])
    score = np.linspace(0.9, 0.4, len(frame)) + seed_offset
    return metrics.records(frame, score, where, centers, np.where(np.isfinite(centers[:, 0]), 3.0, 0.0),
                           np.repeat(np.arange(clips), 2))


def test_paired_intervals_resolve_a_clear_difference_and_not_an_identity():
    perfect = {s: _records(np.arange(0, 12, 2)) for s in range(3)}
    none = {s: _records([]) for s in range(3)}
    values = stats.replicates({"rf": perfect, "same": perfect, "blind": none}, "ap", reps=200)
    assert stats.interval(values["rf"]) == stats.Interval(1.0, 1.0, 1.0)
    diff = stats.paired(values, "rf", ["rf", "same", "blind"])
    assert set(diff) == {"same", "blind"}
    assert diff["same"] == stats.Interval(0.0, 0.0, 0.0) and not diff["same"].resolved
    assert diff["blind"].estimate == 1.0 and diff["blind"].resolved
    # Half the drones found: the interval of the AP is a proper one around it.
    half = {s: _records([0, 4, 8]) for s in range(3)}
    iv = stats.interval(stats.replicates({"half": half}, "ap", reps=300)["half"])
    assert iv.low < iv.estimate < iv.high and 0 <= iv.low and iv.high <= 1


def test_strata_keep_each_stratum_s_count_of_seeds_in_every_replicate():
    """Seeds 0, 1 find every drone, seeds 2, 3 none: resampled across all
    seeds the mean AP varies between replicates; resampled within the two
    strata every replicate holds two of each, so the interval is the point."""
    per = {"x": {s: _records(np.arange(0, 12, 2) if s < 2 else []) for s in range(4)}}
    free = stats.interval(stats.replicates(per, "ap", reps=300)["x"])
    assert free.estimate == 0.5 and free.low < 0.5 < free.high
    strata = {0: "a", 1: "a", 2: "b", 3: "b"}
    assert stats.interval(stats.replicates(per, "ap", reps=300, strata=strata)["x"]) == stats.Interval(0.5, 0.5, 0.5)
    # One stratum is the plain bootstrap, draw for draw.
    one = stats.replicates(per, "ap", reps=50, strata=dict.fromkeys(range(4), "all"))["x"]
    assert np.array_equal(one, stats.replicates(per, "ap", reps=50)["x"])


def test_flow_coding_direction_and_normalisation():
    f = np.zeros((1, 4, 2), np.float32)
    f[0, 1] = [2.0, 0.0]  # right, the longest: full value, red
    f[0, 2] = [-1.0, 0.0]  # left, half as long: cyan at half value
    f[0, 3] = [0.0, 2.0]  # down (y grows down): hue 90 degrees
    rgb = flow.hsv(f)
    assert rgb.shape == (1, 4, 3) and rgb.dtype == np.uint8
    assert rgb[0, 0].tolist() == [0, 0, 0]  # no motion: black
    assert rgb[0, 1].tolist() == [255, 0, 0]
    assert rgb[0, 2, 0] == 0 and abs(int(rgb[0, 2, 1]) - 128) <= 1 and rgb[0, 2, 1] == rgb[0, 2, 2]
    assert rgb[0, 3, 1] == 255 and rgb[0, 3, 2] == 0 and 120 <= rgb[0, 3, 0] <= 135


def test_a_flow_method_that_raises_gives_zero_flow():
    """PCAFlow raises on a featureless pair (no points to track): that pair
    is coded as no motion, black, instead of ending the run."""
    flat = np.full((2, 40, 48), 128, np.uint8)
    img = inputs.BY_NAME["pcaflow"].make(flat)
    assert img.shape == (1, 40, 48, 3) and not img.any()


def test_every_input_is_computed_on_the_same_pairs():
    clip = scenes.make_clip(np.random.default_rng(1), ("clouds",), 4)
    for inp in inputs.INPUTS:
        x = inp.make(clip.frames)
        assert x.shape[:3] == (3, scenes.HEIGHT, scenes.WIDTH) and x.dtype == np.uint8, inp.name
        assert inputs.three_channels(x).shape == (3, scenes.HEIGHT, scenes.WIDTH, 3), inp.name
    # The flows move with the clouds: a flow image is not blank.
    assert inputs.BY_NAME["farneback"].make(clip.frames).max() > 0


NO_NETWORK = textwrap.dedent(
    """
    import json, socket, sys
    import numpy as np
    attempts = []
    def deny(*args, **kwargs):
        attempts.append(repr(args[:2]))
        raise OSError("network access attempted")
    socket.getaddrinfo = socket.create_connection = socket.socket.connect = deny
    socket.socket.connect_ex = deny
    from reynoldsflow.bench.downstream import yolo
    rng = np.random.default_rng(0)
    x = rng.integers(0, 255, size=(6, 64, 64, 3), dtype=np.uint8)
    centers = np.array([[20.0, 30.0]] * 4 + [[np.nan, np.nan]] * 2)
    (frame, score, boxes), trained = yolo.train_and_detect(
        x, centers, np.array([4.0] * 4 + [0.0] * 2), x[:2], seed=0, epochs=1, batch=4, size=64,
        device="cpu", scratch=__import__("pathlib").Path(sys.argv[1]) / "job")
    print(json.dumps(dict(attempts=attempts, steps=trained.steps, boxes=list(boxes.shape),
                          modules=sorted(m for m in sys.modules if m.split(".")[0] == "ultralytics")[:1])))
    """
)


def test_yolo_trains_from_its_yaml_without_network_access(tmp_path):
    """YOLO11n is built from ultralytics' YAML and trained and run with every
    socket connection and name lookup refused: none is attempted."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("YOLO_")}
    res = subprocess.run([sys.executable, "-c", NO_NETWORK, str(tmp_path)], capture_output=True, text=True,
                         env=env, timeout=600)
    assert res.returncode == 0, res.stderr[-4000:]
    got = json.loads(res.stdout.strip().splitlines()[-1])
    assert got["attempts"] == [] and got["steps"] == 2 and got["boxes"][1:] == [4]
    assert got["modules"] == ["ultralytics"]
    assert not (tmp_path / "job").exists(), "the job's scratch folder outlived it"


def test_package_does_not_import_ultralytics():
    code = ("import sys, reynoldsflow, reynoldsflow.bench.downstream.run, reynoldsflow.bench.downstream.inputs; "
            "print(any(m.split('.')[0] == 'ultralytics' for m in sys.modules))")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0 and res.stdout.strip() == "False", res.stderr

"""The separability study (python -m reynoldsflow.bench.separability): its
statistics on a constructed case whose answer is known by hand (a bright
blob on flat Gaussian noise), the bootstrap's pieces, and the --quick
run's structure (every input and channel present, every interval
computed, the paired differences) -- not its figures."""

import csv
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import run_bench_quick

from reynoldsflow.bench.separability import channels, measure, report

H, W = 60, 80


def _noise(seed, sigma, n=1):
    return 100.0 + np.random.default_rng(seed).normal(0, sigma, size=(n, H, W))


def test_scr_of_a_bright_blob_on_flat_noise_is_computed_by_hand():
    # A blob of +20 levels on every pixel within d/2 + 1 px of its centre,
    # on noise of 2 levels: SCR = |mean_T - mean_B| / std_B over the
    # documented regions, about 20 / 2 = 10.
    sigma, amp, d, c = 2.0, 20.0, 4.0, np.array([40.3, 30.6])
    x = _noise(1, sigma)[0]
    yy, xx = np.mgrid[0:H, 0:W]
    dist = np.hypot(xx - c[0], yy - c[1])
    x[dist <= d / 2 + 1] += amp
    t_hand = dist <= d / 2 + 1
    b_hand = (np.abs(xx - 40) <= 10) & (np.abs(yy - 30) <= 10) & (dist > d / 2 + 4)
    want = abs(x[t_hand].mean() - x[b_hand].mean()) / x[b_hand].std()
    t, b, far = measure.regions(x.shape, c, d)
    assert np.array_equal(t, t_hand) and np.array_equal(b, b_hand) and np.array_equal(far, dist > d / 2 + 11)
    got, sd = measure.scr(x, t, b)
    assert got == pytest.approx(want, rel=1e-12) and sd == pytest.approx(x[b_hand].std(), rel=1e-12)
    assert got == pytest.approx(amp / sigma, rel=0.1)
    # Flat background: std_B 0, the SCR capped, not infinite.
    flat = np.full((H, W), 100.0)
    flat[t_hand] += 5
    assert measure.scr(flat, t, b) == (measure.SCR_CAP, 0.0)


def test_local_contrast_is_its_windows_by_hand():
    x = _noise(2, 3.0)[0]
    d = measure.local_contrast(x)
    i, j = 30, 40
    inner = x[i - 1 : i + 2, j - 1 : j + 2].mean()
    outer = x[i - 10 : i + 11, j - 10 : j + 11]
    guard = x[i - 4 : i + 5, j - 4 : j + 5]
    ring = (outer.sum() - guard.sum()) / (21 * 21 - 9 * 9)
    assert d[i, j] == pytest.approx(abs(inner - ring), rel=1e-9)


def test_pd_at_a_false_alarm_rate_on_flat_noise_is_computed_by_hand():
    # Noise of sigma 3: the statistic D = |3x3 mean - ring mean| is
    # |N(0, s^2)| with s^2 = sigma^2 (1/9 + 1/360) at every background pixel,
    # so the threshold at Fa 1e-3 is s z(1 - 5e-4) = 3.29 s. Half the drone
    # frames hold a 9x9 block of +25 levels (D ~ 25 >> the threshold: all
    # detected), half hold nothing (detected only by a noise excursion in
    # T, ~1e-3 per pixel): Pd = 0.5, plus at most a few percent.
    sigma, n = 3.0, 400
    frames = _noise(3, sigma, n)
    c, d = np.array([40.0, 30.0]), 9.0
    frames[: n // 2, 26:35, 36:45] += 25
    # The background: the blob-free frames (pure noise), away from the
    # border (where the mirrored windows change the statistic's spread).
    t, _, _ = measure.regions((H, W), c, d)
    bg = np.zeros(measure.NBINS, np.int64)
    tg = np.zeros(measure.NBINS, np.int64)
    for k, x in enumerate(frames):
        s = measure.local_contrast(x)
        if k >= n // 2:
            bg += measure.histogram(s[11:-11, 11:-11])
        tg[measure.to_bins(s[t].max())] += 1
    s_hand = sigma * math.sqrt(1 / 9 + 1 / 360)
    tau = measure.threshold_at(bg, 1e-3)
    assert tau == pytest.approx(3.2905 * s_hand, rel=0.05)
    pd = measure.pd_at(bg, tg, (1e-3,))[0]
    assert 0.5 <= pd <= 0.56
    # The realised false-alarm rate is at most the rate asked, and close.
    realised = np.mean([(measure.local_contrast(x)[11:-11, 11:-11] >= tau).mean() for x in frames[n // 2 :]])
    assert 0.6e-3 <= realised <= 1e-3 * 1.0 + 1e-12
    # Replicates along a leading axis give the same answer row by row.
    both = measure.pd_at(np.stack([bg, bg]), np.stack([tg, tg]))
    assert both.shape == (2, len(measure.FAS)) and np.allclose(both[0], both[1])


def test_bins_cover_the_scores_in_order():
    s = np.array([0.0, measure.UNIT, 2 * measure.UNIT, 1.0, 100.0])
    b = measure.to_bins(s)
    assert b[0] == b[1] == 0 and b[2] == measure.PER_OCTAVE + 1 and np.all(np.diff(b[1:]) > 0)
    assert np.all(measure.bin_floor(b[2:]) <= s[2:] * (1 + 1e-9))


def test_bootstrap_weights_and_weighted_median():
    w = measure.resample([[0, 1, 2], [3, 4]], 200, seed=1)
    assert w.shape == (201, 5) and np.all(w[0] == 1)
    # Each replicate draws 2 seeds, each brings as many clips as it has.
    assert set(w[1:].sum(1)) <= {4.0, 5.0, 6.0}
    v = np.array([3.0, 1.0, 2.0, 5.0, 4.0, np.nan])
    clip = np.array([0, 1, 2, 3, 4, 4])
    assert measure.weighted_median(v, clip, w[:1])[0] == 3.0
    est, lo, hi = measure.interval(measure.weighted_median(v, clip, w))
    assert est == 3.0 and 1.0 <= lo <= est <= hi <= 5.0


def test_fisher_weights_the_separating_channel():
    rng = np.random.default_rng(4)
    bg = rng.normal(0, 1, size=(2000, 2))
    tg = rng.normal(0, 1, size=(300, 2)) + [0.0, 4.0]
    w = measure.fisher(tg, bg)
    assert abs(w[1]) > 0.95 and w[1] > 0


def test_every_input_has_its_channels_named():
    from reynoldsflow.bench.downstream import scenes

    frames = scenes.make_clip(np.random.default_rng(5), scenes.FACTORS, 3).frames
    got = channels.maps(frames, channels.DEFAULT)
    assert len(got) == 2
    for name in channels.DEFAULT:
        assert got[0][name].shape == (len(channels.NAMES[name]), scenes.HEIGHT, scenes.WIDTH), name
        assert got[0][name].dtype == np.float32
    with pytest.raises(ValueError, match="unknown inputs"):
        channels.select(["rf", "sobel"])
    assert channels.select(["diff"]) == ("gray", "diff", "rf")


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("separability")
    return out, run_bench_quick("separability", out, threads=1, timeout=600)


def test_quick_run_has_every_input_channel_and_interval(quick):
    out, stdout = quick
    assert sorted(p.name for p in out.iterdir()) == ["intervals.csv", "plot.png", "report.md"]
    assert (out / "plot.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with open(out / "intervals.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == report.COLUMNS
    key = {(r["family"], r["input"], r["score"], r["metric"], r["bin"]): r for r in rows}
    for fam in ("sky", "real"):
        for n in channels.DEFAULT:
            for score in list(channels.NAMES[n]) + ["combination"]:
                for m in report.PD_METRICS:
                    r = key[(fam, n, score, m, "all")]
                    lo, est, hi = float(r["low"]), float(r["estimate"]), float(r["high"])
                    assert 0 <= lo <= est <= hi <= 1, r  # an interval computed, around its estimate
            for c in channels.NAMES[n]:
                r = key[(fam, n, c, "scr", "all")]
                assert math.isfinite(float(r["low"])) and float(r["low"]) <= float(r["high"]), r
                # Gain and BSF are undefined (NaN) where a channel is flat
                # around every drone (an HSV channel of a flow that found
                # nothing): present, and ordered where defined.
                for m in ("scr_gain", "bsf"):
                    r = key[(fam, n, c, m, "all")]
                    assert not float(r["low"]) > float(r["high"]), r
            for dim, label, _, _ in report.BINS:
                assert (fam, n, "combination", "pd@1e-04", f"{dim} {label}") in key
            if n != channels.REFERENCE:
                for m in report.PD_METRICS:
                    r = key[(fam, n, "rf − input", m, "all")]
                    assert r["resolved"] in ("True", "False") and float(r["low"]) <= float(r["high"])
    text = (out / "report.md").read_text()
    assert "`python -m reynoldsflow.bench.separability --out" in text
    for n in channels.DEFAULT:
        assert f"\n| {n} | " in text
    assert stdout.strip().startswith("| input | generated skies: Pd at Fa 1e-4 | real footage: Pd at Fa 1e-4 |")
    assert stdout.strip() in text


def test_bad_options_are_refused_before_any_work(tmp_path):
    for args, word in ((["--inputs", "rf,sobel"], "--inputs"), (["--families", "moon"], "--families")):
        res = subprocess.run([sys.executable, "-m", "reynoldsflow.bench.separability", "--out", str(tmp_path / "o"),
                              "--quick"] + args, capture_output=True, text=True, timeout=120)
        assert res.returncode == 2 and word in res.stderr
        assert not (tmp_path / "o").exists()
    res = subprocess.run([sys.executable, "-m", "reynoldsflow.bench.separability", "--out", str(tmp_path / "o"),
                          "--seeds", "0"], capture_output=True, text=True, timeout=120)
    assert res.returncode == 2 and "--seeds" in res.stderr


def _md_rows(text, header_start):
    lines = text.splitlines()
    start = next(i for i, l in enumerate(lines) if l.startswith(header_start))
    out = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        out.append(line)
    return out


def test_docs_carry_the_committed_run():
    """docs/evaluation.md's separability table is the committed run's
    headline (docs/downstream/separability/report.md, whose command is named
    beside it), and the README's figures are that run's within 2x."""
    root = Path(os.environ["REYNOLDSFLOW_REPO"])
    rep = (root / "docs" / "downstream" / "separability" / "report.md").read_text()
    command = next(l for l in rep.splitlines() if l.startswith("Command: `")).split("`")[1]
    assert command.startswith("python -m reynoldsflow.bench.separability --out docs/downstream/separability")
    docs = (root / "docs" / "evaluation.md").read_text()
    header = "| input | generated skies: Pd at Fa 1e-4 | real footage: Pd at Fa 1e-4 |"
    assert _md_rows(docs, header) == _md_rows(rep, header) and len(_md_rows(rep, header)) >= 10
    assert command.split(" --out ")[0] + " --out" in " ".join(docs.split())
    with open(root / "docs" / "downstream" / "separability" / "intervals.csv", newline="") as f:
        rows = {(r["family"], r["input"], r["score"], r["metric"], r["bin"]): float(r["estimate"])
                for r in csv.DictReader(f)}
    line = next(l for l in (root / "README.md").read_text().splitlines() if "docs/evaluation.md" in l and "separability" in l)
    import re

    for name, value in re.findall(r"`(rf|gray|diff)` (\d\.\d\d)", line):
        want = rows[("sky", name, "combination", "pd@1e-03", "all")]
        assert want / 2 <= float(value) <= want * 2 or abs(float(value) - want) < 0.005, (name, value, want)
    assert re.findall(r"`(rf|gray|diff)` (\d\.\d\d)", line)

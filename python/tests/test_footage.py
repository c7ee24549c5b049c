"""The real-footage panel (python -m reynoldsflow.bench.footage) on a small
clip the test encodes itself with ffmpeg: the files it writes, the panel's
size and rows, the frames it picks, and its errors (no video, a file that
is no video, no ffmpeg), which write nothing."""

import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

from conftest import read_png
from reynoldsflow.bench import footage

W, H, FRAMES = 96, 64, 8


def _run(*args, env=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "reynoldsflow.bench.footage", *map(str, args)],
                          capture_output=True, text=True, env=env, timeout=300)


@pytest.fixture(scope="module")
def video(tmp_path_factory):
    """An MPEG-4 AVI of ffmpeg's moving test pattern, W x H, FRAMES frames."""
    ffmpeg = shutil.which("ffmpeg")
    assert ffmpeg, "ffmpeg is needed (scripts/test and scripts/test-python install it)"
    path = tmp_path_factory.mktemp("footage-clip") / "clip.avi"
    res = subprocess.run([ffmpeg, "-nostdin", "-hide_banner", "-loglevel", "error", "-f", "lavfi",
                          "-i", f"testsrc=size={W}x{H}:rate=10", "-frames:v", str(FRAMES),
                          "-c:v", "mpeg4", "-q:v", "2", "-pix_fmt", "yuv420p", str(path)],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    return path


def _rows_drawn(png: np.ndarray, pairs: int, w: int, h: int) -> None:
    """Each of the `pairs` rows of images is drawn where the layout puts it,
    with background (white) between rows and below the last one."""
    for row in range(pairs):
        top = footage.TOP + row * (h + footage.GAP_Y)
        for col in range(len(footage.COLUMNS)):
            left = footage.LEFT + col * (w + footage.GAP_X)
            cell = png[top + 2 : top + h - 2, left + 2 : left + w - 2]
            assert cell.size and not (cell == 255).all(), (row, col)
        gap = png[top + h + footage.GAP_Y // 2, footage.LEFT + 2 : -footage.RIGHT - 2]
        assert (gap == 255).all(), row


@pytest.mark.parametrize("pairs, width, size", [(3, 0, (W, H)), (2, 48, (48, 32))])
def test_panel_and_description(tmp_path, video, pairs, width, size):
    out = tmp_path / "out"
    res = _run("--video", video, "--out", out, "--pairs", pairs, "--width", width)
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in out.iterdir()) == ["footage.md", "footage.png"]  # no temporary left
    png = read_png(out / "footage.png")
    want_w, want_h = footage.panel_size(pairs, *size)
    assert abs(png.shape[1] - want_w) <= 1 and abs(png.shape[0] - want_h) <= 1, (png.shape, want_w, want_h)
    _rows_drawn(png, pairs, *size)

    md = (out / "footage.md").read_text()
    starts = footage.pair_starts(FRAMES, pairs)
    rows = re.findall(r"^\| (\d+) \| (\d+), (\d+) \| ([\d.]+) \| ([\d.]+) \|$", md, re.M)
    assert [(int(r[1]), int(r[2])) for r in rows] == [(t, t + 1) for t in starts]
    assert [float(r[3]) for r in rows] == [round(t / 10, 1) for t in starts]  # 10 frames/s
    assert all(float(r[4]) > 0 for r in rows)  # the pattern moves
    scaled = f", decoded at {size[0]}×{size[1]} (ffmpeg `scale`, area)" if size != (W, H) else ""
    assert f"`clip.avi`, {W}×{H}{scaled}, {FRAMES} frames, 10 frames/s" in md
    assert f"--pairs {pairs} --width {width}" in md
    assert "not stated (give it with --source)" in md


def test_source_is_recorded(tmp_path, video):
    out = tmp_path / "out"
    res = _run("--video", video, "--out", out, "--pairs", 1, "--source", "ffmpeg's testsrc")
    assert res.returncode == 0, res.stderr
    assert "- Source: ffmpeg's testsrc." in (out / "footage.md").read_text()


def _fails(res, out, *words):
    assert res.returncode != 0
    assert res.stderr.startswith(f"{footage.PROG}: error: "), res.stderr
    for word in words:
        assert word in res.stderr, res.stderr
    assert not (out / "footage.png").exists() and not (out / "footage.md").exists()


def test_missing_video(tmp_path):
    out = tmp_path / "out"
    _fails(_run("--video", tmp_path / "nope.avi", "--out", out), out, "nope.avi: no such video file")


def test_not_a_video(tmp_path):
    bad = tmp_path / "bad.avi"
    bad.write_bytes(b"RIFF not really a video" * 10)
    out = tmp_path / "out"
    _fails(_run("--video", bad, "--out", out), out, "bad.avi: ffprobe cannot read it")


def test_missing_ffmpeg(tmp_path, video):
    out = tmp_path / "out"
    env = dict(os.environ, REYNOLDSFLOW_FFMPEG=str(tmp_path / "no-ffmpeg"))
    _fails(_run("--video", video, "--out", out, env=env), out, "ffmpeg", "was not found", "apt-get install ffmpeg")


def test_too_many_pairs(tmp_path, video):
    out = tmp_path / "out"
    _fails(_run("--video", video, "--out", out, "--pairs", FRAMES), out,
           f"--pairs {FRAMES}: the clip has {FRAMES} frames, so 1 to {FRAMES - 1} pairs")


def test_bad_option_is_a_usage_error(tmp_path, video):
    res = _run("--video", video, "--out", tmp_path / "out", "--pairs", 0)
    assert res.returncode == 2 and "argument --pairs: 0: at least 1" in res.stderr, res.stderr


def test_pair_starts_spread_and_distinct():
    for frames in range(2, 40):
        for pairs in range(1, frames):
            starts = footage.pair_starts(frames, pairs)
            assert len(set(starts)) == pairs and starts == sorted(starts), (frames, pairs)
            assert 0 <= starts[0] and starts[-1] <= frames - 2, (frames, pairs)
    assert footage.pair_starts(795, 3) == [132, 397, 661]
    with pytest.raises(footage.FootageError):
        footage.pair_starts(1, 1)


def test_scaled_size_only_scales_down():
    assert footage.scaled_size(768, 576, 384) == (384, 288)
    assert footage.scaled_size(768, 576, 0) == (768, 576)
    assert footage.scaled_size(96, 64, 384) == (96, 64)
    assert footage.scaled_size(100, 1, 10) == (10, 1)


def test_readme_panel_is_the_defaults_on_vtest(repo):
    """The committed panel (docs/downstream/footage.*) is the command at its
    defaults on the clip scripts/fetch-vtest extracts, and docs/evaluation.md shows
    it with the commands that make it."""
    md = (repo / "docs" / "downstream" / "footage.md").read_text()
    assert "`python -m reynoldsflow.bench.footage --video target/footage/vtest.avi --out docs/downstream`" in md
    digest = re.search(r"SHA-256 `([0-9a-f]{64})`", md).group(1)
    assert digest in footage.KNOWN_SOURCES and footage.KNOWN_SOURCES[digest] in md
    frames = int(re.search(r"decoded at \d+×\d+ \(ffmpeg `scale`, area\), (\d+) frames", md).group(1))
    w, h = footage.scaled_size(768, 576, footage.DEFAULT_WIDTH)
    assert f"768×576, decoded at {w}×{h}" in md
    rows = re.findall(r"^\| \d+ \| (\d+), \d+ \|", md, re.M)
    assert [int(t) for t in rows] == footage.pair_starts(frames, footage.DEFAULT_PAIRS)
    png = read_png(repo / "docs" / "downstream" / "footage.png")
    want_w, want_h = footage.panel_size(footage.DEFAULT_PAIRS, w, h)
    assert abs(png.shape[1] - want_w) <= 1 and abs(png.shape[0] - want_h) <= 1

    readme = " ".join((repo / "docs" / "evaluation.md").read_text().split())
    assert "`scripts/fetch-vtest`" in readme and (repo / "scripts" / "fetch-vtest").is_file()
    assert "`python -m reynoldsflow.bench.footage --video target/footage/vtest.avi --out DIR`" in readme
    assert "(downstream/footage.png)" in readme

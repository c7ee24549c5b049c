"""The downstream benchmark's real-footage scenes (bench.downstream.backgrounds):
a folder of generated videos works (decoded at the benchmark's size, a
drone composited at its ground truth, training and test from different
videos), and bad folders -- empty, a file ffmpeg cannot decode, videos
smaller than the crop or shorter than a clip -- give a clear error, from
the module and from the command, before anything is trained or written."""

import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from reynoldsflow.bench.downstream import backgrounds, scenes

FFMPEG = shutil.which(os.environ.get("REYNOLDSFLOW_FFMPEG", "ffmpeg"))
pytestmark = pytest.mark.skipif(FFMPEG is None and not os.environ.get("REYNOLDSFLOW_REQUIRE_FFMPEG"),
                                reason="ffmpeg is not installed")


def _video(path, size="200x150", frames=12, source="testsrc2"):
    subprocess.run([FFMPEG, "-v", "error", "-y", "-f", "lavfi", "-i", f"{source}=size={size}:rate=10",
                    "-frames:v", str(frames), "-pix_fmt", "yuv420p", "-f", "yuv4mpegpipe", str(path)], check=True)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    d = tmp_path_factory.mktemp("videos")
    _video(d / "a.y4m", source="testsrc2")
    _video(d / "b.y4m", size="320x180", source="mandelbrot")
    _video(d / "c.y4m", source="life")
    return d


def test_a_folder_of_videos_gives_clips_with_exact_drones(folder):
    paths = backgrounds.folder_videos(folder)
    assert [p.name for p in paths] == ["a.y4m", "b.y4m", "c.y4m"]
    train, test = backgrounds.split(paths, seed=0)
    assert len(test) == 1 and not set(train) & set(test) and set(train) | set(test) == set(paths)
    # Each seed tests on another video.
    assert {tuple(backgrounds.split(paths, s)[1]) for s in range(3)} == {(p,) for p in paths}
    clips = backgrounds.clips(train, seed=0, part=0, n=4, frames=5)
    assert len(clips) == 4 and [c.has_drone for c in clips] == [True, True, True, False]
    for c in clips:
        assert c.frames.shape == (5, scenes.HEIGHT, scenes.WIDTH) and c.frames.dtype == np.uint8
    # The drone is where its ground truth says: the composite differs from
    # the same crop without it only within the drone's radius (+1 px).
    rng = np.random.default_rng(7)
    video = backgrounds.load(paths[0], scenes.WIDTH, scenes.HEIGHT, 5)
    with_drone = backgrounds.make_clip(np.random.default_rng(7), video, 5, drone=True)
    without = backgrounds.make_clip(rng, video, 5, drone=False)
    assert 2 <= with_drone.diameter <= 6 and 10 <= with_drone.contrast <= 40
    steps = np.hypot(*np.diff(with_drone.centers, axis=0).T)
    assert (steps < 1.0).all(), "the drone moves by less than a pixel per frame"
    for t in range(5):
        diff = np.abs(with_drone.frames[t].astype(int) - without.frames[t].astype(int))
        ys, xs = np.nonzero(diff)
        assert len(xs) > 0
        x, y = with_drone.centers[t]
        assert np.hypot(xs - x, ys - y).max() <= with_drone.diameter / 2 + 1.5


def test_videos_are_decoded_at_the_benchmarks_size(folder):
    v = backgrounds.load(folder / "b.y4m", scenes.WIDTH, scenes.HEIGHT, 5)
    n, h, w = v.frames.shape
    assert n == 12 and h >= scenes.HEIGHT and w >= scenes.WIDTH
    # Scaled to cover 1.25x the crop (320x180 -> 267x150), never below it.
    assert (w, h) == (267, 150)


@pytest.mark.parametrize("case", ["empty", "unreadable", "too small", "too short", "one video", "not a folder"])
def test_bad_folders_give_a_clear_error(tmp_path, case):
    d = tmp_path / "bg"
    d.mkdir()
    expect = {
        "empty": "no files in it",
        "unreadable": "cannot be read",
        "too small": "smaller than the crop 160x120",
        "too short": "fewer than a clip's 5",
        "one video": "at least 2 videos",
        "not a folder": "not a folder",
    }[case]
    if case == "unreadable":
        _video(d / "good.y4m")
        (d / "notes.mp4").write_text("not a video\n")
    elif case == "too small":
        _video(d / "good.y4m")
        _video(d / "small.y4m", size="64x48")
    elif case == "too short":
        _video(d / "good.y4m")
        _video(d / "short.y4m", frames=3)
    elif case == "one video":
        _video(d / "good.y4m")
    elif case == "not a folder":
        d = tmp_path / "missing"
    with pytest.raises(backgrounds.BackgroundError, match=expect):
        paths = backgrounds.folder_videos(d)
        for p in paths:
            backgrounds.load(p, scenes.WIDTH, scenes.HEIGHT, 5)
        backgrounds.split(paths, 0)
    # The command says the same and writes nothing.
    out = tmp_path / "out"
    res = subprocess.run([sys.executable, "-m", "reynoldsflow.bench.downstream", "--out", str(out), "--quick",
                          "--frames", "5", "--backgrounds", str(d)], capture_output=True, text=True, timeout=120)
    assert res.returncode == 2 and expect in res.stderr and "Traceback" not in res.stderr, res.stderr
    assert not out.exists()

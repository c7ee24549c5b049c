"""Frames taken and resized before the pairs (step, fps, resize,
short_side), output types (npy_dtype, image_format): the Python package
gives what the command line's flags of the same names give."""

import numpy as np
import pytest

import reynoldsflow as rf
from conftest import clip, read_png, run_cli, tree, write_pgm, write_y4m


def write_y4m_at(path, frames, rate: str):
    """Gray frames as a mono Y4M at `rate` ("30:1")."""
    t, h, w = frames.shape
    out = bytearray(b"YUV4MPEG2 W%d H%d F%s Ip A1:1 Cmono\n" % (w, h, rate.encode()))
    for f in frames:
        out += b"FRAME\n" + np.ascontiguousarray(f).tobytes()
    path.write_bytes(bytes(out))


def cli_reps(cli, tmp_path, src, *flags):
    out = tmp_path / "cli"
    run_cli(cli, "run", src, "--out", out, *flags)
    names = sorted(p for p in tree(out) if p.endswith(".png"))
    return names, np.stack([read_png(out / n) for n in names])


def test_represent_clip_steps_and_resizes_as_run_does(cli, tmp_path):
    frames = clip(9, 48, 32)
    src = tmp_path / "clip.y4m"
    write_y4m(src, frames)
    names, reps = cli_reps(cli, tmp_path, src, "--step", "2", "--resize", "30x20")
    assert names == ["000000_000002.png", "000002_000004.png", "000004_000006.png", "000006_000008.png"]
    got = rf.represent_clip(frames, step=2, resize=(30, 20))
    assert got.shape == (4, 20, 30, 3)
    assert np.array_equal(got, reps)
    assert np.array_equal(rf.represent_clip(frames, step=2, resize="30x20"), reps)
    # short_side: 48x32 at 20 -> 30x20, the same resampler.
    assert np.array_equal(rf.represent_clip(frames, step=2, short_side=20), reps)
    assert np.array_equal(rf.represent_clip(frames, step=2, resize=(30, 20), layout="chw"),
                          reps.transpose(0, 3, 1, 2))


def test_fps_takes_frames_of_the_input_rate(cli, tmp_path):
    frames = clip(10, 40, 24)
    src = tmp_path / "clip.y4m"
    write_y4m_at(src, frames, "30:1")
    taken = list(rf.read_frames(src, fps=10))
    assert [i for i, _ in taken] == [0, 3, 6, 9]
    for i, f in taken:
        assert np.array_equal(f, frames[i])
    assert rf.read_frames(src, fps=10).frame_rate == (10, 1)
    names, reps = cli_reps(cli, tmp_path, src, "--fps", "10")
    assert names == ["000000_000003.png", "000003_000006.png", "000006_000009.png"]
    assert np.array_equal(rf.represent_clip(frames, fps=10, source_fps=30), reps)
    assert np.array_equal(rf.represent_clip(frames, fps="10/1", source_fps="30000/1000"), reps)
    with pytest.raises(ValueError, match="source_fps"):
        rf.represent_clip(frames, fps=10)
    folder = tmp_path / "frames"
    folder.mkdir()
    for i, f in enumerate(frames[:3]):
        write_pgm(folder / f"f{i}.pgm", f)
    with pytest.raises(ValueError, match="frame rate"):
        list(rf.read_frames(folder, fps=10))
    resized = [f.shape for _, f in rf.read_frames(folder, short_side=12, max_frames=2)]
    assert resized == [(12, 20), (12, 20)]


def test_convert_makes_the_files_of_dataset_with_the_new_flags(cli, tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    write_y4m(src / "clip.y4m", clip(7, 48, 32))
    flags = {"step": 2, "short_side": 16, "npy": "v_R", "npy_dtype": "f16",
             "image_format": "jpg", "jpeg_quality": 80}
    run_cli(cli, "dataset", src, tmp_path / "cli", "--step", "2", "--short-side", "16", "--npy=v_R",
            "--npy-dtype", "f16", "--image-format", "jpg", "--jpeg-quality", "80")
    record = rf.convert(src / "clip.y4m", tmp_path / "py" / "clip", **flags)
    assert record["status"] == "done"
    assert record["source_frames"] == [0, 2, 4, 6]
    made = tree(tmp_path / "py")
    assert made == tree(tmp_path / "cli")
    jpgs = sorted(p for p in made if p.endswith(".jpg"))
    assert jpgs == ["clip/000000_000002.jpg", "clip/000002_000004.jpg", "clip/000004_000006.jpg"]
    assert read_png(tmp_path / "py" / jpgs[0]).shape == (16, 24, 3)
    field = np.load(tmp_path / "py" / "clip" / "v_R" / "000000_000002.npy")
    assert field.dtype == np.float16 and field.shape == (16, 24, 2)


def test_bad_frame_options_raise_with_the_flags_message():
    frames = clip(4)
    for kwargs, error, message in [
        ({"step": 0}, ValueError, "step"),
        ({"short_side": 15}, ValueError, "even"),
        ({"resize": (0, 10)}, ValueError, "WxH"),
        ({"resize": "big"}, ValueError, "WxH"),
        ({"resize": 3}, TypeError, "width, height"),
        ({"fps": 0, "source_fps": 30}, ValueError, "above 0"),
        ({"step": 2, "fps": 10, "source_fps": 30}, ValueError, "not both"),
        ({"resize": (8, 8), "short_side": 8}, ValueError, "not both"),
        ({"layout": "nchw"}, ValueError, "chw"),
        ({"step": 4}, ValueError, "at least 2"),
    ]:
        with pytest.raises(error, match=message):
            rf.represent_clip(frames, **kwargs)
    for kwargs, message in [({"npy_dtype": "f8"}, "f16"), ({"image_format": "gif"}, "png"),
                            ({"jpeg_quality": 0}, "1 to 100")]:
        with pytest.raises(ValueError, match=message):
            rf.convert("/nonexistent.y4m", "/tmp/never", **kwargs)

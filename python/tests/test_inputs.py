"""Any strides and layouts give the bytes of a contiguous (H, W) copy; bad
arguments raise TypeError or ValueError with a readable message."""

import numpy as np
import pytest

import reynoldsflow as rf
from conftest import clip, moving_frame, write_pgm


def layouts(frame):
    """The same pixels as strided, Fortran-order, read-only and (H, W, 1) arrays."""
    h, w = frame.shape
    big = np.zeros((2 * h, 3 * w), np.uint8)
    big[::2, ::3] = frame
    strided = big[::2, ::3]
    assert not strided.flags.c_contiguous
    fortran = np.asfortranarray(frame)
    assert fortran.flags.f_contiguous and not fortran.flags.c_contiguous
    readonly = frame.copy()
    readonly.setflags(write=False)
    channel = frame.copy()[..., None]
    flipped = np.ascontiguousarray(frame[::-1])[::-1]
    return {"strided": strided, "fortran": fortran, "readonly": readonly,
            "channel": channel, "negative-strides": flipped}


def test_layouts_give_the_same_result_as_contiguous_copies():
    f0, f1 = moving_frame(37, 23, 0), moving_frame(37, 23, 1)
    expected = rf.represent(f0, f1)
    fields = rf.fields(f0, f1)
    l0, l1 = layouts(f0), layouts(f1)
    for name in l0:
        assert np.array_equal(rf.represent(l0[name], l1[name]), expected), name
        assert np.array_equal(rf.represent(l0[name], f1), expected), name
        got = rf.fields(l0[name], l1[name])
        for k in fields:
            assert np.array_equal(got[k], fields[k]), (name, k)
        assert rf.motion_score(l0[name], l1[name]) == rf.motion_score(f0, f1)
    c = clip(4, 37, 23)
    expected = rf.represent_clip(c)
    assert np.array_equal(rf.represent_clip(np.asfortranarray(c)), expected)
    assert np.array_equal(rf.represent_clip(c[..., None]), expected)
    big = np.zeros((4, 23, 74), np.uint8)
    big[:, :, ::2] = c
    assert np.array_equal(rf.represent_clip(big[:, :, ::2]), expected)
    ro = c.copy()
    ro.setflags(write=False)
    assert np.array_equal(rf.represent_clip(ro), expected)


def test_wrong_types_and_dimensions_raise_type_error():
    f = moving_frame(16, 12, 0)
    cases = [
        (f.astype(np.float32), f, "dtype float32 is not uint8"),
        (f.astype(np.uint16), f, "not uint8"),
        (f.astype(np.int8), f, "not uint8"),
        (f[0], f, "1 dimensions"),
        (f[None, None], f, "4 dimensions"),
        (f.tolist(), f, "expected a numpy.ndarray"),
        (None, f, "expected a numpy.ndarray"),
    ]
    for prev, nxt, message in cases:
        for fn in (rf.represent, rf.fields, rf.motion_score):
            with pytest.raises(TypeError, match=message):
                fn(prev, nxt)
            with pytest.raises(TypeError):
                fn(nxt, prev)
    with pytest.raises(TypeError, match="2 dimensions"):
        rf.represent_clip(f)
    with pytest.raises(TypeError, match="not uint8"):
        rf.represent_clip(clip(3).astype(np.float64))
    with pytest.raises(TypeError, match="unexpected keyword argument 'lambda_'"):
        rf.represent(f, f, lambda_=1e-4)
    with pytest.raises(TypeError, match="unexpected keyword argument 'variant'"):
        rf.fields(f, f, variant="dc")
    with pytest.raises(TypeError, match="lam"):
        rf.represent(f, f, lam="small")
    with pytest.raises(TypeError, match="scale"):
        rf.represent(f, f, scale=3)
    with pytest.raises(TypeError, match="intensity_scale"):
        rf.represent(f, f, intensity_scale=[1, 2, 3])
    with pytest.raises(TypeError):
        rf.Stream(16, 12).push(f.astype(np.float32))
    with pytest.raises(TypeError, match="float32 or float64"):
        rf.write_flo("x.flo", np.zeros((2, 2, 2), np.int32))


def test_wrong_shapes_and_values_raise_value_error(tmp_path):
    f = moving_frame(16, 12, 0)
    g = moving_frame(17, 12, 0)
    with pytest.raises(ValueError, match="differ in shape"):
        rf.represent(f, g)
    with pytest.raises(ValueError, match="3 channels"):
        rf.represent(np.stack([f] * 3, -1), np.stack([f] * 3, -1))
    with pytest.raises(ValueError, match="sides at least 1"):
        rf.represent(np.zeros((0, 5), np.uint8), np.zeros((0, 5), np.uint8))
    bad = [
        ({"engine": "gpu"}, "engine"),
        ({"scale": "max"}, "scale"),
        ({"scale": (-1.0, 2.0)}, "scale"),
        ({"scale": (1e6, 1.0)}, "scale"),
        ({"lam": 0.0}, "lam"),
        ({"lam": float("nan")}, "lam"),
        ({"lam": 1e9}, "lam"),
        ({"intensity_scale": 2.0}, "intensity_scale"),
        ({"intensity_scale": 0.1234567891234}, "intensity_scale"),
        ({"intensity_scale": (1, 0)}, "intensity_scale"),
        ({"tile": (0, 4)}, "tile"),
        ({"engine": "float", "tile": (8, 8)}, "tile"),
        ({"variant": "rgb"}, "variant"),
        ({"hsv_max": -1.0}, "hsv_max"),
    ]
    for kwargs, word in bad:
        with pytest.raises(ValueError, match=word):
            rf.represent(f, f, **kwargs)
    c = clip(3)
    with pytest.raises(ValueError, match="threads"):
        rf.represent_clip(c, threads=0)
    with pytest.raises(ValueError, match="at least 2"):
        rf.represent_clip(c[:1])
    with pytest.raises(ValueError, match="at least 2"):
        rf.represent_clip(c[:0])
    with pytest.raises(ValueError, match="3 channels"):
        rf.represent_clip(np.stack([c] * 3, -1))
    s = rf.Stream(16, 12)
    with pytest.raises(ValueError, match="takes"):
        s.push(g)
    with pytest.raises(ValueError):
        rf.Stream(0, 12)
    with pytest.raises(ValueError):
        rf.Stream(16, 12, lam=-1.0)
    with pytest.raises(ValueError, match="shape"):
        rf.write_flo(tmp_path / "x.flo", np.zeros((2, 2, 3), np.float32))
    (tmp_path / "bad.flo").write_bytes(b"not a flo file at all")
    with pytest.raises(ValueError, match="PIEH"):
        rf.read_flo(tmp_path / "bad.flo")
    with pytest.raises(FileNotFoundError):
        rf.read_flo(tmp_path / "missing.flo")
    with pytest.raises(ValueError, match="npy"):
        rf.convert(tmp_path, tmp_path / "out", npy="v_x")
    with pytest.raises(ValueError, match="rep=False"):
        rf.convert(tmp_path, tmp_path / "out", rep=False)
    assert not (tmp_path / "out").exists()


def test_flo_round_trip_and_cli_flo(cli, tmp_path):
    from conftest import run_cli

    flow = np.random.default_rng(3).normal(size=(5, 7, 2))
    rf.write_flo(tmp_path / "a.flo", flow)
    back = rf.read_flo(tmp_path / "a.flo")
    assert back.dtype == np.float32 and back.shape == (5, 7, 2)
    assert np.array_equal(back, flow.astype(np.float32))
    rf.write_flo(tmp_path / "b.flo", flow.astype(np.float32))
    assert (tmp_path / "b.flo").read_bytes() == (tmp_path / "a.flo").read_bytes()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []
    # The CLI's --flo of v_R is fields()["v_R"].
    frames = tmp_path / "frames"
    frames.mkdir()
    f0, f1 = moving_frame(30, 20, 0), moving_frame(30, 20, 1)
    write_pgm(frames / "a.pgm", f0)
    write_pgm(frames / "b.pgm", f1)
    run_cli(cli, "run", frames, "--out", tmp_path / "out", "--flo")
    assert np.array_equal(rf.read_flo(tmp_path / "out" / "v_R" / "a.flo"), rf.fields(f0, f1)["v_R"])


def test_a_stream_too_large_for_the_engine_is_refused_when_made():
    for w, h in [(2**40, 2**40), (70000, 1), (1, 70000), (8192, 8193)]:
        with pytest.raises(ValueError, match="Stream") as refused:
            rf.Stream(w, h)
        # No command-line flag in a Python message.
        assert "--" not in str(refused.value), refused.value


def test_the_pixel_limit_is_set_and_named_as_python_sets_it(tmp_path):
    write_pgm(tmp_path / "a.pgm", moving_frame(30, 20, 0))
    write_pgm(tmp_path / "b.pgm", moving_frame(30, 20, 1))
    default = rf.max_pixels()
    assert default == 8192 * 8192
    try:
        rf.set_max_pixels(599)
        assert rf.max_pixels() == 599
        for call in (lambda: list(rf.read_frames(tmp_path)), lambda: rf.Stream(30, 20)):
            with pytest.raises(ValueError, match="exceeds the limit of 599 pixels") as refused:
                call()
            assert str(refused.value).startswith("set_max_pixels: "), refused.value
            assert "--" not in str(refused.value), refused.value
        rf.set_max_pixels(600)
        assert len(list(rf.read_frames(tmp_path))) == 2
        for bad in (0, -1):
            with pytest.raises(ValueError, match=f"^set_max_pixels: {bad} pixels; the limit is at least 1"):
                rf.set_max_pixels(bad)
        assert rf.max_pixels() == 600
    finally:
        rf.set_max_pixels(default)


def test_a_meta_tensor_is_the_modules_type_error():
    import torch

    meta = torch.empty(8, 8, dtype=torch.uint8, device="meta")
    cpu = torch.zeros(8, 8, dtype=torch.uint8)
    for call in (lambda: rf.represent(meta, cpu), lambda: rf.represent(cpu, meta), lambda: rf.Stream(8, 8).push(meta)):
        with pytest.raises(TypeError, match="not in host memory"):
            call()

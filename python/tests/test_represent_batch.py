"""reynoldsflow.torch.represent_batch on CPU torch against the Rust core:
the RGB bytes byte for byte and the float32 fields bit for bit, on the
golden pairs, on generated pairs of every kind and size, at both
parameter sets, both scalings and the three variants; its checks, chunks,
strides and the transform's device=."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

import reynoldsflow as rf
from reynoldsflow import _torch_batch
from reynoldsflow.torch import ReynoldsFlow, represent_batch
from conftest import clip, moving_frame, read_gray, read_png

SMALL = {"intensity_scale": 1 / 1024, "lam": 1e-6}


@pytest.fixture(autouse=True)
def one_torch_thread():
    """The tensors here are small: one thread computes them faster than
    two, which wait on each other (and, on a busy machine, much longer)."""
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)
PARAMS = [{}, SMALL]
# Every scaling with every variant would repeat the same tail: each
# variant with each scaling is enough to tell them apart.
IMAGES = [
    {"scale": "minmax", "variant": "dc"},
    {"scale": (8, 32), "variant": "dc"},
    {"scale": "minmax", "variant": "dc0"},
    {"scale": "fixed:0.5,2", "variant": "cd"},
    {"scale": (8, 32), "variant": "dc0"},
    {"scale": "minmax", "variant": "cd"},
]
# (H, W): one pixel, one row, one column, odd and even sizes.
SIZES = [(1, 1), (1, 2), (1, 9), (1, 40), (2, 1), (9, 1), (33, 1), (2, 2), (3, 5),
         (7, 13), (16, 16), (17, 11), (24, 31), (5, 64)]
KINDS = ["random", "nudge", "checker", "steps", "flat", "ramps", "saturated", "texture"]


def generated_pair(kind: str, h: int, w: int, rng: np.random.Generator):
    """One (prev, next) uint8 pair of a kind, at (h, w)."""
    y, x = np.mgrid[0:h, 0:w]
    if kind == "random":
        return rng.integers(0, 256, (2, h, w), dtype=np.uint8)
    if kind == "nudge":  # a frame and its copy with a few small changes
        f0 = rng.integers(0, 256, (h, w))
        f1 = f0 + rng.integers(-2, 3, (h, w)) * (rng.random((h, w)) < 0.3)
        return np.clip(f0, 0, 255).astype(np.uint8), np.clip(f1, 0, 255).astype(np.uint8)
    if kind == "checker":  # 0/255 (or two levels) squares of 1-3 px, moved or inverted
        k = int(rng.integers(1, 4))
        lo, hi = (0, 255) if rng.random() < 0.5 else sorted(rng.integers(0, 256, 2))
        board = lambda dx: np.where(((x + dx) // k + y // k) % 2 == 0, lo, hi)
        f1 = board(1) if rng.random() < 0.5 else lo + hi - board(0)
        return board(0).astype(np.uint8), f1.astype(np.uint8)
    if kind == "steps":  # an edge across, moved by a pixel
        axis, at = (x, int(rng.integers(0, w + 1))) if rng.random() < 0.5 else (y, int(rng.integers(0, h + 1)))
        lo, hi = rng.integers(0, 256, 2)
        return np.where(axis < at, lo, hi).astype(np.uint8), np.where(axis < at + 1, lo, hi).astype(np.uint8)
    if kind == "flat":  # a constant frame, the same or brighter
        v = int(rng.integers(0, 256))
        return np.full((h, w), v, np.uint8), np.full((h, w), min(255, v + int(rng.integers(0, 3))), np.uint8)
    if kind == "ramps":  # a linear gradient, shifted
        gx, gy, c = rng.uniform(-9, 9), rng.uniform(-9, 9), rng.uniform(0, 255)
        ramp = lambda s: np.clip(c + gx * (x - s) + gy * y, 0, 255).astype(np.uint8)
        return ramp(0), ramp(1)
    if kind == "saturated":  # only 0 and 255
        return (rng.integers(0, 2, (2, h, w)) * 255).astype(np.uint8)
    t = int(rng.integers(0, 5))
    return moving_frame(w, h, t, seed=int(rng.integers(1 << 30))), moving_frame(w, h, t + 1)


def generated_batches(pairs_per_size: int, seed: int = 49):
    """Per size, a (B, H, W) batch of prev and of next with every kind."""
    rng = np.random.default_rng(seed)
    for h, w in SIZES:
        pairs = [generated_pair(KINDS[i % len(KINDS)], h, w, rng) for i in range(pairs_per_size)]
        yield np.stack([p for p, _ in pairs]), np.stack([n for _, n in pairs])


def bits(a) -> np.ndarray:
    """float32 values as their bit patterns (NaN, -0.0 and all told apart)."""
    return np.asarray(a, dtype=np.float32).view(np.int32)


def core_fields(f0, f1, params) -> dict:
    """The core's v_c and v_d as (2, H, W) float32."""
    got = rf.fields(f0, f1, **params)
    return {k: np.moveaxis(got[k], -1, 0) for k in ("v_c", "v_d")}


def test_golden_pairs_are_the_golden_bytes_and_fields(repo):
    golden = repo / "tests" / "golden"
    cases = sorted(p.name for p in golden.iterdir() if p.is_dir())
    assert len(cases) >= 10
    for case in cases:
        v = repo / "tests" / "vectors" / case
        f0, f1 = read_gray(v / "f0.pgm"), read_gray(v / "f1.pgm")
        t0, t1 = torch.from_numpy(f0.copy())[None], torch.from_numpy(f1.copy())[None]
        h, w = f0.shape
        for scale, name in [("minmax", "rep_minmax.png"), ((8, 32), "rep_fixed.png")]:
            rgb, fields = represent_batch(t0, t1, scale=scale, fields=True)
            want = np.moveaxis(read_png(golden / case / name), -1, 0)
            assert np.array_equal(rgb[0].numpy(), want), (case, name)
        # fields.bin: six float32 planes, v_c x, y, v_d x, y, |v_c|, |v_d|.
        planes = np.frombuffer((golden / case / "fields.bin").read_bytes(), "<f4").reshape(6, h, w)
        got = np.concatenate([fields["v_c"][0], fields["v_d"][0], fields["m_c"], fields["m_d"]])
        assert np.array_equal(bits(got), bits(planes)), case


@pytest.mark.parametrize("params", PARAMS, ids=["default", "s1024"])
def test_generated_pairs_equal_the_core(params):
    """At least 1000 pairs (SIZES × 72), batched by size: every image of
    IMAGES and the fields equal the core's."""
    pairs = 0
    for f0, f1 in generated_batches(72):
        t0, t1 = torch.from_numpy(f0), torch.from_numpy(f1)
        fields = None
        for image in IMAGES:
            got = represent_batch(t0, t1, fields=fields is None, **params, **image)
            if fields is None:
                got, fields = got
            for i in range(len(f0)):
                want = rf.represent(f0[i], f1[i], layout="chw", **params, **image)
                assert np.array_equal(got[i].numpy(), want), (f0.shape, i, image)
        for i in range(len(f0)):
            want = core_fields(f0[i], f1[i], params)
            for k in want:
                assert np.array_equal(bits(fields[k][i]), bits(want[k])), (f0.shape, i, k)
        pairs += len(f0)
    assert pairs >= 1000


@pytest.mark.parametrize("params", PARAMS, ids=["default", "s1024"])
def test_640x480_equals_the_core(params):
    rng = np.random.default_rng(640)
    f0 = np.stack([moving_frame(640, 480, 0), rng.integers(0, 256, (480, 640), dtype=np.uint8)])
    f1 = np.stack([moving_frame(640, 480, 1), np.roll(f0[1], 1, axis=1)])
    t0, t1 = torch.from_numpy(f0), torch.from_numpy(f1)
    for image in [{"scale": "minmax"}, {"scale": (8, 32), "variant": "cd"}]:
        got, fields = represent_batch(t0, t1, fields=True, **params, **image)
        for i in range(2):
            assert np.array_equal(got[i].numpy(), rf.represent(f0[i], f1[i], layout="chw", **params, **image))
    for i in range(2):
        want = core_fields(f0[i], f1[i], params)
        for k in want:
            assert np.array_equal(bits(fields[k][i]), bits(want[k])), (i, k)


def strided_views(frames: np.ndarray) -> dict:
    """(B, H, W) frames as contiguous, strided, transposed, flipped-back and
    (B, 1, H, W) tensors, the same pixels."""
    b, h, w = frames.shape
    contiguous = torch.from_numpy(frames.copy())
    big = torch.zeros((b, 2 * h, 3 * w), dtype=torch.uint8)
    big[:, ::2, ::3] = contiguous
    views = {
        "contiguous": contiguous,
        "strided": big[:, ::2, ::3],
        "transposed": contiguous.transpose(1, 2).contiguous().transpose(1, 2),
        "channel": contiguous.unsqueeze(1),
        "every_other_pair": torch.stack([contiguous, contiguous], 1).flatten(0, 1)[::2],
        "flipped": torch.flip(torch.flip(contiguous, [2]), [2])[:, :, :],
    }
    assert not views["strided"].is_contiguous() and not views["transposed"].is_contiguous()
    return views


def test_any_strides_give_the_same_bytes():
    frames = clip(5, 29, 19)
    want = np.stack([rf.represent(frames[i], frames[i + 1], layout="chw") for i in range(4)])
    views = strided_views(frames)
    for name, t in views.items():
        assert np.array_equal(represent_batch(t[:-1], t[1:]).numpy(), want), name
    # prev strided, next contiguous.
    assert np.array_equal(represent_batch(views["strided"][:-1], views["contiguous"][1:]).numpy(), want)


def test_batch_of_one_and_chunks_give_the_same_bytes():
    frames = clip(9, 21, 14)
    t = torch.from_numpy(frames)
    whole, fields = represent_batch(t[:-1], t[1:], fields=True)
    one_pair = _torch_batch.pair_bytes(14, 21)
    assert _torch_batch.chunk_pairs(14, 21, 2 * one_pair - 1) == 1
    chunked, chunk_fields = represent_batch(t[:-1], t[1:], fields=True, memory_budget=one_pair)
    assert torch.equal(whole, chunked)
    for k in fields:
        assert torch.equal(fields[k].view(torch.int32), chunk_fields[k].view(torch.int32)), k
    for i in range(8):
        one = represent_batch(t[i:i + 1], t[i + 1:i + 2])
        assert torch.equal(one[0], whole[i])
        assert np.array_equal(one[0].numpy(), rf.represent(frames[i], frames[i + 1], layout="chw"))
    empty, empty_fields = represent_batch(t[:0], t[:0], fields=True)
    assert empty.shape == (0, 3, 14, 21) and empty_fields["v_c"].shape == (0, 2, 14, 21)


def test_chunk_size_follows_the_budget():
    per_pair = (480 + 14) * (640 + 14) * 256
    assert _torch_batch.chunk_pairs(480, 640, 10 * per_pair) == 10
    assert _torch_batch.chunk_pairs(480, 640, 10 * per_pair - 1) == 9
    assert _torch_batch.chunk_pairs(480, 640, 1 << 30) == (1 << 30) // per_pair


def test_bad_input_names_the_argument():
    good = torch.zeros((2, 5, 6), dtype=torch.uint8)
    cases = [
        ((good.float(), good), TypeError, "prev"),
        ((good, good.to(torch.int16)), TypeError, "next"),
        ((good.numpy(), good), TypeError, "prev"),
        ((good[0], good[0]), TypeError, "prev"),
        ((good[None, None], good[None, None]), TypeError, "prev"),
        ((good[None], good[None]), ValueError, "prev"),
        ((good, torch.zeros((2, 2, 5, 6), dtype=torch.uint8)), ValueError, "next"),
        ((good, good[:, :4]), ValueError, "next"),
        ((good, good[:1]), ValueError, "next"),
        ((good[:, :0], good[:, :0]), ValueError, "prev"),
        ((good[:, :, :0], good[:, :, :0]), ValueError, "prev"),
        ((good, torch.zeros((2, 5, 6), dtype=torch.uint8, device="meta")), ValueError, "next"),
    ]
    for args, error, name in cases:
        with pytest.raises(error, match=name):
            represent_batch(*args)
    settings = [
        ({"variant": "hsv"}, ValueError, "hsv"),
        ({"engine": "float"}, ValueError, "engine"),
        ({"lam": -1.0}, ValueError, "lam"),
        ({"intensity_scale": 2.0}, ValueError, "intensity_scale"),
        ({"intensity_scale": 1e-12}, ValueError, "intensity_scale"),
        ({"scale": "fixed:1"}, ValueError, "scale"),
        ({"scale": (70000, 1)}, ValueError, "scale"),
        ({"layout": "rgb"}, ValueError, "layout"),
        ({"memory_budget": 0}, ValueError, "memory_budget"),
    ]
    for kwargs, error, name in settings:
        with pytest.raises(error, match=name):
            represent_batch(good, good, **kwargs)


def test_settings_take_every_form_the_core_takes():
    """intensity_scale as a float, string, pair and Fraction; lam and gains
    rounded as the core rounds them."""
    from fractions import Fraction

    f0, f1 = moving_frame(23, 17, 0), moving_frame(23, 17, 1)
    t0, t1 = torch.from_numpy(f0)[None], torch.from_numpy(f1)[None]
    for kwargs in [
        {"intensity_scale": "1/1024", "lam": 1e-6},
        {"intensity_scale": (2, 510)},
        {"intensity_scale": Fraction(3, 7), "lam": 0.01},
        {"intensity_scale": "0.5"},
        {"intensity_scale": 0.3},
        {"intensity_scale": 1.0, "lam": 3.3e-5},
        {"intensity_scale": 6144 / 2**32, "lam": 2.0**-32},
        {"scale": (1000.123, 0.00001)},
        {"scale": "fixed: 7.5 , 65535.99999"},
        {"tile": (4, 3)},
    ]:
        want = rf.represent(f0, f1, layout="chw", **kwargs)
        assert np.array_equal(represent_batch(t0, t1, **kwargs)[0].numpy(), want), kwargs


def test_transform_on_a_device_gives_the_core_bytes():
    frames = torch.from_numpy(clip(6, 30, 20))
    for options in [{}, {"keep_count": True, "variant": "cd"}, {"scale": (8, 32), "lam": 1e-3}]:
        on_device = ReynoldsFlow(device="cpu", **options)(frames.unsqueeze(1))
        assert torch.equal(on_device, ReynoldsFlow(**options)(frames)), options
    with pytest.raises(ValueError, match="step"):
        ReynoldsFlow(device="cpu", step=2)
    with pytest.raises(ValueError, match="hsv"):
        ReynoldsFlow(device="cpu", variant="hsv")
    with pytest.raises(ValueError, match="2"):
        ReynoldsFlow(device="cpu")(frames[:1])


GPU_CHECK = Path(__file__).resolve().parents[1] / "bench" / "gpu_check.py"


def run_gpu_check(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, CUDA_VISIBLE_DEVICES="", OMP_NUM_THREADS="1")
    return subprocess.run([sys.executable, str(GPU_CHECK), *args], capture_output=True, text=True,
                          env=env, timeout=300)


def test_gpu_check_refuses_without_cuda():
    res = run_gpu_check()
    assert res.returncode == 2, res.stdout + res.stderr
    assert "no CUDA device" in res.stderr and res.stdout == ""


def test_gpu_check_rehearsed_on_the_cpu_finds_every_value_equal():
    """The script's own comparisons, run on the CPU (--rehearse), so its
    CUDA path's code is exercised where there is no GPU."""
    res = run_gpu_check("--rehearse")
    assert res.returncode == 0, res.stdout + res.stderr
    for step in ["golden pairs: 11, equal", "generated pairs: 70, equal", "640x480 pairs: 2, equal",
                 "divisions: 1000000, equal",
                 "sqrt patterns: 4194304, equal", "every value equal"]:
        assert step in res.stdout, res.stdout


def test_the_square_root_is_correctly_rounded():
    """_torch_core._sqrt against NumPy's root (the CPU's sqrt instruction,
    correctly rounded) on random float32 patterns of every exponent and on
    the squares and their neighbours; torch.sqrt on the CPU is not (MKL),
    which is why the module corrects it (every pattern:
    ``gpu_check.py --cpu-sqrt``)."""
    from reynoldsflow._torch_core import _sqrt

    rng = np.random.default_rng(5)
    squares = (np.arange(1, 1 << 12, dtype=np.float64) ** 2).astype(np.float32).view(np.int32)
    patterns = np.concatenate([
        rng.integers(0, 0x7F800000, 1 << 22, dtype=np.int32),
        squares - 1, squares, squares + 1,
        np.array([0, 1, 2, 0x007FFFFF, 0x00800000, 0x7F7FFFFF], np.int32),
    ])
    x = patterns.view(np.float32)
    want = np.sqrt(x).view(np.int32)
    assert np.array_equal(_sqrt(torch.from_numpy(x)).view(torch.int32).numpy(), want)

"""Refusals at every entry point: one frame-size limit (set_max_pixels)
for every function, one pair's memory against represent_batch's
memory_budget, the same settings with the same meaning in represent and
represent_batch, Stream's sizes named, the lambda range the refusal states,
and the GPU path's guardrails (torch.compile, ROCm) as far as a CPU shows
them."""

import re
import subprocess
import sys

import numpy as np
import pytest
import torch

import reynoldsflow as rf
from reynoldsflow import _torch_batch, _torch_core
from reynoldsflow.torch import represent_batch
from conftest import moving_frame


@pytest.fixture
def max_pixels_100():
    before = rf.max_pixels()
    rf.set_max_pixels(100)
    yield
    rf.set_max_pixels(before)


def refusal(size: str, pixels: int, subject: str) -> str:
    """The message every entry point gives for a frame over the limit of 100."""
    return (f"set_max_pixels: {subject}: frame size {size} ({pixels} pixels) exceeds the limit of "
            "100 pixels; raise the limit if the input really is that large")


def test_every_entry_point_applies_set_max_pixels(max_pixels_100):
    big, small = np.zeros((10, 11), np.uint8), np.zeros((10, 10), np.uint8)
    calls = {
        "prev": [lambda: rf.represent(big, big), lambda: rf.fields(big, big),
                 lambda: rf.motion_score(big, big)],
        "frames": [lambda: rf.represent_clip(np.stack([big, big]))],
        "Stream": [lambda: rf.Stream(11, 10)],
    }
    for subject, functions in calls.items():
        for call in functions:
            with pytest.raises(ValueError) as e:
                call()
            assert str(e.value) == refusal("11x10", 110, subject)
    # At the limit, every one computes.
    assert rf.represent(small, small).shape == (10, 10, 3)
    assert rf.represent_clip(np.stack([small, small])).shape == (1, 10, 10, 3)
    # A resize to more pixels than the limit is refused too.
    with pytest.raises(ValueError) as e:
        rf.represent_clip(np.stack([small, small]), resize=(20, 10))
    assert str(e.value) == refusal("20x10", 200, "resize")


HUGE_CHILD = """
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
import numpy as np, reynoldsflow as rf
side = 65535
x = np.broadcast_to(np.zeros(1, np.uint8), (side, side))
for call in (lambda: rf.represent(x, x), lambda: rf.represent_clip(np.broadcast_to(x, (2, side, side)))):
    try:
        call()
        print("computed")
    except (MemoryError, ValueError) as e:
        print(type(e).__name__, str(e).split(';')[0])
"""


def test_a_65535_square_frame_is_refused_not_aborted():
    """Frames with no memory behind them (broadcast), in a child whose
    address space is capped at 2 GiB: a refusal, never SIGABRT."""
    res = subprocess.run([sys.executable, "-c", HUGE_CHILD], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, f"exit {res.returncode}: {res.stdout} {res.stderr[-2000:]}"
    lines = res.stdout.splitlines()
    assert len(lines) == 2 and all(line.startswith("ValueError set_max_pixels") for line in lines), lines


def test_batch_refuses_a_pair_over_the_memory_budget():
    """Refused up front, naming the argument, the budget and the need
    (the chunks' own accounting); a budget of exactly one pair's need is
    taken."""
    f = torch.from_numpy(moving_frame(40, 30, 0))[None]
    need = _torch_batch.pair_bytes(30, 40)
    assert need == (30 + 2 * _torch_core.HALO) * (40 + 2 * _torch_core.HALO) * _torch_core.WORKING_BYTES_PER_PIXEL
    with pytest.raises(ValueError, match=rf"^represent_batch: memory_budget = {need - 1} bytes .*{need} bytes"):
        represent_batch(f, f, memory_budget=need - 1)
    assert represent_batch(f, f, memory_budget=need).shape == (1, 3, 30, 40)


def test_batch_refuses_an_8192_square_pair_at_the_default_budget():
    """The largest frame the readers take by default needs ~17 GB a pair:
    refused before any allocation (frames with no memory behind them)."""
    x = torch.zeros(1, 1, 1, dtype=torch.uint8).expand(1, 8192, 8192)
    with pytest.raises(ValueError, match=r"memory_budget = 1073741824 bytes"):
        represent_batch(x, x)


@pytest.mark.parametrize("kw", [{"lam": None}, {"engine": None}, {"variant": None}, {"scale": None},
                                {"intensity_scale": None}, dict(rf.DEFAULTS), {"layout": "chw"},
                                {"layout": "hwc", "variant": "cd", "lam": 1e-3},
                                {"layout": None, "tile": None, "hsv_max": None}])
def test_batch_takes_the_settings_represent_takes(kw):
    f0, f1 = moving_frame(23, 17, 0), moving_frame(23, 17, 1)
    t0, t1 = torch.from_numpy(f0)[None], torch.from_numpy(f1)[None]
    got = represent_batch(t0, t1, **kw)
    # Channels first unless layout says otherwise (represent's default is hwc).
    want = rf.represent(f0, f1, **{"layout": "chw", **{k: v for k, v in kw.items() if v is not None}})
    assert got.shape == (1, *want.shape) and np.array_equal(got[0].numpy(), want), kw
    rgb, fields = represent_batch(t0, t1, fields=True, **kw)
    assert torch.equal(rgb, got) and fields["v_c"].shape == (1, 2, 17, 23)


def test_batch_settings_errors_name_the_function_and_keyword():
    t = torch.zeros((1, 4, 4), dtype=torch.uint8)
    for kw, error, pattern in [({"lam": "x"}, TypeError, r"represent_batch\(\): lam"),
                               ({"engine": 3}, TypeError, r"represent_batch\(\): engine"),
                               ({"colour": 1}, TypeError, r"represent_batch\(\) got an unexpected keyword argument 'colour'"),
                               ({"layout": "rgb"}, ValueError, "layout")]:
        with pytest.raises(error, match=pattern):
            represent_batch(t, t, **kw)


@pytest.mark.parametrize("args, error, name", [
    ((-1, 4), ValueError, "width"), ((4, -1), ValueError, "height"),
    ((4.5, 4), TypeError, "width"), ((4, 4.5), TypeError, "height"),
    (("4", 4), TypeError, "width"), ((0, 4), ValueError, "width"),
    ((2**70, 4), ValueError, "width"),
])
def test_stream_sizes_are_named(args, error, name):
    with pytest.raises(error, match=rf"^Stream: {name}"):
        rf.Stream(*args)


def test_stream_takes_integer_like_sizes():
    s = rf.Stream(np.int64(5), True + 3)
    assert (s.width, s.height) == (5, 4)


@pytest.mark.parametrize("intensity_scale", [1, "1/255", "6144/4294967295"])
def test_the_lambda_range_stated_is_the_range_taken(intensity_scale):
    """At both ends, the stated bound is taken and one unit of its last
    digit beyond it is refused."""
    f = np.zeros((4, 4), np.uint8)
    with pytest.raises(ValueError) as e:
        rf.represent(f, f, intensity_scale=intensity_scale, lam=1e9)
    low, high = re.search(r"\(about (\S+) to (\S+)\)", str(e.value)).groups()

    def step(number: str, up: bool) -> float:
        mantissa, exponent = number.split("e")
        digits = len(mantissa.split(".")[1])
        units = int(mantissa.replace(".", "")) + (1 if up else -1)
        return units * 10.0 ** (int(exponent) - digits)

    for lam in (float(low), float(high)):
        rf.represent(f, f, intensity_scale=intensity_scale, lam=lam)
    for lam in (step(low, False), step(high, True)):
        with pytest.raises(ValueError, match="^lam: "):
            rf.represent(f, f, intensity_scale=intensity_scale, lam=lam)
    if intensity_scale == 1:  # the value the range once covered but the core refuses
        with pytest.raises(ValueError, match="^lam: "):
            rf.represent(f, f, intensity_scale=1, lam=5e-6)
        assert float(low) > 5e-6


def test_batch_is_not_traced_by_torch_compile():
    """A caller's torch.compile runs represent_batch eagerly (its bytes are
    those of one eager kernel per operation): none of its operations
    reaches a compiled graph."""
    graphs = []

    def backend(gm, example_inputs):
        graphs.append(gm)
        return gm.forward

    def caller(a, b):
        return represent_batch(a, b).to(torch.int16) + 1

    torch._dynamo.reset()
    f0, f1 = moving_frame(12, 9, 0), moving_frame(12, 9, 1)
    t0, t1 = torch.from_numpy(f0)[None], torch.from_numpy(f1)[None]
    got = torch.compile(caller, backend=backend)(t0, t1)
    torch._dynamo.reset()
    assert np.array_equal(got[0].numpy(), rf.represent(f0, f1, layout="chw").astype(np.int16) + 1)
    traced = [str(node.target) for gm in graphs for node in gm.graph.nodes if node.op == "call_function"]
    assert not any(name in t for t in traced for name in ("div", "amin", "amax", "where")), traced


def test_rocm_builds_are_refused_off_the_cpu(monkeypatch):
    """A ROCm build reports its GPU as "cuda"; nobody has checked its bytes:
    off the CPU, represent_batch refuses it (the CPU path stays)."""
    monkeypatch.setattr(torch.version, "hip", "6.2.0", raising=False)
    meta = torch.zeros((1, 8, 8), dtype=torch.uint8, device="meta")
    with pytest.raises(ValueError, match=r"represent_batch: prev: on meta.*ROCm.*6\.2\.0"):
        represent_batch(meta, meta)
    cpu = torch.zeros((1, 8, 8), dtype=torch.uint8)
    assert represent_batch(cpu, cpu).shape == (1, 3, 8, 8)

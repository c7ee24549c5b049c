"""out=: represent_clip and Stream.push write into a given array, the same
bytes as the arrays they allocate, and refuse one they cannot fill."""

import numpy as np
import pytest
import torch

import reynoldsflow as rf
from conftest import clip

CASES = [
    {},
    {"layout": "chw"},
    {"keep_count": True, "layout": "chw"},
    {"variant": "cd", "scale": (8, 32)},
    {"variant": "hsv", "layout": "chw"},
    {"engine": "float", "variant": "dc0", "layout": "chw"},
    {"step": 2, "resize": (24, 16), "layout": "chw"},
]


@pytest.mark.parametrize("options", CASES)
def test_represent_clip_into_out_equals_the_allocated_result(options):
    c = clip(7)
    expected = rf.represent_clip(c, **options)
    for out in (np.full(expected.shape, 77, np.uint8), torch.full(expected.shape, 77, dtype=torch.uint8)):
        got = rf.represent_clip(c, out=out, **options)
        assert got is out
        assert np.array_equal(np.asarray(out), expected)
    out = np.empty(expected.shape, np.uint8)
    reps, scores = rf.represent_clip(c, out=out, return_scores=True, **options)
    assert reps is out and np.array_equal(out, expected)
    assert np.array_equal(scores, rf.represent_clip(c, return_scores=True, **options)[1])


@pytest.mark.parametrize("layout", ["hwc", "chw"])
def test_stream_push_into_out_equals_the_allocated_result(layout):
    c = clip(4)
    s, allocating = rf.Stream(48, 32, layout=layout), rf.Stream(48, 32, layout=layout)
    shape = (32, 48, 3) if layout == "hwc" else (3, 32, 48)
    out = torch.full(shape, 9, dtype=torch.uint8)
    # The first frame gives no image: None, and out untouched.
    assert s.push(c[0], out=out) is None and allocating.push(c[0]) is None
    assert bool((out == 9).all())
    for frame in c[1:]:
        assert s.push(frame, out=out) is out
        assert np.array_equal(out.numpy(), allocating.push(frame))


def test_a_wrong_out_is_refused_with_what_it_needs():
    c = clip(3)
    good = (2, 32, 48, 3)
    bad = [
        (np.empty(good, np.int16), TypeError, r"out: dtype int16 is not uint8; give a uint8 array of shape \(2, 32, 48, 3\)"),
        (np.empty((2, 32, 48, 4), np.uint8), ValueError, r"out: shape \(2, 32, 48, 4\); the result has shape \(2, 32, 48, 3\)"),
        (np.empty((3, 32, 48, 3), np.uint8), ValueError, r"the result has shape \(2, 32, 48, 3\)"),
        (np.empty((2, 32, 96, 3), np.uint8)[:, :, ::2], ValueError, "out: not C-contiguous"),
        (torch.empty((2, 3, 32, 48), dtype=torch.uint8).permute(0, 2, 3, 1), ValueError, "out: not C-contiguous"),
        ([[0]], TypeError, "out: expected a numpy.ndarray"),
    ]
    readonly = np.empty(good, np.uint8)
    readonly.flags.writeable = False
    bad.append((readonly, ValueError, "out: .*not writeable; give a writable array"))
    for out, error, message in bad:
        with pytest.raises(error, match=message):
            rf.represent_clip(c, out=out)
    s = rf.Stream(48, 32)
    for out, error, message in [(np.empty((32, 48, 3), np.float32), TypeError, "not uint8"),
                                (np.empty((3, 32, 48), np.uint8), ValueError, r"the result has shape \(32, 48, 3\)")]:
        # Refused at the first frame already, and the stream stays where it was.
        with pytest.raises(error, match=message):
            s.push(c[0], out=out)
    assert s.push(c[0]) is None
    with pytest.raises(ValueError, match="not C-contiguous"):
        s.push(c[1], out=np.empty((32, 96, 3), np.uint8)[:, ::2])
    assert np.array_equal(s.push(c[1]), rf.represent(c[0], c[1]))

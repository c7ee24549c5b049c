"""The package's defaults are the library's: every function falls back on
the Rust host's ``Settings::default()`` (``reynoldsflow.DEFAULTS``), and
``settings()`` shows what a call's keywords give, checked as every function
checks them."""

import numpy as np
import pytest

import reynoldsflow as rf


def test_no_keyword_gives_the_library_defaults():
    assert rf.settings() == rf.DEFAULTS
    assert rf.DEFAULTS["engine"] == "fixed"
    assert rf.DEFAULTS["variant"] == "dc"


def test_keywords_change_only_what_they_name():
    s = rf.settings(lam=1e-6, scale=(8, 32), variant="cd", intensity_scale="1/1024")
    assert s["lam"] == 1e-6
    assert s["scale"] == "fixed:8,32"
    assert s["variant"] == "cd"
    assert s["intensity_scale"] == "1/1024"
    unchanged = {k: v for k, v in s.items() if k not in ("lam", "scale", "variant", "intensity_scale")}
    assert unchanged == {k: rf.DEFAULTS[k] for k in unchanged}


def test_the_defaults_compute_what_no_keyword_computes():
    rng = np.random.default_rng(7)
    a = rng.integers(0, 256, (24, 31), dtype=np.uint8)
    b = np.roll(a, 1, axis=1)
    d = dict(rf.DEFAULTS)
    assert np.array_equal(rf.represent(a, b), rf.represent(a, b, **d))


@pytest.mark.parametrize(
    "kw, message",
    [
        ({"lam": -1.0}, "lam"),
        ({"engine": "gpu"}, "engine"),
        ({"variant": "rgb"}, "variant"),
        ({"tile": (0, 4)}, "tile"),
    ],
)
def test_bad_values_name_the_keyword(kw, message):
    with pytest.raises(ValueError, match=message):
        rf.settings(**kw)


def test_a_host_setting_error_names_the_python_keyword_not_a_flag():
    a = np.zeros((8, 8), np.uint8)
    with pytest.raises(ValueError) as e:
        rf.represent(a, a, lam=1e9)
    assert str(e.value).startswith("lam: "), e.value
    assert "--" not in str(e.value)


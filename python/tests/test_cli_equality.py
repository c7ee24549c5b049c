"""represent and fields against `reynoldsflow pair` and the golden bytes."""

import numpy as np
import pytest

import reynoldsflow as rf
from conftest import moving_frame, read_gray, read_png, run_cli, write_pgm

ENGINES = ["fixed", "float"]
SCALES = [("minmax", "minmax"), ((8.0, 32.0), "fixed:8,32"), ("fixed:0.5,2", "fixed:0.5,2")]
CASES = ["translate_64x48", "rotate_64x48", "noise_33x17", "row_7x1", "pixel_1x1"]


def pair_outputs(cli, tmp_path, f0, f1, engine, scale_flag, extra=()):
    d = tmp_path / "in"
    d.mkdir(exist_ok=True)
    write_pgm(d / "f0.pgm", f0)
    write_pgm(d / "f1.pgm", f1)
    out = tmp_path / f"out-{engine}-{scale_flag}".replace(":", "_").replace(",", "_")
    run_cli(cli, "pair", d / "f0.pgm", d / "f1.pgm", "--out", out, "--engine", engine, "--scale", scale_flag, *extra)
    return out


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("scale,scale_flag", SCALES)
def test_represent_and_fields_equal_the_cli(cli, repo, tmp_path, engine, scale, scale_flag):
    pairs = [(moving_frame(70, 45, 0), moving_frame(70, 45, 1))]
    for case in CASES:
        d = repo / "tests" / "vectors" / case
        pairs.append((read_gray(d / "f0.pgm"), read_gray(d / "f1.pgm")))
    for i, (f0, f1) in enumerate(pairs):
        sub = tmp_path / str(i)
        sub.mkdir()
        out = pair_outputs(cli, sub, f0, f1, engine, scale_flag)
        rep = rf.represent(f0, f1, engine=engine, scale=scale)
        assert rep.dtype == np.uint8 and rep.shape == f0.shape + (3,)
        assert np.array_equal(rep, read_png(out / "rep.png")), (engine, scale_flag, i)
        fields = rf.fields(f0, f1, engine=engine)
        planes = {name: np.load(out / f"{name}.npy") for name in ["vcx", "vcy", "vdx", "vdy"]}
        for field, (x, y) in {"v_c": ("vcx", "vcy"), "v_d": ("vdx", "vdy")}.items():
            got = fields[field]
            assert got.dtype == np.float32 and got.shape == f0.shape + (2,)
            assert np.array_equal(got[..., 0], planes[x].astype(np.float32)), (field, i)
            assert np.array_equal(got[..., 1], planes[y].astype(np.float32)), (field, i)
        v_r = np.stack([planes["vcx"] + planes["vdx"], planes["vcy"] + planes["vdy"]], axis=-1)
        assert np.array_equal(fields["v_R"], v_r.astype(np.float32))


def test_represent_options_match_the_cli(cli, tmp_path):
    f0, f1 = moving_frame(60, 40, 2), moving_frame(60, 40, 3)
    out = pair_outputs(cli, tmp_path, f0, f1, "fixed", "minmax",
                       extra=("--intensity-scale", "1/128", "--lambda", "3e-4", "--tile", "16x8"))
    rep = rf.represent(f0, f1, intensity_scale=(1, 128), lam=3e-4, tile=(16, 8))
    assert np.array_equal(rep, read_png(out / "rep.png"))
    # The same intensity scale written every way gives the same bytes.
    for s in [1 / 128, "1/128", (2, 256)]:
        assert np.array_equal(rf.represent(f0, f1, intensity_scale=s, lam=3e-4), rep)
    from fractions import Fraction
    assert np.array_equal(rf.represent(f0, f1, intensity_scale=Fraction(1, 128), lam=3e-4), rep)
    # ... and the default is 1/255, a float included.
    assert np.array_equal(rf.represent(f0, f1), rf.represent(f0, f1, intensity_scale=1 / 255))
    assert not np.array_equal(rf.represent(f0, f1), rf.represent(f0, f1, intensity_scale=(1, 128)))


def test_variants_are_the_cli_run_images(cli, tmp_path):
    frames = tmp_path / "frames"
    frames.mkdir()
    f0, f1 = moving_frame(40, 30, 0), moving_frame(40, 30, 1)
    write_pgm(frames / "a.pgm", f0)
    write_pgm(frames / "b.pgm", f1)
    for variant in ["dc", "dc0", "cd", "hsv"]:
        out = tmp_path / variant
        run_cli(cli, "run", frames, "--out", out, "--variant", variant)
        assert np.array_equal(rf.represent(f0, f1, variant=variant), read_png(out / "a.png")), variant


@pytest.mark.parametrize("scaling,golden", [("minmax", "rep_minmax.png"), ((8, 32), "rep_fixed.png")])
def test_fixed_engine_equals_the_golden_bytes(repo, scaling, golden):
    cases = sorted(p.name for p in (repo / "tests" / "golden").iterdir() if p.is_dir())
    assert len(cases) >= 10
    for case in cases:
        v = repo / "tests" / "vectors" / case
        f0, f1 = read_gray(v / "f0.pgm"), read_gray(v / "f1.pgm")
        expected = read_png(repo / "tests" / "golden" / case / golden)
        assert np.array_equal(rf.represent(f0, f1, scale=scaling), expected), case

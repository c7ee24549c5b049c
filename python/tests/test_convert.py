"""convert and dataset_items: what `reynoldsflow dataset` does, item by item,
byte for byte (markers included); the Ray recipe likewise, on a local Ray."""

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

import reynoldsflow as rf
from conftest import clip, run_cli, tree, write_pgm, write_y4m

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def source_tree(root: Path) -> None:
    """Two Y4M videos (one nested), a frame folder, a broken video, a text file."""
    (root / "a" / "b").mkdir(parents=True)
    write_y4m(root / "a" / "b" / "clip.y4m", clip(5))
    write_y4m(root / "a" / "short.y4m", clip(3, 40, 24))
    seq = root / "seq1"
    seq.mkdir()
    for i, name in enumerate(["img2.pgm", "img10.pgm", "img1.pgm"]):
        write_pgm(seq / name, clip(3)[i])
    (root / "a" / "cut.y4m").write_bytes(b"YUV4MPEG2 W4 H4 C444p12\n")
    (root / "README").write_text("not a video")


def records(stdout: str) -> list:
    return [json.loads(line) for line in stdout.splitlines() if line.strip()]


def test_convert_makes_what_dataset_makes(cli, tmp_path):
    src, by_cli, by_py = tmp_path / "src", tmp_path / "cli", tmp_path / "py"
    source_tree(src)
    res = subprocess.run([str(cli), "dataset", str(src), str(by_cli), "--keep-count", "--npy=v_R", "--flo"],
                         capture_output=True, text=True)
    assert res.returncode == 1, res.stderr  # the broken video
    cli_records = {r["path"]: r for r in records(res.stdout)}
    items = rf.dataset_items(src)
    assert {s for s, _ in items} == set(cli_records)
    for s, rel in items:
        r = rf.convert(s, by_py / rel, keep_count=True, npy="v_R", flo=True)
        c = cli_records[s]
        assert (r["status"], r["frames"], r["outputs"]) == (c["status"], c["frames"], c["outputs"]), (r, c)
        assert r["output"] == str(by_py / rel)
        assert set(r) == {"path", "output", "status", "frames", "outputs", "seconds", "error"}
        if r["status"] == "failed":
            assert "12-bit" in r["error"] and "12-bit" in c["error"]
    assert tree(by_py) == tree(by_cli)
    assert len([p for p in tree(by_py) if p.endswith(".npy")]) == 5 + 3 + 3
    # Finished items are skipped on a rerun, by either.
    for s, rel in items:
        r = rf.convert(s, by_py / rel, keep_count=True, npy="v_R", flo=True)
        assert r["status"] in ("skipped", "failed")
        if r["status"] == "skipped":
            assert r["frames"] == cli_records[s]["frames"]
    res = subprocess.run([str(cli), "dataset", str(src), str(by_py), "--keep-count", "--npy=v_R", "--flo"],
                         capture_output=True, text=True)
    assert sorted(r["status"] for r in records(res.stdout)) == ["failed", "skipped", "skipped", "skipped"]
    # Other options redo the item.
    s, rel = items[0]
    assert rf.convert(s, by_py / rel)["status"] == "done"
    assert rf.convert(s, by_py / rel, force=True)["status"] == "done"


def test_dataset_items_refuse_what_dataset_refuses(tmp_path):
    # An item in another's side-output folder, or two items writing one
    # folder: the CLI refuses them, so the listing does too, naming them.
    src = tmp_path / "src"
    (src / "x").mkdir(parents=True)
    write_y4m(src / "x.y4m", clip(3))
    write_y4m(src / "x" / "hsv.y4m", clip(3))
    with pytest.raises(ValueError, match=r"hsv\.y4m: its output folder DST/x/hsv lies in hsv/"):
        rf.dataset_items(src)
    (src / "x" / "hsv.y4m").unlink()
    write_y4m(src / "x.mp4.y4m", clip(3))  # another name, another folder: taken
    assert [rel for _, rel in rf.dataset_items(src)] == ["x", "x.mp4"]


def test_dataset_items_follow_a_manifest(tmp_path):
    src = tmp_path / "src"
    source_tree(src)
    manifest = tmp_path / "todo.txt"
    manifest.write_text("# a comment\nseq1\n\na/short.y4m\nmissing.y4m\n")
    items = rf.dataset_items(src, files_from=manifest)
    assert [rel for _, rel in items] == ["a/short", "missing", "seq1"]
    r = rf.convert(items[1][0], tmp_path / "out" / "missing")
    assert r["status"] == "failed" and "missing.y4m" in r["error"]
    # Or the paths themselves: relative, absolute inside src, PathLike.
    listed = rf.dataset_items(src, files_from=["seq1", str(src / "a" / "short.y4m"), Path("missing.y4m")])
    assert listed == items
    for shard in range(3):
        assert (rf.dataset_items(src, files_from=["seq1", "a/short.y4m", "missing.y4m"], shard=(shard, 3))
                == rf.dataset_items(src, files_from=manifest, shard=(shard, 3)))
    with pytest.raises(ValueError, match=r"item 1: \.\./elsewhere.y4m: expected a path inside SRC"):
        rf.dataset_items(src, files_from=["seq1", "../elsewhere.y4m"])
    with pytest.raises(ValueError, match="not inside SRC"):
        rf.dataset_items(src, files_from=[str(tmp_path / "elsewhere.y4m")])
    with pytest.raises(TypeError, match="a manifest's path or a list of paths, not int"):
        rf.dataset_items(src, files_from=3)
    # A list needs a folder to be relative to; the message names the keyword.
    with pytest.raises(ValueError, match="^files_from: lists paths relative to the source, which must then be a folder"):
        rf.dataset_items(src / "a" / "short.y4m", files_from=["seq1"])


def test_ray_recipe_outputs_equal_the_cli_dataset(cli, tmp_path):
    import ray  # installed by scripts/test-python: its absence is a failure

    src = tmp_path / "src"
    source_tree(src)
    (src / "a" / "cut.y4m").unlink()
    write_y4m(src / "more.y4m", clip(7, 64, 40))
    by_cli, by_ray = tmp_path / "cli", tmp_path / "ray"
    run_cli(cli, "dataset", src, by_cli, "--keep-count")
    # Ray keeps its sockets and logs in a short temp dir, and its state out of $HOME.
    ray_tmp = tempfile.mkdtemp(prefix="rfray", dir="/tmp")
    env = dict(os.environ, RAY_TMPDIR=ray_tmp, HOME=str(tmp_path), RAY_USAGE_STATS_ENABLED="0")
    try:
        res = subprocess.run(
            [sys.executable, str(EXAMPLES / "ray_dataset.py"), str(src), str(by_ray), "--num-cpus", "2",
             "--keep-count", "--status", str(tmp_path / "status.jsonl")],
            capture_output=True, text=True, env=env, timeout=600,
        )
    finally:
        subprocess.run(["rm", "-rf", ray_tmp])
    assert res.returncode == 0, res.stderr[-3000:]
    assert "4 items: 4 done, 0 skipped, 0 failed" in res.stderr, res.stderr[-3000:]
    assert tree(by_ray) == tree(by_cli)
    assert len(tree(by_cli)) == 4 + 5 + 3 + 3 + 7
    lines = records((tmp_path / "status.jsonl").read_text())
    assert sorted(r["status"] for r in lines) == ["done"] * 4
    assert ray.__version__


@pytest.mark.parametrize(
    "keywords, flags",
    [
        ({"png_compression": "best"}, ["--png-compression", "best"]),
        ({"image_format": "jpg", "jpeg_subsampling": "420"}, ["--image-format", "jpg", "--jpeg-subsampling", "420"]),
    ],
)
def test_convert_encodes_as_the_cli_does(cli, tmp_path, keywords, flags):
    src = tmp_path / "clip.y4m"
    write_y4m(src, clip(5, 40, 24))
    res = subprocess.run([str(cli), "run", str(src), "--out", str(tmp_path / "cli"), *flags],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert rf.convert(src, tmp_path / "py", **keywords)["status"] == "done"
    images = sorted(p.name for p in (tmp_path / "cli").iterdir() if not p.name.startswith("."))
    assert images and images == sorted(p.name for p in (tmp_path / "py").iterdir() if not p.name.startswith("."))
    for name in images:
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name


def test_convert_refuses_encoder_keywords_of_the_other_format(tmp_path):
    src = tmp_path / "clip.y4m"
    write_y4m(src, clip(3, 16, 16))
    with pytest.raises(ValueError, match="jpeg_subsampling"):
        rf.convert(src, tmp_path / "a", jpeg_subsampling="420")
    with pytest.raises(ValueError, match="png_compression"):
        rf.convert(src, tmp_path / "b", image_format="jpg", png_compression="best")
    with pytest.raises(ValueError, match="png_compression"):
        rf.convert(src, tmp_path / "c", png_compression="9")

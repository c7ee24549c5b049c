"""`reynoldsflow dataset --webdataset` read by the PyPI `webdataset` package:
every sample's members are `dataset`'s files byte for byte, and the
docs' recipe (decode to tensors, a DataLoader) runs."""

import io
import json
import os

import numpy as np
import torch
import webdataset as wds
from torch.utils.data import DataLoader

from conftest import clip, moving_frame, read_png, run_cli, tree, write_pgm, write_y4m


def source_tree(root):
    (root / "class_a").mkdir(parents=True)
    for i in range(3):
        write_y4m(root / "class_a" / f"clip{i}.y4m", clip(4 + i, 40, 24))
    seq = root / "class_b" / "seq.v2"
    seq.mkdir(parents=True)
    for i in range(4):
        write_pgm(seq / f"img.{i:03d}.pgm", moving_frame(40, 24, i, seed=3))


def test_shards_hold_the_files_dataset_writes(cli, tmp_path):
    src, files, shards = tmp_path / "src", tmp_path / "files", tmp_path / "shards"
    source_tree(src)
    flags = ["--npy=v_R", "--npy-dtype", "f16", "--keep-count"]
    run_cli(cli, "dataset", src, files, *flags)
    # Small shards: several tars, each closed between items.
    res = run_cli(cli, "dataset", src, shards, "--webdataset", "--shard-size", "8k", *flags)
    tars = sorted(p for p in os.listdir(shards) if p.endswith(".tar"))
    assert len(tars) >= 2 and tars[0] == "shard-000000.tar", tars
    records = [json.loads(line) for line in res.stdout.splitlines()]
    assert sorted(r["status"] for r in records) == ["done"] * 4

    expected = {p: b for p, b in tree(files).items() if not p.endswith(".reynoldsflow-done")}
    urls = [str(shards / t) for t in tars]
    seen = set()
    for sample in wds.WebDataset(urls, shardshuffle=False):
        key = sample["__key__"]
        item, stem = key.rsplit("/", 1)
        # The package lower-cases member suffixes: v_R.npy is "v_r.npy".
        members = {k for k in sample if not k.startswith("__")}
        assert members == {"rep.png", "v_r.npy", "json"}, sorted(sample)
        meta = json.loads(sample["json"])
        assert meta["key"] == key
        # File stems keep their dots; keys have them as "_" (WebDataset splits at a dot).
        matches = [p for p in expected
                   if p.startswith(item + "/") and p.endswith(".png")
                   and p[len(item) + 1:-4].replace(".", "_") == stem]
        assert len(matches) == 1, (key, matches)
        png = matches[0]
        assert sample["rep.png"] == expected[png], key
        npy = f"{item}/v_R/{png[len(item) + 1:-4]}.npy"
        assert sample["v_r.npy"] == expected[npy], key
        field = np.load(io.BytesIO(sample["v_r.npy"]))
        assert field.dtype == np.float16 and field.shape == (24, 40, 2)
        assert meta["settings"]["npy_dtype"] == "f16"
        assert len(meta["source_frames"]) == 2 and meta["motion"] > 0
        seen.add(png)
    assert seen == {p for p in expected if p.endswith(".png")}
    assert len(seen) == (4 + 5 + 6) + 4  # --keep-count: one per frame


def test_the_recipe_decodes_to_tensors_in_a_dataloader(cli, tmp_path):
    src, files, shards = tmp_path / "src", tmp_path / "files", tmp_path / "shards"
    source_tree(src)
    run_cli(cli, "dataset", src, files)
    run_cli(cli, "dataset", src, shards, "--webdataset", "--shard-size", "8k")
    urls = sorted(str(p) for p in shards.glob("shard-*.tar"))
    dataset = (
        wds.WebDataset(urls, shardshuffle=False, nodesplitter=wds.split_by_node,
                       workersplitter=wds.split_by_worker)
        .decode("torchrgb8")
        .to_tuple("rep.png", "json")
        .batched(4)
    )
    loader = DataLoader(dataset, batch_size=None, num_workers=2)
    got = {}
    for reps, metas in loader:
        assert reps.dtype == torch.uint8 and tuple(reps.shape[1:]) == (3, 24, 40)
        for rep, meta in zip(reps, metas):
            got[meta["key"]] = rep.numpy().transpose(1, 2, 0)
    pngs = sorted(p for p in tree(files) if p.endswith(".png"))
    assert len(got) == len(pngs) == 3 + 4 + 5 + 3
    for png in pngs:
        item, name = png.rsplit("/", 1)
        key = f"{item}/{name[:-4].replace('.', '_')}"
        assert np.array_equal(got[key], read_png(files / png)), key



def test_shards_read_whole_after_sources_change(cli, tmp_path):
    """Reruns after a source is rewritten, a frame added and an item
    deleted leave shards the package reads with every key once and only
    the current items' samples, equal to a fresh build's."""
    src, shards, fresh = tmp_path / "src", tmp_path / "shards", tmp_path / "fresh"
    source_tree(src)
    run_cli(cli, "dataset", src, shards, "--webdataset", "--shard-size", "8k")
    write_y4m(src / "class_a" / "clip0.y4m", clip(7, 40, 24))
    write_pgm(src / "class_b" / "seq.v2" / "img.004.pgm", moving_frame(40, 24, 4, seed=3))
    (src / "class_a" / "clip2.y4m").unlink()
    res = run_cli(cli, "dataset", src, shards, "--webdataset", "--shard-size", "8k")
    statuses = {json.loads(line)["path"].split("/")[-1]: json.loads(line)["status"]
                for line in res.stdout.splitlines()}
    assert statuses == {"clip0.y4m": "done", "clip1.y4m": "skipped", "seq.v2": "done"}, statuses
    run_cli(cli, "dataset", src, fresh, "--webdataset")

    def samples(folder):
        urls = sorted(str(p) for p in folder.glob("shard-*.tar"))
        out = {}
        # The package raises on a repeated member name within a shard.
        for sample in wds.WebDataset(urls, shardshuffle=False):
            key = sample["__key__"]
            assert key not in out, key
            out[key] = {k: v for k, v in sample.items() if not k.startswith("__")}
        return out

    got, want = samples(shards), samples(fresh)
    assert sorted(got) == sorted(want)
    for key in want:
        assert got[key]["rep.png"] == want[key]["rep.png"], key

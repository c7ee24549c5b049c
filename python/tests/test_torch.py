"""PyTorch: tensors in (any strides, read in place), the transform, and the
IterableDataset split across DataLoader workers and ranks."""

import os

import numpy as np
import pytest
import torch
from torch.utils.data import DataLoader

import reynoldsflow as rf
from reynoldsflow import _native
from reynoldsflow.torch import ReynoldsFlow, ReynoldsFlowDataset, collate, shard_of_this_process
from conftest import clip, moving_frame, write_pgm, write_y4m


def tensor_layouts(frame: np.ndarray) -> dict:
    """The same pixels as contiguous, strided, transposed and (H, W, 1)
    tensors."""
    h, w = frame.shape
    contiguous = torch.from_numpy(frame.copy())
    big = torch.zeros((2 * h, 3 * w), dtype=torch.uint8)
    big[::2, ::3] = contiguous
    strided = big[::2, ::3]
    transposed = contiguous.t().contiguous().t()
    channel = contiguous.unsqueeze(-1)
    flipped = torch.flip(torch.flip(contiguous, [0]), [0])
    assert contiguous.is_contiguous()
    assert not strided.is_contiguous() and not transposed.is_contiguous()
    return {"contiguous": contiguous, "strided": strided, "transposed": transposed,
            "channel": channel, "flipped": flipped}


def test_tensors_give_the_numpy_results_whatever_their_strides():
    f0, f1 = moving_frame(37, 23, 0), moving_frame(37, 23, 1)
    rep = rf.represent(f0, f1)
    fields = rf.fields(f0, f1)
    score = rf.motion_score(f0, f1)
    t0, t1 = tensor_layouts(f0), tensor_layouts(f1)
    for name in t0:
        assert np.array_equal(rf.represent(t0[name], t1[name]), rep), name
        assert np.array_equal(rf.represent(t0[name], f1), rep), name
        got = rf.fields(t0[name], t1[name])
        for k in fields:
            assert np.array_equal(got[k], fields[k]), (name, k)
        assert rf.motion_score(t0[name], t1[name]) == score, name
        stream = rf.Stream(37, 23)
        assert stream.push(t0[name]) is None
        assert np.array_equal(stream.push(t1[name]), rep), name
    frames = clip(5, 37, 23)
    expected = rf.represent_clip(frames)
    t = torch.from_numpy(frames.copy())
    big = torch.zeros((5, 23, 74), dtype=torch.uint8)
    big[:, :, ::2] = t
    for view in (t, big[:, :, ::2], t.unsqueeze(-1), t.transpose(1, 2).contiguous().transpose(1, 2)):
        assert np.array_equal(rf.represent_clip(view), expected)


def test_tensors_are_read_in_place_without_a_copy():
    t = torch.from_numpy(moving_frame(40, 30, 0).copy())
    for view in (t, t[::2, 1::3], t.t()):
        array = _native._as_ndarray(view)
        assert array.__array_interface__["data"][0] == view.data_ptr()
        assert array.strides == tuple(s * view.element_size() for s in view.stride())
        assert array.shape == tuple(view.shape)

    class Exported:
        """Only the array interface (no __dlpack__)."""

        def __init__(self, a):
            self.__array_interface__ = a.__array_interface__
            self._keep = a

    a = moving_frame(40, 30, 3)
    assert _native._as_ndarray(Exported(a)).__array_interface__["data"][0] == a.ctypes.data
    assert np.array_equal(rf.represent(Exported(a), a), rf.represent(a, a))


def test_bad_tensors_raise_type_errors_that_say_what_to_do():
    f = torch.from_numpy(moving_frame(16, 12, 0).copy())
    with pytest.raises(TypeError, match="not uint8"):
        rf.represent(f.float(), f)
    with pytest.raises(TypeError, match="4 dimensions"):
        rf.represent(f[None, None], f)
    with pytest.raises(TypeError, match="expected a numpy.ndarray or an array exporting"):
        rf.represent([[1, 2], [3, 4]], f)


def test_the_transform_gives_channels_first_representations():
    frames = clip(6, 33, 21)
    expected = rf.represent_clip(frames).transpose(0, 3, 1, 2)
    transform = ReynoldsFlow()
    t = torch.from_numpy(frames.copy())
    for view in (t, t.unsqueeze(1)):
        out = transform(view)
        assert out.dtype == torch.uint8 and tuple(out.shape) == (5, 3, 21, 33)
        assert np.array_equal(out.numpy(), expected)
    kept = ReynoldsFlow(keep_count=True, scale="fixed:8,32")(t)
    assert tuple(kept.shape) == (6, 3, 21, 33)
    assert np.array_equal(kept.numpy(), rf.represent_clip(frames, keep_count=True, scale="fixed:8,32").transpose(0, 3, 1, 2))
    with pytest.raises(ValueError, match=r"\(T, 1, H, W\)"):
        transform(t.unsqueeze(1).expand(6, 3, 21, 33))
    with pytest.raises(TypeError, match="uint8"):
        transform(t.float())
    with pytest.raises(TypeError, match="torch.Tensor"):
        transform(frames)
    with pytest.raises(TypeError, match="layout"):
        ReynoldsFlow(layout="hwc")


# Six clips: four Y4M videos and two PGM frame folders, 5 to 10 frames each.
CLIPS = {f"class_{c}/clip{i}": (4 + i + 2 * (c == "b"), i) for c in "ab" for i in range(3)}


@pytest.fixture(scope="module")
def six_clips(tmp_path_factory):
    root = tmp_path_factory.mktemp("clips")
    frames = {}
    for name, (t, seed) in CLIPS.items():
        c = np.stack([moving_frame(40, 24, k, seed=seed) for k in range(t + 1)])
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if name.endswith("2"):
            path.mkdir()
            for k, f in enumerate(c):
                write_pgm(path / f"img{k:03d}.pgm", f)
            frames[name] = c
        else:
            write_y4m(path.with_suffix(".y4m"), c)
            frames[name + ".y4m"] = c
    return root, frames


@pytest.fixture(scope="module")
def twenty_clips(tmp_path_factory):
    """Twenty 4-frame Y4M clips of one size."""
    root = tmp_path_factory.mktemp("twenty")
    frames = {}
    for i in range(20):
        c = np.stack([moving_frame(40, 24, k, seed=i) for k in range(4)])
        write_y4m(root / f"clip{i:02d}.y4m", c)
        frames[f"clip{i:02d}.y4m"] = c
    return root, frames


def every_pair(frames: dict, step: int = 1) -> dict:
    """(source, (a, b)) -> representation, channels first, of every pair."""
    out = {}
    for source, c in frames.items():
        picked = list(range(0, len(c), step))
        reps = rf.represent_clip(c[picked], layout="chw")
        for k, rep in enumerate(reps):
            out[(source, (picked[k], picked[k + 1]))] = rep
    return out


def collect(loader) -> list:
    got = []
    for rep, meta in loader:
        got.append(((meta["source"], tuple(int(i) for i in meta["frames"])), rep.numpy()))
    return got


def test_two_workers_yield_every_pair_exactly_once(six_clips):
    root, frames = six_clips
    expected = every_pair(frames)
    assert len(expected) == sum(t for t, _ in CLIPS.values())
    loader = DataLoader(ReynoldsFlowDataset(root), batch_size=None, num_workers=2)
    got = collect(loader)
    keys = [k for k, _ in got]
    assert sorted(keys) == sorted(expected), "every pair, each once"
    for key, rep in got:
        assert rep.shape == (3, 24, 40)
        assert np.array_equal(rep, expected[key]), key
    # Batches: the default collate stacks same-sized pairs.
    batches = list(DataLoader(ReynoldsFlowDataset(root), batch_size=4, num_workers=2))
    assert sum(len(b[0]) for b in batches) == len(expected)
    assert tuple(batches[0][0].shape[1:]) == (3, 24, 40)


class SendsTwice(ReynoldsFlowDataset):
    """Worker code that sends each clip twice, then a view of it."""

    def __iter__(self):
        for reps, meta in super().__iter__():
            yield reps, meta
            yield reps, meta
            yield reps[1:], {**meta, "view": True}


class KeepsInWorker(ReynoldsFlowDataset):
    """Worker code that keeps every clip it sends, and at the end says
    whether they are as they were sent."""

    def __iter__(self):
        kept = []
        for reps, meta in super().__iter__():
            kept.append((reps, reps.clone()))
            yield reps, meta
        yield torch.zeros(0), {"intact": all(torch.equal(a, b) for a, b in kept), "count": len(kept)}


def test_clips_stay_whole_however_either_side_holds_them(twenty_clips):
    root, frames = twenty_clips
    expected = {s: rf.represent_clip(c, layout="chw") for s, c in frames.items()}
    # The main process holds every clip; none changes.
    held = [(meta["source"], reps) for reps, meta in
            DataLoader(ReynoldsFlowDataset(root, per="clip"), batch_size=None, num_workers=2)]
    assert len(held) == len(frames)
    for source, reps in held:
        assert np.array_equal(reps.numpy(), expected[source]), source
    # A clip sent twice stays whole while one copy of it is held, and so
    # does a view of it sent on its own.
    keep = []
    for reps, meta in DataLoader(SendsTwice(root, per="clip"), batch_size=None, num_workers=2):
        keep.append((meta, reps if meta.get("view") or len(keep) % 3 == 1 else None))
    assert len(keep) == 3 * len(frames)
    for meta, reps in keep:
        if reps is not None:
            want = expected[meta["source"]]
            assert np.array_equal(reps.numpy(), want[1:] if meta.get("view") else want), meta["source"]
    # Clips kept in the worker stay whole there, though the main process
    # lets go of each at once.
    ends = [meta for _, meta in DataLoader(KeepsInWorker(root, per="clip"), batch_size=None, num_workers=2)
            if "intact" in meta]
    assert [e["intact"] for e in ends] == [True, True] and sum(e["count"] for e in ends) == len(frames)


def test_every_epoch_of_new_workers_yields_every_clip(twenty_clips):
    root, frames = twenty_clips
    expected = {s: rf.represent_clip(c, layout="chw") for s, c in frames.items()}
    loader = DataLoader(ReynoldsFlowDataset(root, per="clip"), batch_size=None, num_workers=2)
    for _ in range(4):
        got = {meta["source"]: reps.numpy().copy() for reps, meta in loader}
        assert sorted(got) == sorted(expected)
        for source, reps in got.items():
            assert np.array_equal(reps, expected[source]), source


def test_clips_of_ever_larger_sizes_come_whole(tmp_path):
    expected = {}
    for i in range(12):
        c = np.stack([moving_frame(16 + 8 * i, 12, k, seed=i) for k in range(3)])
        write_y4m(tmp_path / f"clip{i:02d}.y4m", c)
        expected[f"clip{i:02d}.y4m"] = rf.represent_clip(c, layout="chw")
    loader = DataLoader(ReynoldsFlowDataset(tmp_path, per="clip"), batch_size=None, num_workers=1,
                        persistent_workers=True)
    for _ in range(2):
        got = {meta["source"]: reps.numpy().copy() for reps, meta in loader}
        assert sorted(got) == sorted(expected)
        for source, reps in got.items():
            assert np.array_equal(reps, expected[source]), source


def test_collate_gives_default_collates_batches(twenty_clips):
    root, _ = twenty_clips

    def batches(**kw):
        return list(DataLoader(ReynoldsFlowDataset(root), batch_size=8, num_workers=2, **kw))

    ours, theirs = batches(collate_fn=collate), batches()
    assert len(ours) == len(theirs) and sum(len(reps) for reps, _ in ours) == 20 * 3
    for (reps, meta), (want, want_meta) in zip(ours, theirs):
        assert type(reps) is torch.Tensor and reps.dtype == torch.uint8
        assert torch.equal(reps, want)
        assert meta["source"] == want_meta["source"] and meta["path"] == want_meta["path"]
        assert all(torch.equal(a, b) for a, b in zip(meta["frames"], want_meta["frames"]))
    # In the main process too (no worker).
    pairs = list(ReynoldsFlowDataset(root, max_frames=3))[:4]
    here = collate(pairs)[0]
    assert type(here) is torch.Tensor and torch.equal(here, torch.stack([rep for rep, _ in pairs]))



def test_ranks_are_disjoint_and_cover_everything(six_clips):
    root, frames = six_clips
    expected = every_pair(frames)
    per_rank = []
    for rank in range(2):
        ds = ReynoldsFlowDataset(root, rank=rank, world_size=2)
        per_rank.append({k for k, _ in collect(DataLoader(ds, batch_size=None, num_workers=2))})
    assert not per_rank[0] & per_rank[1]
    assert per_rank[0] | per_rank[1] == set(expected)
    # The split is `reynoldsflow dataset --shard`'s: rank r, worker w of 2 is shard 2r + w of 4.
    for rank in range(2):
        items = set()
        for w in range(2):
            items |= {p for p, _ in rf.dataset_items(root, shard=(2 * rank + w, 4))}
        assert {s for s, _ in per_rank[rank]} == {os.path.relpath(p, root) for p in items}


def test_clips_step_and_resize_match_represent_clip(six_clips):
    root, frames = six_clips
    got = {meta["source"]: (reps.numpy(), meta["frames"])
           for reps, meta in ReynoldsFlowDataset(root, per="clip", step=2, resize=(20, 12))}
    assert set(got) == set(frames)
    for source, c in frames.items():
        reps, indices = got[source]
        assert list(indices) == list(range(0, len(c), 2))
        expected = rf.represent_clip(c, step=2, resize=(20, 12), layout="chw")
        assert reps.shape == expected.shape == (len(indices) - 1, 3, 12, 20)
        assert np.array_equal(reps, expected), source
    pairs = dict(collect(ReynoldsFlowDataset(root, step=2, resize=(20, 12))))
    assert set(pairs) == set(every_pair(frames, step=2))


def test_a_list_of_paths_is_a_source(six_clips):
    root, frames = six_clips
    some = sorted(frames)[::2]
    got = {meta["source"]: reps.numpy()
           for reps, meta in ReynoldsFlowDataset(root, files_from=[root / s for s in some], per="clip")}
    assert sorted(got) == some
    for source in some:
        assert np.array_equal(got[source], rf.represent_clip(frames[source], layout="chw")), source
    # Workers split the list by the same hash as a manifest of it.
    loader = DataLoader(ReynoldsFlowDataset(root, files_from=some), batch_size=None, num_workers=2)
    assert sorted({k[0] for k, _ in collect(loader)}) == some


def test_shards_and_bad_options():
    assert shard_of_this_process() == (0, 1)
    assert shard_of_this_process(3, 4) == (3, 4)
    with pytest.raises(ValueError, match="rank 4"):
        shard_of_this_process(4, 4)
    with pytest.raises(ValueError, match="together"):
        ReynoldsFlowDataset(".", rank=1)
    with pytest.raises(ValueError, match="per"):
        ReynoldsFlowDataset(".", per="frame")
    with pytest.raises(ValueError, match="variant"):
        ReynoldsFlowDataset(".", variant="rgb")
    # The Stream options the dataset sets itself are refused up front.
    for key, value in (("layout", "hwc"), ("threads", 4), ("first_frame", "repeat")):
        with pytest.raises(TypeError, match=f"takes no {key}"):
            ReynoldsFlowDataset(".", **{key: value})
    with pytest.raises(OSError):
        ReynoldsFlowDataset("/nonexistent/videos")

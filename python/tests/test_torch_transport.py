"""The way from DataLoader workers to the training loop: every clip a loader
yields holds represent_clip's bytes, computed here in the main process from
the same file, whatever torch lets the training code do with the tensor
(view it as NumPy, send it to another process, share it, hand it to a
forked child), and no shared memory stays mapped once the loader and its
tensors are gone. Each test is a training script's loop: 2 workers, every
clip compared byte for byte."""

import gc
import io

import numpy as np
import pytest
import torch
import torch.multiprocessing as mp
from torch.utils.data import DataLoader

import reynoldsflow as rf
from reynoldsflow.torch import ReynoldsFlowDataset
from conftest import moving_frame, write_y4m

FORK = mp.get_context("fork")


def clip_tree(root, count: int, w: int, h: int, t: int) -> dict:
    """``count`` Y4M clips of ``t`` frames, ``w`` x ``h``, under ``root``,
    and each one's representations as represent_clip makes them here from
    the frames read back."""
    expected = {}
    for i in range(count):
        path = root / f"clip{i:02d}.y4m"
        write_y4m(path, np.stack([moving_frame(w, h, k, seed=i) for k in range(t)]))
        frames = np.stack([f for _, f in rf.read_frames(path)])
        expected[path.name] = rf.represent_clip(frames, layout="chw")
    return expected


@pytest.fixture(scope="module")
def forty_clips(tmp_path_factory):
    root = tmp_path_factory.mktemp("forty")
    return root, clip_tree(root, 40, 96, 64, 8)


def clips(root, **kw) -> DataLoader:
    return DataLoader(ReynoldsFlowDataset(root, per="clip"), batch_size=None, num_workers=2, **kw)


def _drain(q) -> None:
    """Another process that takes the tensors sent to it."""
    while q.get() is not None:
        pass


@pytest.mark.parametrize("send", ["queue", "share_memory_"])
def test_a_numpy_view_of_a_clip_stays_right_once_the_clip_is_sent(forty_clips, send):
    root, expected = forty_clips
    q = FORK.Queue()
    sink = FORK.Process(target=_drain, args=(q,))
    sink.start()
    views = []
    for x, meta in clips(root, prefetch_factor=4):
        arr = x.numpy()  # for logging, OpenCV, NumPy code
        assert np.array_equal(arr, expected[meta["source"]]), meta["source"]
        if send == "queue":
            q.put(x)
        else:
            x.share_memory_()
        views.append((meta["source"], arr))
    q.put(None)
    sink.join()
    assert len(views) == len(expected)
    wrong = [source for source, arr in views if not np.array_equal(arr, expected[source])]
    assert not wrong, f"{len(wrong)} of {len(views)} NumPy views changed"


def test_a_clip_put_on_a_queue_reads_right_while_the_queue_sends_it(tmp_path):
    # A race between the queue's feeder thread, which sends the clip, and
    # torch.save here: many small clips, to meet it if it can happen.
    expected = clip_tree(tmp_path, 40, 32, 24, 3)
    q = FORK.Queue()
    sink = FORK.Process(target=_drain, args=(q,))
    sink.start()
    loader = clips(tmp_path, persistent_workers=True, prefetch_factor=4)
    wrong, count = [], 0
    for _ in range(100):
        for x, meta in loader:
            q.put(x)
            buf = io.BytesIO()
            torch.save(x, buf)
            count += 1
            if not np.array_equal(torch.load(io.BytesIO(buf.getvalue())).numpy(), expected[meta["source"]]):
                wrong.append(meta["source"])
    q.put(None)
    sink.join()
    assert count == 100 * len(expected)
    assert not wrong, f"{len(wrong)} of {count} clips read wrong"


def _equal_later(x: torch.Tensor, want: np.ndarray, go) -> None:
    """A forked child's work on a clip it was given: after the parent has
    iterated on, the clip is still the one it was given."""
    assert go.wait(120)
    raise SystemExit(0 if np.array_equal(x.numpy(), want) else 1)


def test_a_forked_child_given_a_clip_reads_that_clip(forty_clips):
    root, expected = forty_clips
    children = []
    for k, (x, meta) in enumerate(clips(root)):
        if k % 8 == 0:
            go = FORK.Event()
            child = FORK.Process(target=_equal_later, args=(x, expected[meta["source"]], go))
            child.start()
            children.append((child, go))
        # The parent drops x and iterates on.
    for _, go in children:
        go.set()
    for child, _ in children:
        child.join()
    assert len(children) == 5
    wrong = [child.exitcode for child, _ in children if child.exitcode != 0]
    assert not wrong, f"{len(wrong)} of {len(children)} children read another clip"


def _use_and_drop(held: list) -> None:
    """A forked child that reads the clips it inherits, then drops them."""
    assert all(x.numel() for _, x in held)
    held.clear()


def test_a_forked_child_that_drops_its_clips_leaves_the_parents_whole(forty_clips):
    root, expected = forty_clips
    held, count = [], 0
    for x, meta in clips(root):
        count += 1
        if len(held) < 4:
            held.append((meta["source"], x))
            if len(held) == 4:
                child = FORK.Process(target=_use_and_drop, args=(held,))
                child.start()
                child.join()
                assert child.exitcode == 0
    assert count == len(expected)
    wrong = [source for source, x in held if not np.array_equal(x.numpy(), expected[source])]
    assert not wrong, f"{len(wrong)} of {len(held)} held clips overwritten"


def shared_mappings() -> set:
    """This process's mappings of shared memory for data: memfd and
    /dev/shm segments (torch's shared memory is the latter), not the
    semaphores of multiprocessing's queues."""
    with open("/proc/self/maps") as f:
        return {line.split(None, 5)[-1].strip() + " @" + line.split()[0] for line in f
                if "memfd:" in line or ("/dev/shm/" in line and "/dev/shm/sem." not in line)}


def test_no_shared_memory_stays_mapped_once_the_loader_is_gone(forty_clips):
    root, expected = forty_clips
    gc.collect()
    before = shared_mappings()
    loader = clips(root)
    for _ in range(2):
        count = 0
        for x, meta in loader:
            assert np.array_equal(x.numpy(), expected[meta["source"]]), meta["source"]
            count += 1
        assert count == len(expected)
    del loader, x
    gc.collect()
    left = shared_mappings() - before
    assert not left, f"{len(left)} shared segments still mapped: {sorted(left)[:3]}"

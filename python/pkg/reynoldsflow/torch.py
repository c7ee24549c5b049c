"""PyTorch: ReynoldsFlow as a transform and as an ``IterableDataset``.

Imported on its own (``import reynoldsflow.torch``), only where PyTorch is
installed; ``import reynoldsflow`` never imports torch. Tensors are uint8,
channels first (``(3, H, W)``, as torchvision's), and hold the bytes
``reynoldsflow run`` writes.

- :class:`ReynoldsFlow`: a transform from a ``(T, H, W)`` or
  ``(T, 1, H, W)`` uint8 clip to its ``(T - 1, 3, H, W)`` representations.
- :class:`ReynoldsFlowDataset`: the representations of a tree of videos and
  frame folders (or one video, or a manifest), read as ``reynoldsflow
  dataset`` reads them, per pair or per clip. The items are split across
  ``DataLoader`` workers and ``torch.distributed`` ranks by the hash of
  ``reynoldsflow dataset --shard``, so every pair is yielded exactly once.

N frames give N - 1 results; result n is the pair (frame n, frame n + 1)
of the frames taken (``step``/``fps`` take frames 0, K, 2K, ...).
"""

from __future__ import annotations

import math
import os
from typing import Any, Dict, Iterator, List, Optional, Sequence, Tuple, Union

try:
    import torch
    from torch.utils.data import IterableDataset, default_collate, get_worker_info
except ImportError as e:  # pragma: no cover - exercised without torch only
    raise ImportError(
        "reynoldsflow.torch needs PyTorch (pip install torch); "
        "the rest of reynoldsflow works without it"
    ) from e

import numpy

import reynoldsflow as _rf
from reynoldsflow._core_params import SETTING_KEYS as _SETTING_KEYS, checked_settings as _checked_settings
from reynoldsflow._core_params import core_constants as _core_constants
from reynoldsflow._torch_batch import gray_frames, represent_batch

__all__ = ["ReynoldsFlow", "ReynoldsFlowDataset", "collate", "represent_batch", "shard_of_this_process"]

# The keywords of the frames taken (read_frames / represent_clip).
_FRAME_KEYS = ("step", "fps", "resize", "short_side")


def _threads_here(threads: Optional[int]) -> Optional[int]:
    """Inside a DataLoader worker, one thread unless told otherwise: the
    workers are the parallelism, and more threads than cores only contend."""
    if threads is None and get_worker_info() is not None:
        return 1
    return threads


def _result_tensor(shape: Tuple[int, ...]) -> "torch.Tensor":
    """An uninitialised uint8 tensor of ``shape`` for a clip's results to be
    written into. Inside a ``DataLoader`` worker it is in torch's shared
    memory, as ``default_collate`` makes its batches: sending it passes that
    memory, which is the clip's alone, where a tensor in private memory
    would first be copied into new shared memory."""
    if get_worker_info() is None:
        return torch.empty(shape, dtype=torch.uint8)
    # A private method of torch's (default_collate's way to shared memory):
    # where a torch lacks it, private memory, which torch copies to send.
    new_shared = getattr(torch.UntypedStorage, "_new_shared", None)
    if new_shared is None:
        return torch.empty(shape, dtype=torch.uint8)
    return torch.empty(0, dtype=torch.uint8).set_(new_shared(math.prod(shape))).view(shape)


class ReynoldsFlow:
    """A transform: a ``(T, H, W)`` or ``(T, 1, H, W)`` uint8 CPU tensor of
    gray frames to the ``(T - 1, 3, H, W)`` uint8 tensor of its consecutive
    pairs' representations (``keep_count=True``: ``(T, 3, H, W)``, the last
    one repeated).

    Keywords are ``reynoldsflow.represent_clip``'s (``engine``, ``scale``,
    ``variant``, ``step``, ``resize``, ...). ``threads`` defaults to every
    core in the main process and to 1 inside a ``DataLoader`` worker. The
    input is read in place (no copy) whatever its strides.

    ``device`` (e.g. ``"cuda"``): the clip is moved there and computed
    there by :func:`represent_batch` (the same bytes), the result left
    there; it takes ``represent_batch``'s settings and ``keep_count``.
    """

    def __init__(
        self,
        *,
        threads: Optional[int] = None,
        device: Union[None, str, "torch.device"] = None,
        **options: Any,
    ) -> None:
        if "layout" in options:
            raise TypeError("ReynoldsFlow() returns channels first; it takes no layout")
        self.threads = threads
        self.options = options
        self.device = None if device is None else torch.device(device)
        if self.device is not None:
            other = sorted(set(options) - set(_SETTING_KEYS) - {"keep_count"})
            if other or threads is not None:
                raise ValueError(
                    f"ReynoldsFlow(device=...) takes represent_batch's settings and keep_count; "
                    f"not {', '.join(other or ['threads'])}"
                )
            # A bad setting raises here.
            _core_constants(_checked_settings("ReynoldsFlow", self._settings()))

    def _settings(self) -> Dict[str, Any]:
        return {k: v for k, v in self.options.items() if k != "keep_count"}

    def __call__(self, frames: "torch.Tensor") -> "torch.Tensor":
        frames = gray_frames(frames, "ReynoldsFlow", "T")
        if self.device is not None:
            return self._on_device(frames.to(self.device))
        reps = _rf.represent_clip(
            frames, layout="chw", threads=_threads_here(self.threads), **self.options
        )
        return torch.from_numpy(reps)

    def _on_device(self, frames: "torch.Tensor") -> "torch.Tensor":
        if frames.shape[0] < 2:
            raise ValueError(f"ReynoldsFlow: a clip of {frames.shape[0]} frames; expected at least 2")
        reps = represent_batch(frames[:-1], frames[1:], **self._settings())
        if self.options.get("keep_count"):
            reps = torch.cat([reps, reps[-1:]])
        return reps

    def __repr__(self) -> str:
        options = ", ".join(f"{k}={v!r}" for k, v in sorted(self.options.items()))
        return f"ReynoldsFlow({options})"


def collate(batch: Sequence[Tuple["torch.Tensor", Dict[str, Any]]]) -> Any:
    """``default_collate``: the images of ``(rep, meta)`` pairs stacked,
    ``(B, 3, H, W)``, and the metas collated. The ``DataLoader`` default
    already does this, so ``collate_fn`` can be left out; the name stays so
    that code passing ``collate_fn=collate`` keeps working."""
    return default_collate(batch)


def shard_of_this_process(
    rank: Optional[int] = None, world_size: Optional[int] = None
) -> Tuple[int, int]:
    """``(index, count)`` of the shard this process reads: one shard per
    ``DataLoader`` worker of every rank, ``index = rank * workers + worker``.
    ``rank`` and ``world_size`` default to ``torch.distributed``'s when it
    is initialised, else 0 and 1."""
    if (rank is None) != (world_size is None):
        raise ValueError("give rank and world_size together, or neither")
    if rank is None:
        dist = torch.distributed
        if dist.is_available() and dist.is_initialized():
            rank, world_size = dist.get_rank(), dist.get_world_size()
        else:
            rank, world_size = 0, 1
    assert world_size is not None
    if not 0 <= rank < world_size:
        raise ValueError(f"rank {rank} is not in 0..{world_size - 1} (world_size {world_size})")
    info = get_worker_info()
    workers, worker = (info.num_workers, info.id) if info is not None else (1, 0)
    return rank * workers + worker, world_size * workers


class ReynoldsFlowDataset(IterableDataset):
    """The representations of the videos and frame folders under ``src``
    (a folder tree, one video or one frame folder; with ``files_from``, the
    items that manifest lists, one path relative to ``src`` per line, or the
    items of a list of paths, each relative to ``src`` or inside it), read
    in the order and with the frames of ``reynoldsflow dataset SRC``.

    ``per="pair"`` (default) yields ``(rep, meta)`` for each pair: ``rep``
    a ``(3, H, W)`` uint8 tensor, ``meta`` a dict with ``source`` (the item's
    path relative to ``src``, as ``--shard`` hashes it), ``path`` and
    ``frames`` (the input indices of the pair's two frames). ``per="clip"``
    yields ``(reps, meta)`` per item: ``(T - 1, 3, H, W)`` and ``frames``
    the indices of all T frames taken. Items with fewer than 2 frames taken
    yield nothing.

    Each process of a ``DataLoader`` (worker ``w`` of ``W``, rank ``r`` of
    ``R``) reads shard ``r * W + w`` of ``R * W``: the items whose path
    hashes there, as ``reynoldsflow dataset --shard``. Shards are disjoint
    and cover every item, so every pair is yielded exactly once per epoch
    (not evenly: a shard holds the items the hash gives it). ``rank`` and
    ``world_size`` default to ``torch.distributed``'s.

    Keywords: ``step``, ``fps``, ``resize``, ``short_side``, ``max_frames``
    choose the frames (as the command line's flags); the others are
    ``reynoldsflow.Stream``'s image options (``engine``, ``scale``,
    ``variant``, ...), not its ``layout``, ``threads`` or ``first_frame``:
    each worker computes on one thread, channels first, one image a pair.
    Frames of different sizes do not batch: pass ``resize`` or use
    ``batch_size=None``.
    """

    def __init__(
        self,
        src: Union[str, "os.PathLike[str]"],
        *,
        files_from: Union[None, str, "os.PathLike[str]", Sequence[Union[str, "os.PathLike[str]"]]] = None,
        per: str = "pair",
        rank: Optional[int] = None,
        world_size: Optional[int] = None,
        max_frames: Optional[int] = None,
        **options: Any,
    ) -> None:
        super().__init__()
        if per not in ("pair", "clip"):
            raise ValueError(f"per = {per!r}; expected 'pair' or 'clip'")
        if "layout" in options:
            raise TypeError("ReynoldsFlowDataset() yields channels first; it takes no layout")
        for key in ("threads", "first_frame"):
            if key in options:
                raise TypeError(f"ReynoldsFlowDataset() takes no {key}: each worker computes one "
                                "image a pair, on one thread")
        if (rank is None) != (world_size is None):
            raise ValueError("give rank and world_size together, or neither")
        self.src = os.fspath(src)
        self.files_from: Union[None, str, List[str]] = (
            None if files_from is None
            else os.fspath(files_from) if isinstance(files_from, (str, os.PathLike))
            else [os.fspath(p) for p in files_from]
        )
        self.per = per
        self.rank, self.world_size = rank, world_size
        self.frame_options: Dict[str, Any] = {k: options.pop(k) for k in _FRAME_KEYS if k in options}
        if max_frames is not None:
            self.frame_options["max_frames"] = max_frames
        self.image_options = options
        # Checked now, in the main process, not first in a worker: a bad
        # option or a missing src raises here.
        _rf.Stream(2, 2, threads=1, **self.image_options)
        self._items_of((0, 1))

    def _items_of(self, shard: Tuple[int, int]) -> Sequence[Tuple[str, str]]:
        return _rf.dataset_items(self.src, files_from=self.files_from, shard=shard)

    def _source(self, path: str) -> str:
        if os.path.isdir(self.src):
            return os.path.relpath(path, self.src).replace(os.sep, "/")
        return os.path.basename(path)

    def __iter__(self) -> Iterator[Tuple["torch.Tensor", Dict[str, Any]]]:
        shard = shard_of_this_process(self.rank, self.world_size)
        for path, _ in self._items_of(shard):
            meta = {"source": self._source(path), "path": path}
            frames = _rf.read_frames(path, **self.frame_options)
            if self.per == "pair":
                yield from self._pairs(frames, meta)
            else:
                yield from self._clip(frames, meta)

    def _pairs(self, frames: "_rf.FrameReader", meta: Dict[str, Any]) -> Iterator[Any]:
        stream, prev = None, None
        for index, frame in frames:
            if stream is None:
                h, w = frame.shape
                # One thread: the DataLoader's workers are the parallelism.
                stream = _rf.Stream(w, h, layout="chw", threads=1, **self.image_options)
                stream.push(frame)
            else:
                # A frame of another size raises, as `reynoldsflow run` refuses it.
                # Private memory: a batch's collate copies its pairs into the
                # batch's shared memory (unbatched, torch copies each pair).
                rep = torch.from_numpy(stream.push(frame))
                yield rep, {**meta, "frames": (prev, index)}
            prev = index

    def _clip(self, frames: "_rf.FrameReader", meta: Dict[str, Any]) -> Iterator[Any]:
        taken = list(frames)
        if len(taken) < 2:
            return
        indices = [i for i, _ in taken]
        clip = numpy.stack([f for _, f in taken])
        _, h, w = clip.shape
        reps = _result_tensor((len(taken) - 1, 3, h, w))
        _rf.represent_clip(clip, layout="chw", threads=_threads_here(None), out=reps, **self.image_options)
        yield reps, {**meta, "frames": indices}

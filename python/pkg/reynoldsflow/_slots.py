"""Clips from ``DataLoader`` workers to the main process in reused memory.

torch sends a tensor in shared memory by passing its file descriptor (a
connection to the worker's resource-sharer thread each message), and a
worker that makes every clip in new shared memory pays for new pages each
time: allocated and zeroed in the worker, mapped in both processes, freed
when the main process lets the tensor go. On a 2-core machine that cost a
quarter of the pairs per second (``python/bench/torch_loader.py``).

Here each worker keeps a few *slots*: memory of its own (``memfd``), each
sent to the main process once, by descriptor; from then on a clip in a slot
travels as (pool, slot, shape) and the main process keeps the mapping. A
slot is written again only when both sides are done with it:

- in the main process the tensor handed out is ``torch.from_numpy`` over the
  slot: when its storage goes (every view of it dropped, or its data moved
  into torch's shared memory by torch itself), NumPy's array goes, and a
  finalizer tells the worker through the slot's control word;
- in the worker, the same: the clip's tensor and every view of it hold an
  array whose finalizer marks the slot unused there.

Slot memory is not torch's shared memory, so a view of a clip that user code
sends through torch's own path is copied on the way, never aliased. Where
there is no ``memfd`` (not Linux) or the pool is full, a clip is made in
torch's shared memory as before.

The control word (a ``uint32`` after the slot's data): the number of the
slot's messages the main process has received and let go of. The worker
writes into a slot only when that equals the messages it has sent and no
tensor of its own still points there.
"""

from __future__ import annotations

import collections
import math
import mmap
import os
import threading
import uuid
import weakref
from multiprocessing.reduction import DupFd, ForkingPickler
from typing import Deque, Dict, List, Optional, Tuple

import numpy
import torch
from torch.multiprocessing.reductions import reduce_tensor
from torch.utils.data import get_worker_info

__all__ = ["SlotTensor", "slot_tensor"]

# Slots a worker keeps; the main process holds at most this many of one
# worker's clips without falling back to torch's shared memory.
MAX_SLOTS = 8
# Of them, how many may hold single pairs: a batch of pairs is collated
# while its pairs still hold theirs, and needs a slot of its own.
PAIR_SLOTS = MAX_SLOTS // 2
# Bytes after the data: the control word, 8-byte aligned.
_CONTROL = 8


class SlotTensor(torch.Tensor):
    """A tensor made in a worker's slot. Operations on it give plain
    tensors; multiprocessing sends it by slot (registered below)."""

    __torch_function__ = torch._C._disabled_torch_function_impl


class _Slot:
    def __init__(self, number: int, capacity: int) -> None:
        self.number = number
        self.capacity = capacity
        self.fd = os.memfd_create(f"reynoldsflow-slot-{number}", os.MFD_CLOEXEC)
        try:
            os.ftruncate(self.fd, capacity + _CONTROL)
            self.bytes = numpy.frombuffer(mmap.mmap(self.fd, capacity + _CONTROL), numpy.uint8)
        except BaseException:
            os.close(self.fd)
            raise
        self.released = self.bytes[capacity:].view(numpy.uint32)
        self.sent = 0
        self.in_worker = False

    def close(self) -> None:
        os.close(self.fd)

    def _unused_here(self) -> None:
        self.in_worker = False

    def idle(self) -> bool:
        """Neither process holds a tensor over it."""
        return not self.in_worker and int(self.released[0]) == self.sent

    def fits(self, nbytes: int) -> bool:
        """Big enough for ``nbytes``, and not more than twice as big."""
        return nbytes <= self.capacity <= 2 * nbytes


class _Pool:
    """This worker's slots."""

    def __init__(self) -> None:
        self.id = uuid.uuid4().hex
        self.pid = os.getpid()
        self.slots: List[_Slot] = []
        self.numbers = 0
        self.by_address: Dict[int, _Slot] = {}
        # Slots dropped since the last message: the next tells the main
        # process (a deque: the feeder thread takes what this one adds).
        self.dropped: Deque[int] = collections.deque()

    def take(self, shape: Tuple[int, ...], limit: int) -> Optional[SlotTensor]:
        nbytes = math.prod(shape)
        free = [s for s in self.slots if s.fits(nbytes) and s.idle()]
        if free:
            slot = min(free, key=lambda s: s.capacity)
        elif sum(1 for s in self.slots if s.fits(nbytes)) >= limit:
            return None
        else:
            if len(self.slots) >= MAX_SLOTS:
                # Make room by dropping a slot of another size nobody uses.
                idle = [s for s in self.slots if s.idle()]
                if not idle:
                    return None
                self._drop(idle[0])
            try:
                slot = _Slot(self.numbers, -(-nbytes // _CONTROL) * _CONTROL)
            except OSError:
                return None
            self.numbers += 1
            self.slots.append(slot)
            self.by_address[slot.bytes.ctypes.data] = slot
        data = slot.bytes[:nbytes]
        slot.in_worker = True
        weakref.finalize(data, slot._unused_here)
        return torch.from_numpy(data).view(shape).as_subclass(SlotTensor)

    def _drop(self, slot: _Slot) -> None:
        self.slots.remove(slot)
        del self.by_address[slot.bytes.ctypes.data]
        self.dropped.append(slot.number)
        slot.close()


# This process's pool; a forked child makes its own.
_pool: Optional[_Pool] = None


def _this_pool() -> Optional[_Pool]:
    return _pool if _pool is not None and _pool.pid == os.getpid() else None


def slot_tensor(shape: Tuple[int, ...], limit: int = MAX_SLOTS) -> Optional[SlotTensor]:
    """An uninitialised uint8 tensor of ``shape`` in one of this
    ``DataLoader`` worker's slots, or None: outside a worker, where there
    is no ``memfd``, when every slot is in use, or ``limit`` slots of its
    size are."""
    global _pool
    if get_worker_info() is None or not hasattr(os, "memfd_create"):
        return None
    if _this_pool() is None:
        _pool = _Pool()
    assert _pool is not None
    return _pool.take(shape, limit)


def _reduce_slot_tensor(t: SlotTensor):
    """multiprocessing's pickling of a SlotTensor: by slot when its data
    still lies at the start of one, else as torch sends any tensor (after
    torch itself moved its data into shared memory, say)."""
    pool = _this_pool()
    slot = pool.by_address.get(t.data_ptr()) if pool is not None else None
    if pool is None or slot is None or not t.is_contiguous() or t.numel() > slot.capacity:
        return reduce_tensor(t.as_subclass(torch.Tensor))
    fd = DupFd(slot.fd) if slot.sent == 0 else None
    slot.sent += 1
    dropped = tuple(pool.dropped.popleft() for _ in range(len(pool.dropped)))
    head = (pool.id, pool.pid, slot.number, slot.capacity, slot.sent, dropped)
    return (_rebuild, (head, fd, tuple(t.shape)))


ForkingPickler.register(SlotTensor, _reduce_slot_tensor)


class _Mapped:
    """A worker's slot as the main process maps it."""

    def __init__(self, data: numpy.ndarray) -> None:
        self.data = data
        self.received = 0  # messages of this slot received
        self.held = 0  # of them, how many tensors are still alive

    def let_go(self) -> None:
        with _received.lock:
            self.held -= 1
            if self.held == 0:
                # Every message received so far is let go of: the worker may
                # write here once it has sent no more than that.
                self.data[-_CONTROL:].view(numpy.uint32)[0] = self.received


class _Received:
    """The main process's side: every worker's slots, mapped."""

    def __init__(self) -> None:
        # Finalizers may run on any thread, inside this lock's holder too.
        self.lock = threading.RLock()
        self.slots: Dict[Tuple[str, int], _Mapped] = {}
        self.pools: Dict[str, int] = {}  # pool -> worker pid

    def tensor(self, head: tuple, fd: Optional[DupFd], shape: Tuple[int, ...]) -> torch.Tensor:
        pool, pid, number, capacity, seq, dropped = head
        with self.lock:
            for gone in dropped:
                self.slots.pop((pool, gone), None)
            if fd is not None:
                if pool not in self.pools:
                    self.sweep()
                    self.pools[pool] = pid
                own = fd.detach()
                try:
                    mapped = numpy.frombuffer(mmap.mmap(own, capacity + _CONTROL), numpy.uint8)
                finally:
                    os.close(own)
                self.slots[(pool, number)] = _Mapped(mapped)
            slot = self.slots[(pool, number)]
            slot.received = seq
            slot.held += 1
        data = slot.data[: math.prod(shape)]
        weakref.finalize(data, slot.let_go)
        return torch.from_numpy(data).view(shape)

    def sweep(self) -> None:
        """Forget the pools of workers that have exited (a new epoch's
        workers replace them); each mapping goes once no tensor holds it."""
        for pool, pid in list(self.pools.items()):
            try:
                os.kill(pid, 0)
                continue
            except ProcessLookupError:
                pass
            except PermissionError:
                continue
            del self.pools[pool]
            for key in [k for k in self.slots if k[0] == pool]:
                del self.slots[key]


_received = _Received()


def _rebuild(head, fd, shape):
    return _received.tensor(head, fd, shape)


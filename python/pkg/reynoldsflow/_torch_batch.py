"""``represent_batch``: the core's representation of batches of frame pairs
held as tensors on any device, computed there (``_torch_core``), checked
and cut into chunks that bound the working memory."""

from __future__ import annotations

from typing import Any, Dict, Optional, Tuple, Union

import torch

from . import _native, _torch_core
from ._core_params import checked_settings, core_constants

# The largest frame side the core takes (params.rs MAX_SIDE).
MAX_SIDE = 65535

# Default working memory of one chunk of pairs, in bytes.
DEFAULT_MEMORY_BUDGET = 1 << 30

Fields = Dict[str, torch.Tensor]


def gray_frames(t: Any, who: str, axis: str) -> torch.Tensor:
    """``t`` as ``(N, H, W)`` uint8 frames (a view of ``(N, 1, H, W)``), or
    the ``TypeError`` / ``ValueError`` that starts with ``who`` (the
    function and argument); ``axis`` names the first axis (``B``, ``T``)."""
    if not isinstance(t, torch.Tensor):
        raise TypeError(f"{who}: expected a torch.Tensor, got {type(t).__name__}")
    if t.dtype != torch.uint8:
        raise TypeError(f"{who}: expected uint8 frames, got {t.dtype}")
    if t.dim() == 4:
        if t.shape[1] != 1:
            raise ValueError(
                f"{who}: 4-D frames must be ({axis}, 1, H, W) (one gray channel); "
                f"got shape {tuple(t.shape)}"
            )
        return t[:, 0]
    if t.dim() != 3:
        raise TypeError(
            f"{who}: expected ({axis}, H, W) or ({axis}, 1, H, W) frames, got {t.dim()} dimensions"
        )
    return t


def _frames(name: str, t: Any) -> torch.Tensor:
    """``t`` as ``(B, H, W)`` uint8 (a view), or the error naming it."""
    t = gray_frames(t, f"represent_batch: {name}", "B")
    h, w = t.shape[1:]
    if not (1 <= h <= MAX_SIDE and 1 <= w <= MAX_SIDE):
        raise ValueError(
            f"represent_batch: {name}: frames of {w}x{h}; each side must be 1 to {MAX_SIDE} pixels"
        )
    # The frame-size limit of every entry point (reynoldsflow.set_max_pixels).
    _native._check_frame_size(w, h, f"represent_batch: {name}")
    return t


def pair_bytes(height: int, width: int) -> int:
    """The working memory one pair of ``height × width`` takes, by the
    bound the chunks are sized with (``_torch_core``)."""
    pixels = (height + 2 * _torch_core.HALO) * (width + 2 * _torch_core.HALO)
    return pixels * _torch_core.WORKING_BYTES_PER_PIXEL


def chunk_pairs(height: int, width: int, memory_budget: int) -> int:
    """How many pairs of ``height × width`` one chunk computes at once:
    the budget over :func:`pair_bytes`; a ``ValueError`` naming
    ``memory_budget`` where it does not hold one pair."""
    need = pair_bytes(height, width)
    if memory_budget < need:
        raise ValueError(
            f"represent_batch: memory_budget = {memory_budget} bytes ({memory_budget / 2**30:.3g} GiB) "
            f"does not hold one {width}x{height} pair, which needs {need} bytes "
            f"({need / 2**30:.3g} GiB); give a larger memory_budget (where the device has the "
            "memory) or smaller frames"
        )
    return memory_budget // need


def _check_device(device: torch.device, name: str) -> None:
    """Refuse a device whose bytes nobody has checked against the core: on
    a ROCm build of PyTorch (``torch.version.hip`` set), every device but
    the CPU (ROCm's GPUs report ``"cuda"``; ``python/bench/gpu_check.py``
    has checked CUDA's only)."""
    hip = getattr(torch.version, "hip", None)
    if hip and device.type != "cpu":
        raise ValueError(
            f"represent_batch: {name}: on {device} of a ROCm build of PyTorch (torch.version.hip = {hip}): "
            "its bytes have not been checked against the core; give CPU tensors "
            "(prev.cpu(), next.cpu()), or use reynoldsflow.represent_clip"
        )


# A caller's torch.compile must not trace into represent_batch: compiled
# kernels may fuse multiply-adds or rewrite divisions (Triton), which changes
# the bytes; its eager operations are what is checked against the core.
# (torch.compiler.disable from PyTorch 2.1, torch._dynamo.disable before.)
_not_compiled = getattr(getattr(torch, "compiler", None), "disable", None) or torch._dynamo.disable


@_not_compiled
def represent_batch(
    prev: torch.Tensor,
    next: torch.Tensor,
    *,
    fields: bool = False,
    memory_budget: int = DEFAULT_MEMORY_BUDGET,
    **settings: Any,
) -> Union[torch.Tensor, Tuple[torch.Tensor, Fields]]:
    """The representation of every pair ``(prev[i], next[i])``: a
    ``(B, 3, H, W)`` uint8 tensor on the frames' device whose image ``i`` is
    ``reynoldsflow.represent(prev[i], next[i], layout="chw", **settings)``
    byte for byte, on any device (the core's integer and ``float32``
    arithmetic in eager tensor operations, see ``docs/python.md``).

    ``prev``, ``next``: ``(B, H, W)`` or ``(B, 1, H, W)`` uint8 tensors of one
    shape on one device, any strides. ``settings``: ``represent``'s, parsed
    by the same code with the same meaning (``None`` is the default, and
    ``**reynoldsflow.DEFAULTS`` is taken): ``scale``, ``intensity_scale``,
    ``lam``, ``variant`` (``"dc"``, ``"dc0"``, ``"cd"``; ``"hsv"`` raises
    ``ValueError``), ``engine`` (``"fixed"`` only), ``tile`` (no effect on
    the bytes), ``hsv_max`` and ``layout``: ``"hwc"`` gives
    ``(B, H, W, 3)``; unset or ``None``, channels first (``"chw"``).

    With ``fields=True``, returns ``(rgb, fields)``: ``fields["v_c"]`` and
    ``fields["v_d"]`` ``(B, 2, H, W)`` float32 (x, y in pixels) and
    ``fields["m_c"]``, ``fields["m_d"]`` ``(B, H, W)`` float32 (their
    magnitudes), each the core's ``float32`` values bit for bit.

    Pairs are computed in chunks of at most ``memory_budget`` bytes of
    working memory (default 1 GiB): a pair needs about
    ``256 · (H + 14) · (W + 14)`` bytes (83 MB at 640x480, 2.1 GB at
    3840x2160), and a budget that does not hold one pair is refused with a
    ``ValueError`` before anything is allocated.

    Never traced by ``torch.compile`` (it runs eagerly inside a compiled
    caller). On a ROCm build of PyTorch, only CPU tensors are taken.
    """
    p0, p1 = _frames("prev", prev), _frames("next", next)
    if p0.shape != p1.shape:
        raise ValueError(
            f"represent_batch: next: shape {tuple(next.shape)} differs from prev's {tuple(prev.shape)}"
        )
    if p0.device != p1.device:
        raise ValueError(f"represent_batch: next: on {p1.device}, prev on {p0.device}; give both on one device")
    _check_device(p0.device, "prev")
    checked = checked_settings("represent_batch", settings)
    if not isinstance(memory_budget, int) or memory_budget < 1:
        raise ValueError(f"represent_batch: memory_budget = {memory_budget!r}; expected a positive number of bytes")
    k = core_constants(checked)
    channels_last = settings.get("layout") is not None and checked["layout"] == "hwc"
    b, h, w = p0.shape
    step = chunk_pairs(h, w, memory_budget)
    rgb = torch.empty((b, 3, h, w), dtype=torch.uint8, device=p0.device)
    parts = []
    with torch.no_grad():
        for start in range(0, b, step):
            stop = min(b, start + step)
            part = _torch_core.represent_pairs(p0[start:stop], p1[start:stop], k, rgb[start:stop], fields)
            parts.append(part)
    if channels_last:
        rgb = rgb.permute(0, 2, 3, 1).contiguous()
    if not fields:
        return rgb
    if len(parts) == 1:
        return rgb, parts[0]
    if b == 0:
        empty = torch.empty((0, 2, h, w), dtype=torch.float32, device=p0.device)
        flat = torch.empty((0, h, w), dtype=torch.float32, device=p0.device)
        return rgb, {"v_c": empty, "v_d": empty.clone(), "m_c": flat, "m_d": flat.clone()}
    return rgb, {name: torch.cat([part[name] for part in parts]) for name in parts[0]}

"""The fixed-point core (``core/src``: ``engine.rs``, ``stages.rs``,
``tail.rs``, ``scale.rs``) in eager PyTorch, on whatever device the frames
are: the same integers, and the same ``float32`` operations in the same
order, so the same bytes and the same ``float32`` fields.

Exact by construction, on the CPU and on CUDA:

- the stages up to ``Dn′`` and the sums ``a, b, c`` are ``int32``/``int64``
  elementwise operations (exact on every device); borders are the SPEC's
  replicate clamp, done once by gathering the frames at clamped indices,
  after which every stage reads shifted views (no padding of intermediate
  fields: the core computes them as if the frame extended without end);
- every ``float32`` value is made by one eager ``add``, ``sub``, ``mul``,
  ``div``, ``where`` or ``to`` at a time, in the core's order (one kernel,
  one IEEE rounding; nothing to fuse inside it), or by :func:`_sqrt`, the
  correctly rounded root (``torch.sqrt`` is not, on the CPU);
- every ``float32`` constant is a tensor on the frames' device, and every
  division goes through :func:`_divide`, whose divisor is a full tensor
  there: CUDA divides by a CPU scalar as ``a * (1 / b)``, and
  ``scalar / tensor`` is ``reciprocal() * scalar`` on every device;
- no convolution, matrix product, fused multiply-add (``addcmul``,
  ``lerp``, ``alpha=``) or ``float32`` sum reduction (which TF32 or a
  reordering would change), and no ``torch.compile``; the per-frame
  extremes are ``amin``/``amax``, exact in any order.

``python/tests/test_torch_core_lint.py`` lints this module's syntax tree
for those operations, ``python/tests/test_represent_batch.py`` compares
its results with the core's, and ``python/bench/gpu_check.py`` does so on
a GPU.
"""

from __future__ import annotations

import math
from typing import Dict, Optional, Tuple

import torch

from ._core_params import CoreConstants

# Rows and columns of clamped input around the frame that the output needs
# (SPEC §6): stages 2-3 reach 2, the smoothing of v_c 2, its divergence 1,
# the structure sums 2.
HALO = 7

# Bytes per pixel of the padded frames ((H + 14) × (W + 14)) of one pair:
# the most memory its tensors take at once, results included, with room to
# spare (the peak measured on the CPU is 175-200, fields included). The
# chunk size of represent_batch is its memory budget over this.
WORKING_BYTES_PER_PIXEL = 256

Margins = Tuple[int, int]


def _f32(value: float, device: torch.device) -> torch.Tensor:
    """A ``float32`` constant on ``device``: ``value`` rounded to
    ``float32`` (each one here is a ``float32`` already, or, ``1e-9``, rounds
    to the same ``float32`` as the core's literal). A fill on the device,
    not a copy from the host (which on CUDA waits for the queue)."""
    return torch.full((), value, dtype=torch.float32, device=device)


def _divide(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """``a / b`` rounded once: both full tensors of one shape on one
    device, so no kernel takes a scalar path (a reciprocal)."""
    if a.shape != b.shape or a.device != b.device or b.dtype != torch.float32:
        raise AssertionError("_divide: operands must be float32 tensors of one shape and device")
    return torch.div(a, b)


def _sqrt(s: torch.Tensor) -> torch.Tensor:
    """``√s`` of non-negative ``float32`` values, correctly rounded (IEEE's
    ``squareRoot``, what the core's ``fpu::sqrt`` is on every target).

    ``torch.sqrt`` is not that on every device: on the CPU it goes through
    MKL's vector math, within one ulp but off by one for about 0.6 % of
    values (CUDA's rounds correctly). So its root ``r`` is corrected by one
    ulp where the exact root lies beyond the midpoint to a neighbour: with
    ``n`` the neighbour, ``√s < (r + n) / 2`` exactly when
    ``4·s < (r + n)²``, and in ``float64`` both sides are exact (``r + n``
    of two adjacent ``float32`` has 25 bits, its square 50). No root lies
    on a midpoint, so this is the correctly rounded root whenever
    ``torch.sqrt`` is within one ulp (checked on every ``float32``:
    ``python/bench/gpu_check.py --cpu-sqrt`` on the CPU, and without the
    flag on CUDA).
    """
    r = torch.sqrt(s)
    # The neighbours of r ≥ 0 by its bits (no neighbour below 0).
    bits = r.view(torch.int32)
    down = (bits - 1).clamp(min=0).view(torch.float32)
    up = (bits + 1).view(torch.float32)
    wide = torch.float64
    s4, r64 = s.to(wide) * 4, r.to(wide)
    low, high = down.to(wide) + r64, up.to(wide) + r64
    r = torch.where(s4 < low * low, down, r)
    return torch.where(s4 > high * high, up, r)


def _tap(t: torch.Tensor, m: Margins, out: Margins, dy: int, dx: int) -> torch.Tensor:
    """The view of ``t`` (a stage on the frame plus margins ``m`` rows and
    columns either side) shifted by ``(dy, dx)``, over the frame plus
    margins ``out``: tap ``(dy, dx)`` of a stencil whose output is ``out``."""
    (my, mx), (oy, ox) = m, out
    h = t.shape[-2] - 2 * my + 2 * oy
    w = t.shape[-1] - 2 * mx + 2 * ox
    y0, x0 = my - oy + dy, mx - ox + dx
    return t[:, y0:y0 + h, x0:x0 + w]


def _binomial(a, b, c, d, e):
    """``[1 4 6 4 1]``: for integers any order is exact; for ``float32``
    the core's order, ``((a + e) + (b + d) · 4) + c · 6`` (``stages.rs``
    ``Sample::binomial``), with ``4`` and ``6`` tensors of ``a``'s kind."""
    if a.dtype == torch.float32:
        four, six = _f32(4.0, a.device), _f32(6.0, a.device)
        return ((a + e) + (b + d) * four) + c * six
    return (a + e) + (b + d) * 4 + c * 6


def _horizontal_binomial(t: torch.Tensor, m: Margins) -> torch.Tensor:
    out = (m[0], m[1] - 2)
    return _binomial(*(_tap(t, m, out, 0, dx) for dx in (-2, -1, 0, 1, 2)))


def _vertical_binomial(t: torch.Tensor, m: Margins) -> torch.Tensor:
    out = (m[0] - 2, m[1])
    return _binomial(*(_tap(t, m, out, dy, 0) for dy in (-2, -1, 0, 1, 2)))


def _smoothed(t: torch.Tensor, m: Margins) -> torch.Tensor:
    """``G256 ⋆ t``: the horizontal binomial, then the vertical (the
    core's order, which the ``float32`` sums depend on)."""
    return _vertical_binomial(_horizontal_binomial(t, m), (m[0], m[1] - 2))


def _boundary_minus_domain(d: torch.Tensor) -> Tuple[torch.Tensor, torch.Tensor]:
    """``E = Kb3 ⋆ d − 3 · Box⋆Sob ⋆ d`` (x, y) with margins 5 from ``d``
    with margins 7 (``stages.rs`` ``vertical_parts_of``,
    ``boundary_minus_domain_x/y``)."""
    m, mid = (HALO, HALO), (HALO - 2, HALO)
    a, b, c, dd, e = (_tap(d, m, mid, dy, 0) for dy in (-2, -1, 0, 1, 2))
    v1 = b + 4 * c + dd
    v2 = (a + e) + 3 * (b + dd) + 4 * c
    v3 = dd - b
    v4 = (dd + e) - (a + b)
    out = (HALO - 2, HALO - 2)

    def taps(v):
        return [_tap(v, mid, out, 0, dx) for dx in (-2, -1, 0, 1, 2)]

    t1, t2, t3, t4 = taps(v1), taps(v2), taps(v3), taps(v4)
    ex = (t1[3] - t1[1]) - 3 * ((t2[3] + t2[4]) - (t2[1] + t2[0]))
    ey = (t3[1] + 4 * t3[2] + t3[3]) - 3 * ((t4[0] + t4[4]) + 3 * (t4[1] + t4[3]) + 4 * t4[2])
    return ex, ey


def _structure(
    p0: torch.Tensor, d: torch.Tensor, k: CoreConstants
) -> Tuple[torch.Tensor, ...]:
    """``V`` (x, y) on the frame, and the sums ``A, B, C`` (``int32``) and
    ``P, Q`` (``float32``) on it, from ``p0`` and ``d`` with margins 7."""
    ex, ey = _boundary_minus_domain(d)
    vx, vy = _smoothed(ex, (5, 5)), _smoothed(ey, (5, 5))
    del ex, ey
    m_v, out = (3, 3), (2, 2)
    q = (_tap(vx, m_v, out, 0, 1) - _tap(vx, m_v, out, 0, -1)) + (
        _tap(vy, m_v, out, 1, 0) - _tap(vy, m_v, out, -1, 0)
    )
    m_p = (HALO, HALO)

    def p(dy, dx):
        return _tap(p0, m_p, out, dy, dx)

    x = (p(-1, 1) - p(-1, -1)) + 2 * (p(0, 1) - p(0, -1)) + (p(1, 1) - p(1, -1))
    y = (p(1, -1) + 2 * p(1, 0) + p(1, 1)) - (p(-1, -1) + 2 * p(-1, 0) + p(-1, 1))
    # Dn = −κ·d − (X·Vx + Y·Vy) − 4·p0·Q exactly in int64 (< 2^42), then
    # Dn′ = ⌊(Dn + 2^(σ−1)) / 2^σ⌋: stages::rounded_residual's value.
    wide = torch.int64
    dn = (
        -k.kappa * _tap(d, m_p, out, 0, 0).to(wide)
        - (x.to(wide) * _tap(vx, m_v, out, 0, 0).to(wide) + y.to(wide) * _tap(vy, m_v, out, 0, 0).to(wide))
        - 4 * p(0, 0).to(wide) * q.to(wide)
    )
    del q
    dn = ((dn + (1 << (k.shift - 1))) >> k.shift).to(torch.int32)
    # Dn′ rounds to 24 bits (from 28 at most); the scaling by 2⁻²⁰ is exact.
    dn = dn.to(torch.float32) * _f32(math.ldexp(1.0, -20), p0.device)
    xf, yf = x.to(torch.float32), y.to(torch.float32)
    products = [x * x, x * y, y * y, xf * dn, yf * dn]
    del dn, xf, yf, x, y
    sums = []
    while products:
        sums.append(_smoothed(products.pop(0), out))
    v = _tap(vx, m_v, (0, 0), 0, 0), _tap(vy, m_v, (0, 0), 0, 0)
    return (*v, *sums)


def _tail(
    vx: torch.Tensor,
    vy: torch.Tensor,
    sums: Tuple[torch.Tensor, ...],
    k: CoreConstants,
    want_fields: bool,
) -> Tuple[torch.Tensor, torch.Tensor, Optional[Dict[str, torch.Tensor]]]:
    """``tail.rs`` ``solve`` and the magnitudes, per pixel, in ``float32``:
    ``|v_d|``, ``|v_c|`` and, when asked, the fields."""
    a, b, c, p, q = sums
    dev = p.device
    f32 = torch.float32
    a4 = (4 * a + k.lambda4).to(f32)
    c4 = (4 * c + k.lambda4).to(f32)
    b4 = (4 * b).to(f32)
    det = a4 * c4 - b4 * b4
    floor = _f32(k.det_floor, dev)
    det = torch.where(det > floor, det, floor)
    n0 = c4 * p - b4 * q
    n1 = a4 * q - b4 * p
    inv = _divide(torch.full_like(det, k.v_d), det)
    m_d = _sqrt(n0 * n0 + n1 * n1) * inv
    unit_c = _f32(k.v_c, dev)
    vxf, vyf = vx.to(f32), vy.to(f32)
    m_c = _sqrt(vxf * vxf + vyf * vyf) * unit_c
    fields = None
    if want_fields:
        fields = {
            "v_c": torch.stack([vxf * unit_c, vyf * unit_c], 1),
            "v_d": torch.stack([n0 * inv, n1 * inv], 1),
            "m_c": m_c,
            "m_d": m_d,
        }
    return m_d, m_c, fields


def _byte(m: torch.Tensor, offset: torch.Tensor, gain: torch.Tensor) -> torch.Tensor:
    """``ByteScale::byte``: ``⌊t⌋`` of ``t = (m − offset) · gain + ½``
    clamped to ``[0, 255]`` (a NaN to 0), each step rounded to ``f32``."""
    dev = m.device
    zero, top = _f32(0.0, dev), _f32(255.0, dev)
    t = (m - offset) * gain + _f32(0.5, dev)
    t = torch.where(t > zero, t, zero)
    t = torch.where(t < top, t, top)
    return t.to(torch.int32).to(torch.uint8)


def _scales(m: torch.Tensor, gain: Optional[float]) -> Tuple[torch.Tensor, torch.Tensor]:
    """``(offset, gain)`` per pair, shaped to broadcast over its pixels:
    a fixed gain, or ``ByteScale::min_max`` of the pair's extremes (a range
    below 1e-9 px maps every magnitude to 0, SPEC §4)."""
    dev = m.device
    if gain is not None:
        return _f32(0.0, dev), _f32(gain, dev)
    low = torch.amin(m, dim=(1, 2), keepdim=True)
    high = torch.amax(m, dim=(1, 2), keepdim=True)
    span = high - low
    steep = _divide(torch.full_like(span, 255.0), span)
    flat = span >= _f32(1e-9, dev)
    return low, torch.where(flat, steep, _f32(0.0, dev))


def clamped_frames(prev: torch.Tensor, next: torch.Tensor) -> Tuple[torch.Tensor, torch.Tensor]:
    """``p0`` and ``d = p1 − p0`` (``int32``) of ``(B, H, W)`` uint8 frames
    on the frame plus ``HALO`` rows and columns either side, read at
    clamped indices (SPEC §2's replicate border; any strides)."""
    h, w = prev.shape[-2:]
    dev = prev.device
    rows = torch.arange(-HALO, h + HALO, device=dev).clamp(0, h - 1)
    cols = torch.arange(-HALO, w + HALO, device=dev).clamp(0, w - 1)

    def padded(f):
        return f.index_select(1, rows).index_select(2, cols).to(torch.int32)

    p0 = padded(prev)
    return p0, padded(next) - p0


def represent_pairs(
    prev: torch.Tensor,
    next: torch.Tensor,
    k: CoreConstants,
    rgb: torch.Tensor,
    want_fields: bool,
) -> Optional[Dict[str, torch.Tensor]]:
    """The representation of ``(B, H, W)`` uint8 pairs into ``rgb``
    (``(B, 3, H, W)`` uint8 on their device), and their ``float32`` fields
    when asked."""
    p0, d = clamped_frames(prev, next)
    vx, vy, *sums = _structure(p0, d, k)
    del p0, d
    m_d, m_c, fields = _tail(vx, vy, tuple(sums), k, want_fields)
    del sums, vx, vy
    gain_d, gain_c = (None, None) if k.gains is None else k.gains
    r = _byte(m_d, *_scales(m_d, gain_d))
    g = _byte(m_c, *_scales(m_c, gain_c))
    if k.variant == "dc0":
        g = torch.zeros_like(g)
    elif k.variant == "cd":
        r, g = g, r
    rgb[:, 0] = r
    rgb[:, 1] = g
    rgb[:, 2] = prev
    return fields

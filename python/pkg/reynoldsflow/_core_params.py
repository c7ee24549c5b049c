"""The fixed-point core's constants for a call's settings, in plain Python
numbers, derived exactly as the core derives them (``core/src/params.rs``,
``core/src/scale.rs``, ``python/src/settings.rs``), so that
``reynoldsflow._torch_core`` computes with the very integers and ``float32``
values the core computes with.

The settings are first checked by the core itself (a 1x1 ``represent``):
whatever it refuses raises its own ``TypeError``/``ValueError`` here, and
what it accepts has the core's meaning.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Optional, Tuple

import numpy

from . import _native

# The worst |X·Vx + Y·Vy| + |4·p0·Q| (params.rs DN_BOUND_WITHOUT_KAPPA).
_DN_BOUND_WITHOUT_KAPPA = 1020 * (2 * 6_854_400 + 16_144_560)

# The keywords of ``reynoldsflow.represent`` that set the computation.
SETTING_KEYS = ("engine", "scale", "intensity_scale", "lam", "tile", "variant", "hsv_max")


@dataclass(frozen=True)
class CoreConstants:
    """What the core's per-pixel path uses: integers, and ``float32``
    values held as the Python floats they are exactly."""

    kappa: int
    """``κ = round(6144 / s)``, the weight of the temporal difference."""
    shift: int
    """``σ``: the residual is summed as ``round(Dn / 2^σ)``."""
    lambda4: int
    """``Λ4 = round(65536 · λ / s²)``."""
    v_c: float
    """Pixels per unit of ``V`` (``f32``)."""
    v_d: float
    """Pixels per unit of ``N / det`` (``f32``)."""
    det_floor: float
    """``Λ4²`` rounded to ``f32`` (the tail's least determinant)."""
    gains: Optional[Tuple[float, float]]
    """``(k_d, k_c)`` as ``f32`` for fixed gains; ``None`` for per-frame min-max."""
    variant: str
    """``"dc"``, ``"dc0"`` or ``"cd"``."""


def _f32(x: Fraction) -> float:
    """``x`` rounded to ``f64`` (correctly: ``Fraction`` divides its
    integers exactly), then to ``f32``: the core's ``(a / b) as f32``."""
    return float(numpy.float32(float(x)))


def _ratio_of_float(x: float) -> Tuple[int, int]:
    """``settings.rs::ratio_of_float``: the first continued-fraction
    convergent ``h / k`` (both below 2^32) whose ``f64`` quotient is ``x``.
    Only called on floats the core has accepted, which have one."""
    h0, h1, k0, k1 = 0, 1, 1, 0
    r = x
    for _ in range(64):
        a = int(r // 1)
        h2, k2 = a * h1 + h0, a * k1 + k0
        if float(Fraction(h2, k2)) == x:
            return h2, k2
        h0, h1, k0, k1 = h1, h2, k1, k2
        r = float(1 / Fraction(r - a))
    raise ValueError(f"intensity_scale: {x} is not a ratio of 32-bit integers")


def _intensity_scale(value: Any) -> Fraction:
    """The exact ``s`` of an ``intensity_scale`` the core accepted."""
    if value is None:
        return Fraction(1, 255)
    if isinstance(value, str):
        num, _, den = value.partition("/")
        return Fraction(num.strip()) / (Fraction(den.strip()) if den else 1)
    if isinstance(value, float):
        return Fraction(*_ratio_of_float(value))
    if isinstance(value, tuple):
        return Fraction(int(value[0]), int(value[1]))
    return Fraction(int(value.numerator), int(value.denominator))


def _gain(k: float) -> float:
    """A fixed gain as the core's Q16.16 (nearest, ties to even), then
    ``f32`` (``ByteScale::fixed``)."""
    return _f32(Fraction(round(Fraction(k) * 65536), 65536))


def _gains(scale: Any) -> Optional[Tuple[float, float]]:
    if scale is None or scale == "minmax":
        return None
    if isinstance(scale, str):
        k_d, k_c = scale[len("fixed:"):].split(",")
        return _gain(float(k_d.strip())), _gain(float(k_c.strip()))
    k_d, k_c = scale
    return _gain(float(k_d)), _gain(float(k_c))


def core_constants(
    *,
    engine: str = "fixed",
    scale: Any = "minmax",
    intensity_scale: Any = None,
    lam: float = 1e-4,
    tile: Optional[Tuple[int, int]] = None,
    variant: str = "dc",
    hsv_max: Optional[float] = None,
) -> CoreConstants:
    """The constants of ``reynoldsflow.represent``'s settings, checked by
    the core first. ``tile`` is checked and has no effect (every tiling
    gives the same bytes). The float64 engine and the ``hsv`` variant are
    refused with a ``ValueError``."""
    one = numpy.zeros((1, 1), numpy.uint8)
    _native.represent(
        one, one, engine=engine, scale=scale, intensity_scale=intensity_scale,
        lam=lam, tile=tile, variant=variant, hsv_max=hsv_max,
    )
    if engine != "fixed":
        raise ValueError(
            f"engine = {engine!r}: only the fixed-point core ('fixed') is exact in tensor "
            "operations; compute the float64 reference with reynoldsflow.represent"
        )
    if variant not in ("dc", "dc0", "cd"):
        raise ValueError(
            f"variant = {variant!r}: represent_batch makes 'dc', 'dc0' and 'cd'; "
            "the colour wheel ('hsv') is reynoldsflow.represent's"
        )
    s = _intensity_scale(intensity_scale)
    num, den = s.numerator, s.denominator
    kappa = (2 * 6144 * den + num) // (2 * num)
    lambda_bits = round(Fraction(float(lam)) * 2**32)
    lambda_den = (num * num) << 16
    lambda4 = (lambda_bits * den * den + lambda_den // 2) // lambda_den
    shift = max(0, (255 * kappa + _DN_BOUND_WITHOUT_KAPPA).bit_length() - 27)
    l4 = numpy.float32(lambda4)
    return CoreConstants(
        kappa=kappa,
        shift=shift,
        lambda4=lambda4,
        v_c=_f32(Fraction(num, 768 * den)),
        v_d=_f32(Fraction(num << (shift + 20), 192 * den)),
        det_floor=float(l4 * l4),
        gains=_gains(scale),
        variant=variant,
    )

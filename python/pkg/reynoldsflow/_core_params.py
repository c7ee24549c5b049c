"""The fixed-point core's constants for a call's settings, in plain Python
numbers, derived exactly as the core derives them (``core/src/params.rs``,
``core/src/scale.rs``, ``python/src/settings.rs``), so that
``reynoldsflow._torch_core`` computes with the very integers and ``float32``
values the core computes with.

The settings are parsed and checked by the one parser of every entry point
(``reynoldsflow.settings``, what ``represent`` runs): whatever it refuses
raises its own ``TypeError``/``ValueError`` here, and what it accepts has
the core's meaning.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Dict, Optional, Tuple

import numpy

from . import _native

# The worst |X·Vx + Y·Vy| + |4·p0·Q| (params.rs DN_BOUND_WITHOUT_KAPPA).
_DN_BOUND_WITHOUT_KAPPA = 1020 * (2 * 6_854_400 + 16_144_560)

# The keywords of ``reynoldsflow.represent`` that set the computation (all
# its settings but the layout of the images).
SETTING_KEYS = tuple(key for key in _native.DEFAULTS if key != "layout")


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


def _gain(k: float) -> float:
    """A fixed gain as the core's Q16.16 (nearest, ties to even), then
    ``f32`` (``ByteScale::fixed``)."""
    return _f32(Fraction(round(Fraction(k) * 65536), 65536))


def _gains(scale: str) -> Optional[Tuple[float, float]]:
    """The gains of a checked ``scale`` (``"minmax"`` or ``"fixed:KD,KC"``,
    each gain the shortest decimal of its ``f64``)."""
    if scale == "minmax":
        return None
    k_d, k_c = scale[len("fixed:"):].split(",")
    return _gain(float(k_d)), _gain(float(k_c))


def checked_settings(function: str, options: Dict[str, Any]) -> Dict[str, Any]:
    """``options`` (``reynoldsflow.represent``'s keywords, ``None`` meaning
    the default) parsed and checked by the one parser of every entry point,
    the one ``represent`` runs (``reynoldsflow.settings``), its errors
    naming ``function``: every setting in its canonical form
    (``intensity_scale`` as ``"num/den"``, ``scale`` as ``"minmax"`` or
    ``"fixed:KD,KC"``, ...)."""
    return _native._settings(function, options)


def core_constants(settings: Dict[str, Any]) -> CoreConstants:
    """The constants of ``settings`` (as :func:`checked_settings` gives
    them). ``tile`` has no effect (every tiling gives the same bytes). The
    float64 engine and the ``hsv`` variant are refused with a
    ``ValueError``."""
    engine, variant = settings["engine"], settings["variant"]
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
    s = Fraction(settings["intensity_scale"])
    num, den = s.numerator, s.denominator
    kappa = (2 * 6144 * den + num) // (2 * num)
    lambda_bits = round(Fraction(float(settings["lam"])) * 2**32)
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
        gains=_gains(settings["scale"]),
        variant=variant,
    )

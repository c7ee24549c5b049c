"""Classical optical flow as a detector's input: OpenCV's dense methods,
each flow coded as an image the way the paper codes flow.

Methods (all OpenCV, on the uint8 frames t and t + 1, flow from t to
t + 1, one OpenCV thread): Farneback (``cv2.calcOpticalFlowFarneback``,
OpenCV's tutorial parameters), DIS (``cv2.DISOpticalFlow``, preset
MEDIUM) and, from opencv-contrib (``cv2.optflow``, PyPI's
``opencv-contrib-python-headless``), TV-L1 (``DualTVL1OpticalFlow``),
DeepFlow and PCAFlow, each with its defaults. A method that raises on a
pair (PCAFlow does where it finds no feature points to track) gives that
pair zero flow.

The coding (``hsv``): the HSV colour wheel of OpenCV's optical-flow
tutorial: hue = the direction of the vector (OpenCV's 0-180 hue for 0-360
degrees, x right, y down), saturation 255, value = the length scaled by
the pair's own min-max to 0-255 (the representation's default scale, so
every motion input is normalised alike), converted to RGB. The same
function codes the representation's ``v_R`` for the ``rf hsv`` input.

Not here: Horn-Schunck and Lucas-Kanade are implemented in this project's
``eval`` crate (Rust) and not reachable from Python; Brox is in OpenCV's
CUDA module only, which PyPI's wheels do not build; the learned methods
need pretrained weights that this harness does not download.
"""

from __future__ import annotations

from typing import Callable

import numpy as np


def _cv2():
    """cv2 with its contrib modules, or an ImportError saying what to install."""
    try:
        import cv2
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("the optical-flow inputs need OpenCV: pip install opencv-contrib-python-headless") from e
    if not hasattr(cv2, "optflow"):
        raise ImportError(
            "the optical-flow inputs need OpenCV's contrib modules (cv2.optflow): "
            "pip install opencv-contrib-python-headless (a plain opencv-python installed after it hides them)"
        )
    cv2.setNumThreads(1)  # the benchmark runs one job per core
    return cv2


def _method(name: str) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """A function (frame t, frame t + 1) -> (H, W, 2) float32 flow."""
    cv2 = _cv2()
    if name == "farneback":
        return lambda a, b: cv2.calcOpticalFlowFarneback(a, b, None, 0.5, 3, 15, 3, 5, 1.2, 0)
    make = {
        "dis": lambda: cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM),
        "tvl1": cv2.optflow.DualTVL1OpticalFlow_create,
        "deepflow": cv2.optflow.createOptFlow_DeepFlow,
        "pcaflow": cv2.optflow.createOptFlow_PCAFlow,
    }[name]
    algo = make()

    def calc(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        try:
            return algo.calc(a, b, None)
        except cv2.error:
            # PCAFlow tracks feature points first and raises where it finds
            # none (a featureless sky): no points, no motion found.
            return np.zeros(a.shape + (2,), np.float32)

    return calc


METHODS = ("farneback", "tvl1", "dis", "deepflow", "pcaflow")


def raw(name: str) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """One method's flow function (frame t, frame t + 1) -> (H, W, 2)
    float32, uncoded (the separability study measures its length)."""
    if name not in METHODS:
        raise ValueError(f"unknown flow method {name!r}; known: {', '.join(METHODS)}")
    return _method(name)


def hsv(flow: np.ndarray) -> np.ndarray:
    """(H, W, 2) flow -> (H, W, 3) uint8 RGB: hue = direction, value = length
    min-max scaled over the image, saturation 255."""
    u = flow[..., 0].astype(np.float64)
    v = flow[..., 1].astype(np.float64)
    mag = np.hypot(u, v)
    mag[~np.isfinite(mag)] = 0.0
    angle = np.degrees(np.arctan2(v, u)) % 360.0
    lo, hi = float(mag.min()), float(mag.max())
    value = (mag - lo) / (hi - lo) * 255.0 if hi > lo else np.zeros_like(mag)
    hsv_img = np.empty(flow.shape[:2] + (3,), np.uint8)
    hsv_img[..., 0] = np.clip(np.rint(np.nan_to_num(angle) / 2.0), 0, 179).astype(np.uint8)
    hsv_img[..., 1] = 255
    hsv_img[..., 2] = np.clip(np.rint(value), 0, 255).astype(np.uint8)
    return _cv2().cvtColor(hsv_img, _cv2().COLOR_HSV2RGB)


def coded(name: str) -> Callable[[np.ndarray], np.ndarray]:
    """The input maker of one method: (T, H, W) uint8 clip -> (T - 1, H, W,
    3) uint8 HSV-coded flow of every pair."""

    def make(frames: np.ndarray) -> np.ndarray:
        flow = _method(name)
        return np.stack([hsv(flow(frames[t], frames[t + 1])) for t in range(len(frames) - 1)])

    return make


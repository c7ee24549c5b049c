"""The paper's detector: YOLO11n from ``ultralytics``, trained from scratch.

The network is built from ultralytics' own model YAML (``yolo11n.yaml``,
one class) with no pretrained weights, and nothing is downloaded: before
ultralytics is imported, ``YOLO_OFFLINE=1`` and ``YOLO_CONFIG_DIR`` point
it at the run's scratch folder, where matplotlib's DejaVu Sans stands in for
the Arial.ttf it would otherwise fetch for its plots (plots are off
anyway); AMP (whose check downloads weights) is off. ultralytics (AGPL-3.0)
is an optional dependency of this benchmark, imported here only, when the
YOLO detector is asked for.

Every input is given as a 3-channel image (inputs.three_channels) written
as PNG in the channel order the network sees. Training uses ultralytics'
defaults (SGD/AdamW chosen by it, mosaic, flips, scale) except the colour
jitter, which is off: the channels of a motion input are measurements, not
colours. Boxes are the drone's exact box; predictions are taken at
confidence >= 0.001, at most 10 per frame, and scored by the benchmark's
metrics (AP50, AP50-95, and the 3 px criterion of the heatmap detector).
"""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path

import numpy as np

from .detector import Training

MAX_DET = 10
CONF = 0.001


def offline(folder: Path) -> None:
    """Settings that keep ultralytics off the network, its configuration in
    folder/ultralytics-config (call before importing it; later calls keep
    the first folder, as ultralytics reads it once)."""
    config = Path(os.environ.setdefault("YOLO_CONFIG_DIR", str(Path(folder) / "ultralytics-config")))
    os.environ["YOLO_OFFLINE"] = "1"
    os.environ.setdefault("YOLO_VERBOSE", "False")
    font_dir = config / "Ultralytics"
    font_dir.mkdir(parents=True, exist_ok=True)
    if not (font_dir / "Arial.ttf").exists():
        import matplotlib

        dejavu = Path(matplotlib.get_data_path()) / "fonts" / "ttf" / "DejaVuSans.ttf"
        shutil.copyfile(dejavu, font_dir / "Arial.ttf")


def imgsz(width: int, height: int) -> int:
    """The smallest multiple of 32 that holds the frame."""
    return -(-max(width, height) // 32) * 32


def _write(folder: Path, data: np.ndarray, centers: np.ndarray, diameters: np.ndarray) -> list:
    """Images and YOLO labels (class cx cy w h, normalised; pixel j spans
    [j, j + 1), so a centre at index x is at x + 0.5) of (N, H, W, 3) uint8
    inputs; the image paths."""
    import cv2

    (folder / "images").mkdir(parents=True)
    (folder / "labels").mkdir(parents=True)
    _, h, w, _ = data.shape
    paths = []
    for i, (img, (x, y), d) in enumerate(zip(data, centers, diameters)):
        path = folder / "images" / f"{i:06d}.png"
        if not cv2.imwrite(str(path), np.ascontiguousarray(img[..., ::-1])):  # cv2 writes BGR
            raise OSError(f"cannot write {path}")
        label = f"0 {(x + 0.5) / w:.6f} {(y + 0.5) / h:.6f} {d / w:.6f} {d / h:.6f}\n" if np.isfinite(x) else ""
        (folder / "labels" / f"{i:06d}.txt").write_text(label)
        paths.append(path)
    return paths


def train_and_detect(train_x: np.ndarray, centers: np.ndarray, diameters: np.ndarray, test_x: np.ndarray, *,
                     seed: int, epochs: int, batch: int, size: int, device: str, scratch: Path):
    """Train YOLO11n on (N, H, W, 3) uint8 inputs with their drones (centre,
    diameter; NaN: none) and detect on the test inputs, in the job's own
    scratch folder (removed after; its parent holds ultralytics'
    configuration). Returns ((frame, score, (D, 4) boxes in pixel-index
    coordinates), Training)."""
    scratch = Path(scratch)
    offline(scratch.parent)
    import torch
    from ultralytics import YOLO

    start = time.perf_counter()
    shutil.rmtree(scratch, ignore_errors=True)
    _write(scratch / "data" / "train", train_x, centers, diameters)
    test_paths = _write(scratch / "data" / "test", test_x, np.full((len(test_x), 2), np.nan), np.zeros(len(test_x)))
    yaml = scratch / "data" / "drone.yaml"
    yaml.write_text(f"path: {scratch / 'data'}\ntrain: train/images\nval: train/images\nnames:\n  0: drone\n")
    torch.manual_seed(seed)
    model = YOLO("yolo11n.yaml")
    losses = []
    model.add_callback("on_train_batch_end", lambda tr: losses.append(float(tr.loss.detach().sum())))
    model.train(data=str(yaml), epochs=epochs, batch=batch, imgsz=size, device=device, workers=0, seed=seed,
                deterministic=True, pretrained=False, amp=False, plots=False, val=False, save=False,
                project=str(scratch / "runs"), name="run", exist_ok=True, verbose=False,
                hsv_h=0.0, hsv_s=0.0, hsv_v=0.0)
    k = max(1, len(losses) // 10)
    trained = Training(len(losses), float(np.mean(losses[:k])) if losses else float("nan"),
                       float(np.mean(losses[-k:])) if losses else float("nan"), time.perf_counter() - start)
    frames, scores, boxes = [], [], []
    for i in range(0, len(test_paths), 64):
        results = model.predict([str(p) for p in test_paths[i : i + 64]], imgsz=size, conf=CONF, max_det=MAX_DET,
                                device=device, verbose=False)
        for j, r in enumerate(results):
            b = r.boxes
            frames.append(np.full(len(b), i + j))
            scores.append(b.conf.cpu().numpy().astype(np.float64))
            boxes.append(b.xyxy.cpu().numpy().astype(np.float64) - 0.5)
    shutil.rmtree(scratch, ignore_errors=True)
    return (np.concatenate(frames).astype(np.int64), np.concatenate(scores), np.concatenate(boxes).reshape(-1, 4)), trained

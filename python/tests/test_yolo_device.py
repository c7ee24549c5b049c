"""python/bench/yolo_device.py, the YOLO11n table for a GPU machine: its
--dry path prints the downstream benchmark's command at the paper's input
size on CUDA for the inputs it names, and every input it names exists."""

import os
import subprocess
import sys
from pathlib import Path

from reynoldsflow.bench.downstream import inputs


def test_dry_prints_the_gpu_command(tmp_path):
    script = Path(os.environ["REYNOLDSFLOW_REPO"]) / "python" / "bench" / "yolo_device.py"
    res = subprocess.run([sys.executable, str(script), "--out", str(tmp_path / "o"), "--dry"],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    line = res.stdout.strip()
    assert "-m reynoldsflow.bench.downstream" in line and "--detectors yolo" in line
    assert "--device cuda" in line and "--imgsz 640" in line
    names = line.split("--inputs ")[1].split()[0].split(",")
    assert "gray" in names and "rf" in names and all(n in inputs.BY_NAME for n in names)
    assert not (tmp_path / "o").exists()

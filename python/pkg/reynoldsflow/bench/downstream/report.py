"""The benchmark's outputs: results.csv (one row per input, seed and test
subset), report.md (tables of mean ± standard deviation over seeds) and
plot.png; every file written atomically (a temporary file in the same
folder, then renamed over the target)."""

from __future__ import annotations

import csv
import io
import math
import os
import tempfile
from pathlib import Path
from typing import Dict, Iterable, List, Sequence

import numpy as np

COLUMNS = (
    "input",
    "seed",
    "subset",
    "located_3px",
    "ap",
    "fp_per_free_frame",
    "drone_frames",
    "free_frames",
    "train_steps",
    "loss_first",
    "loss_last",
    "train_seconds",
)
MAIN_SUBSET = "all"


def atomic_write(path: Path, data: bytes) -> None:
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp's 0600 would outlive the rename
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write_csv(path: Path, rows: Sequence[dict]) -> None:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=COLUMNS, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{r[k]:.6g}" if isinstance(r[k], float) else r[k]) for k in COLUMNS})
    atomic_write(path, buf.getvalue().encode())


def _values(rows, name, subset, key) -> List[float]:
    return [r[key] for r in rows if r["input"] == name and r["subset"] == subset]


def mean_sd(values: Iterable[float], digits: int = 2) -> str:
    """'mean ± sd' over the finite values (sample sd); '(k/n)' appended when
    only k of n are finite; 'n/r' when none is."""
    values = list(values)
    finite = [v for v in values if math.isfinite(v)]
    if not finite:
        return "n/r"
    m = float(np.mean(finite))
    sd = float(np.std(finite, ddof=1)) if len(finite) > 1 else float("nan")
    text = f"{m:.{digits}f} ± {sd:.{digits}f}" if math.isfinite(sd) else f"{m:.{digits}f}"
    if len(finite) < len(values):
        text += f" ({len(finite)}/{len(values)})"
    return text


def main_table(rows: Sequence[dict], inputs: Sequence[str], recall: float) -> List[str]:
    """The headline table (the 'all factors' subset), one row per input."""
    seeds = len({r["seed"] for r in rows})
    lines = [
        f"| input | located ≤ 3 px | AP | FP per drone-free frame at recall {recall:g} |",
        "|---|---:|---:|---:|",
    ]
    for name in inputs:
        lines.append(
            f"| {name} | {mean_sd(_values(rows, name, MAIN_SUBSET, 'located_3px'))} "
            f"| {mean_sd(_values(rows, name, MAIN_SUBSET, 'ap'))} "
            f"| {mean_sd(_values(rows, name, MAIN_SUBSET, 'fp_per_free_frame'))} |"
        )
    lines.append("")
    lines.append(f"Mean ± standard deviation over {seeds} seeds, test subset `{MAIN_SUBSET}` (every factor on).")
    return lines


def factor_table(rows: Sequence[dict], inputs: Sequence[str], subsets: Sequence[str], key: str) -> List[str]:
    lines = ["| input | " + " | ".join(subsets) + " |", "|---|" + "---:|" * len(subsets)]
    for name in inputs:
        lines.append(f"| {name} | " + " | ".join(mean_sd(_values(rows, name, s, key)) for s in subsets) + " |")
    return lines


def training_table(rows: Sequence[dict], inputs: Sequence[str]) -> List[str]:
    lines = ["| input | steps | loss, first tenth | loss, last tenth | seconds per training |", "|---|---:|---:|---:|---:|"]
    for name in inputs:
        per_seed = {r["seed"]: r for r in rows if r["input"] == name}.values()
        lines.append(
            f"| {name} | {sorted({r['train_steps'] for r in per_seed})[0]} "
            f"| {mean_sd([r['loss_first'] for r in per_seed], 3)} "
            f"| {mean_sd([r['loss_last'] for r in per_seed], 3)} "
            f"| {mean_sd([r['train_seconds'] for r in per_seed], 1)} |"
        )
    return lines


def write_report(path: Path, *, rows, inputs, descriptions: Dict[str, str], subsets, contrast_subsets,
                 recall: float, settings: Dict[str, object], seconds: float, command: str) -> str:
    """report.md; returns the main table as printed."""
    table = "\n".join(main_table(rows, inputs, recall))
    out = [
        "# Downstream detection: does ReynoldsFlow help a tiny-drone detector?",
        "",
        f"`{command}` — finished in {seconds:.0f} s.",
        "",
        "Settings: " + ", ".join(f"{k} = {v}" for k, v in settings.items()) + ".",
        "",
        "## All factors on",
        "",
        table,
        "",
        "![located within 3 px](plot.png)",
        "",
        "## Per factor: located within 3 px",
        "",
        "Test subsets: `none` (a plain sky and the drone), each factor alone, `all`.",
        "",
        *factor_table(rows, inputs, subsets, "located_3px"),
        "",
        "## Per factor: AP",
        "",
        *factor_table(rows, inputs, subsets, "ap"),
        "",
        "## By the drone's contrast (subset `all`): located within 3 px",
        "",
        *factor_table(rows, inputs, contrast_subsets, "located_3px"),
        "",
        "## Training (identical budget, crops and seeds for every input)",
        "",
        *training_table(rows, inputs),
        "",
        "## Inputs",
        "",
        "| input | what |",
        "|---|---|",
        *(f"| {n} | {descriptions[n].replace('|', chr(92) + '|')} |" for n in inputs),
        "",
    ]
    atomic_write(path, "\n".join(out).encode())
    return table


def write_plot(path: Path, rows, inputs: Sequence[str], subsets: Sequence[str]) -> None:
    """Left: located within 3 px on subset 'all' per input (mean, bars: sd
    over seeds). Right: the same per test subset, as a heat map."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def mean(name, subset):
        v = [x for x in _values(rows, name, subset, "located_3px") if math.isfinite(x)]
        return (float(np.mean(v)) if v else float("nan")), (float(np.std(v, ddof=1)) if len(v) > 1 else 0.0)

    fig, (a, b) = plt.subplots(1, 2, figsize=(13, 0.42 * len(inputs) + 1.8), gridspec_kw={"width_ratios": [1, 1.6]})
    ms = [mean(n, MAIN_SUBSET) for n in inputs]
    y = np.arange(len(inputs))
    a.barh(y, [m for m, _ in ms], xerr=[s for _, s in ms], color="#4c72b0", capsize=3)
    a.set_yticks(y, inputs)
    a.invert_yaxis()
    a.set_xlim(0, 1)
    a.set_xlabel("located within 3 px (subset 'all')")
    grid = np.array([[mean(n, s)[0] for s in subsets] for n in inputs])
    im = b.imshow(grid, vmin=0, vmax=1, cmap="viridis", aspect="auto")
    b.set_xticks(np.arange(len(subsets)), subsets, rotation=30, ha="right")
    b.set_yticks(y, inputs)
    for i in range(len(inputs)):
        for j in range(len(subsets)):
            if math.isfinite(grid[i, j]):
                b.text(j, i, f"{grid[i, j]:.2f}", ha="center", va="center", fontsize=7,
                       color="white" if grid[i, j] < 0.6 else "black")
    b.set_title("located within 3 px, per test subset")
    fig.colorbar(im, ax=b, fraction=0.03)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    atomic_write(path, buf.getvalue())

"""The benchmark's outputs: results.csv (one row per scene family,
detector, input and seed), intervals.csv (each input's AP and each paired
difference with its bootstrap 95 % interval), report.md (the tables) and
plot.png; every file written atomically (a temporary file in the same
folder, then renamed over the target)."""

from __future__ import annotations

import csv
import io
import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, Iterable, List, Sequence, Tuple

import numpy as np

from . import stats

COLUMNS = (
    "family",
    "detector",
    "input",
    "seed",
    "located_3px",
    "ap",
    "ap50",
    "ap50_95",
    "drone_frames",
    "free_frames",
    "train_steps",
    "loss_first",
    "loss_last",
    "train_seconds",
)
INTERVAL_COLUMNS = ("family", "detector", "metric", "kind", "input", "estimate", "low", "high", "resolved")
# What each detector is scored by in the tables: the heatmap network gives
# points (AP with a hit within 3 px), YOLO boxes (AP at IoU 0.5 and
# 0.5:0.95, as the paper reports).
SCORED = {"heatmap": ("ap",), "yolo": ("ap50", "ap50_95")}
LABELS = {"ap": "AP (3 px)", "ap50": "AP50", "ap50_95": "AP50-95"}
FAMILY_LABELS = {"sky": "generated skies", "real": "real footage"}


@dataclass(frozen=True)
class Results:
    rows: list
    inputs: Sequence[str]
    families: Sequence[str]
    detectors: Sequence[str]
    reference: str  # the input the paired differences start from

    def columns(self) -> List[Tuple[str, str, str]]:
        """(family, detector, metric) of the tables' columns."""
        return [(f, d, m) for f in self.families for d in self.detectors for m in SCORED[d]]


Intervals = Dict[Tuple[str, str, str], Dict[str, Dict[str, stats.Interval]]]


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


def bootstrap(results: Results, recs: dict, reps: int) -> Intervals:
    """Per (family, detector, metric): {"input": {input: Interval},
    "paired": {baseline: reference - baseline}} (stats)."""
    out = {}
    seeds = sorted({r["seed"] for r in results.rows})
    for fam, det, metric in results.columns():
        per = {i: {s: recs[(fam, det, i, s)] for s in seeds} for i in results.inputs}
        values = stats.replicates(per, metric, reps)
        entry = {"input": {i: stats.interval(v) for i, v in values.items()}, "paired": {}}
        if results.reference in values:
            entry["paired"] = stats.paired(values, results.reference, results.inputs)
        out[(fam, det, metric)] = entry
    return out


def write_csv(path: Path, rows: Sequence[dict]) -> None:
    _write_rows(path, COLUMNS, rows)


def write_intervals(path: Path, intervals: Intervals) -> None:
    rows = []
    for (fam, det, metric), entry in intervals.items():
        for kind in ("input", "paired"):
            for name, iv in entry[kind].items():
                rows.append(dict(family=fam, detector=det, metric=metric, kind=kind, input=name,
                                 estimate=iv.estimate, low=iv.low, high=iv.high,
                                 resolved=int(iv.resolved) if kind == "paired" else ""))
    _write_rows(path, INTERVAL_COLUMNS, rows)


def _write_rows(path: Path, columns: Sequence[str], rows: Sequence[dict]) -> None:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=columns, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{r[k]:.6g}" if isinstance(r[k], float) else r[k]) for k in columns})
    atomic_write(path, buf.getvalue().encode())


def cell(iv: stats.Interval, signed: bool = False) -> str:
    """'0.41 [0.30, 0.52]'; 'n/r' when there is no estimate."""
    if not math.isfinite(iv.estimate):
        return "n/r"
    f = "{:+.2f}" if signed else "{:.2f}"
    if not math.isfinite(iv.low):
        return f.format(iv.estimate)
    return f"{f.format(iv.estimate)} [{f.format(iv.low)}, {f.format(iv.high)}]"


def _header(results: Results, first: str) -> List[str]:
    cols = results.columns()
    return [
        f"| {first} | " + " | ".join(f"{FAMILY_LABELS[f]}: {d} {LABELS[m]}" for f, d, m in cols) + " |",
        "|---|" + "---:|" * len(cols),
    ]


def main_table(results: Results, intervals: Intervals) -> List[str]:
    """The headline table: one row per input, one column per (family,
    detector, metric): AP [95 % interval]."""
    lines = _header(results, "input")
    for name in results.inputs:
        lines.append(f"| {name} | " + " | ".join(cell(intervals[c]["input"][name]) for c in results.columns()) + " |")
    return lines


def verdict(iv: stats.Interval) -> str:
    if not math.isfinite(iv.low):
        return "n/r"
    return "beats" if iv.low > 0 else "loses" if iv.high < 0 else "tie"


def paired_table(results: Results, intervals: Intervals) -> List[str]:
    """One row per baseline: reference - baseline [95 % interval] and the
    verdict (beats / loses: the interval excludes 0; tie: it does not)."""
    lines = _header(results, f"{results.reference} − baseline")
    for name in results.inputs:
        if name == results.reference:
            continue
        cells = []
        for c in results.columns():
            iv = intervals[c]["paired"][name]
            cells.append(f"{cell(iv, signed=True)} {verdict(iv)}")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return lines


def summary_lines(results: Results, intervals: Intervals) -> List[str]:
    """Per column: the baselines the reference beats, ties and loses to."""
    out = []
    for c in results.columns():
        fam, det, metric = c
        by = {"beats": [], "tie": [], "loses": [], "n/r": []}
        for name, iv in intervals[c]["paired"].items():
            by[verdict(iv)].append(name)
        out.append(f"- {FAMILY_LABELS[fam]}, {det}, {LABELS[metric]}: `{results.reference}` beats "
                   f"{_names(by['beats'])}; ties {_names(by['tie'])}; loses to {_names(by['loses'])}"
                   + (f"; not resolvable for {_names(by['n/r'])}" if by["n/r"] else "") + ".")
    return out


def _names(names: Sequence[str]) -> str:
    return ", ".join(f"`{n}`" for n in names) if names else "none"


def training_table(results: Results) -> List[str]:
    lines = ["| family | detector | input | steps | loss, first tenth | loss, last tenth | seconds per training |",
             "|---|---|---|---:|---:|---:|---:|"]
    for fam in results.families:
        for det in results.detectors:
            for name in results.inputs:
                rs = [r for r in results.rows if (r["family"], r["detector"], r["input"]) == (fam, det, name)]
                lines.append(
                    f"| {fam} | {det} | {name} | {min(r['train_steps'] for r in rs)} "
                    f"| {mean_sd([r['loss_first'] for r in rs], 3)} | {mean_sd([r['loss_last'] for r in rs], 3)} "
                    f"| {mean_sd([r['train_seconds'] for r in rs], 1)} |"
                )
    return lines


def located_table(results: Results) -> List[str]:
    """Located within 3 px (the strongest detection of a drone frame),
    mean ± sd over seeds, per family and detector."""
    cols = [(f, d) for f in results.families for d in results.detectors]
    lines = ["| input | " + " | ".join(f"{FAMILY_LABELS[f]}: {d}" for f, d in cols) + " |", "|---|" + "---:|" * len(cols)]
    for name in results.inputs:
        cells = [mean_sd([r["located_3px"] for r in results.rows if (r["family"], r["detector"], r["input"]) == (f, d, name)])
                 for f, d in cols]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return lines


def write_report(path: Path, *, results: Results, intervals: Intervals, descriptions: Dict[str, str],
                 settings: Dict[str, object], seconds: float, command: str) -> str:
    """report.md; returns the headline table as printed."""
    seeds = len({r["seed"] for r in results.rows})
    table = "\n".join(main_table(results, intervals))
    clips = sorted({(r["family"], r["drone_frames"], r["free_frames"]) for r in results.rows})
    out = [
        "# Downstream detection: ReynoldsFlow against classical optical flow as a tiny-drone detector's input",
        "",
        f"`{command}` — finished in {seconds:.0f} s.",
        "",
        "Settings: " + ", ".join(f"{k} = {v}" for k, v in settings.items()) + ".",
        "",
        "## AP per input",
        "",
        table,
        "",
        f"Mean over {seeds} seeds of the AP on each seed's test clips; in brackets the bootstrap 95 % interval "
        "(seeds and clips resampled). Test frames per seed (family, drone frames, drone-free frames): "
        + "; ".join(f"{f} {d} + {n}" for f, d, n in clips) + ".",
        "",
        "![AP per input with 95 % intervals](plot.png)",
        "",
        f"## Paired differences: {results.reference} − each baseline",
        "",
        *paired_table(results, intervals),
        "",
        "Over the same seeds and clips; *beats* / *loses*: the 95 % interval excludes 0; *tie*: it does not.",
        "",
        *summary_lines(results, intervals),
        "",
        "## Located within 3 px (the strongest detection of each drone frame)",
        "",
        *located_table(results),
        "",
        "Mean ± standard deviation over seeds.",
        "",
        "## Training (identical data, budget and seeds for every input)",
        "",
        *training_table(results),
        "",
        "## Inputs",
        "",
        "| input | what |",
        "|---|---|",
        *(f"| {n} | {descriptions[n].replace('|', chr(92) + '|')} |" for n in results.inputs),
        "",
    ]
    atomic_write(path, "\n".join(out).encode())
    return table


def write_plot(path: Path, results: Results, intervals: Intervals) -> None:
    """One panel per (family, detector, metric): each input's AP with its
    95 % interval."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = results.columns()
    fig, axes = plt.subplots(1, len(cols), figsize=(3.2 * len(cols) + 1.5, 0.32 * len(results.inputs) + 1.6),
                             squeeze=False, sharey=True)
    y = np.arange(len(results.inputs))
    for ax, c in zip(axes[0], cols):
        ivs = [intervals[c]["input"][n] for n in results.inputs]
        est = np.array([iv.estimate for iv in ivs])
        lo = np.array([iv.estimate - iv.low if math.isfinite(iv.low) else 0 for iv in ivs])
        hi = np.array([iv.high - iv.estimate if math.isfinite(iv.high) else 0 for iv in ivs])
        colors = ["#c44e52" if n == results.reference else "#4c72b0" for n in results.inputs]
        ax.barh(y, np.nan_to_num(est), xerr=[lo, hi], color=colors, capsize=2)
        ax.set_xlim(0, 1)
        ax.set_title(f"{FAMILY_LABELS[c[0]]}\n{c[1]} {LABELS[c[2]]}", fontsize=9)
    axes[0][0].set_yticks(y, results.inputs)
    axes[0][0].invert_yaxis()
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    atomic_write(path, buf.getvalue())
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



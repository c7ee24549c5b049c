"""The study's statistics over clips and seeds (Study) and its outputs:
intervals.csv (every figure with its bootstrap 95 % interval), report.md
(the tables) and plot.png, each written atomically."""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Sequence

import numpy as np

from ..downstream.report import FAMILY_LABELS, atomic_write
from . import channels, measure

REFERENCE = channels.REFERENCE
# Drone-frame bins: (dimension, label, low, high) with low <= value < high.
BINS = (
    [("size", f"{lo}–{lo + 1} px", lo, lo + 1 if lo < 5 else 6.01) for lo in (2, 3, 4, 5)]
    + [("contrast", f"{lo}–{lo + 10}", lo, lo + 10 if lo < 30 else 40.01) for lo in (10, 20, 30)]
    + [("speed", label, lo, hi) for label, lo, hi in
       (("< 0.5 px/frame", 0, 0.5), ("0.5–1", 0.5, 1), ("1–2", 1, 2), ("≥ 2", 2, math.inf))]
)
PD_METRICS = tuple(f"pd@{fa:.0e}" for fa in measure.FAS)
COLUMNS = ("family", "input", "score", "metric", "bin", "estimate", "low", "high", "resolved")


@dataclass
class Study:
    families: Sequence[str]
    inputs: Sequence[str]
    rows: List[dict] = field(default_factory=list)  # every figure (intervals.csv)
    combination: Dict[tuple, str] = field(default_factory=dict)  # (family, input) -> label per seed
    best: Dict[tuple, str] = field(default_factory=dict)  # (family, input) -> channel (by training SCR)
    drone_frames: Dict[str, int] = field(default_factory=dict)
    clips: Dict[str, int] = field(default_factory=dict)

    def get(self, family, inp, score, metric, bin="all") -> dict:
        for r in self.rows:
            if (r["family"], r["input"], r["score"], r["metric"], r["bin"]) == (family, inp, score, metric, bin):
                return r
        raise KeyError((family, inp, score, metric, bin))

    @classmethod
    def of(cls, per_family: list, families: Sequence[str], inputs: Sequence[str], reps: int) -> "Study":
        study = cls(families, inputs)
        for fam, results in zip(families, per_family):
            study._family(fam, results, reps)
        return study

    def _add(self, family, inp, score, metric, values, bin="all", kind="value"):
        est, lo, hi = measure.interval(values)
        resolved = bool(np.isfinite(lo) and (lo > 0 or hi < 0)) if kind == "paired" else ""
        self.rows.append(dict(family=family, input=inp, score=score, metric=metric, bin=bin, estimate=est,
                              low=lo, high=hi, resolved=resolved))

    def _family(self, fam: str, results: list, reps: int) -> None:
        offsets = np.cumsum([0] + [r.clips for r in results])
        groups = [list(range(offsets[k], offsets[k + 1])) for k in range(len(results))]
        n_clips = int(offsets[-1])
        w = measure.resample(groups, reps).astype(np.float64)
        frames = [dict(f, clip=f["clip"] + offsets[k]) for k, r in enumerate(results) for f in r.frames]
        clip = np.array([f["clip"] for f in frames], np.int64)
        self.drone_frames[fam], self.clips[fam] = len(frames), n_clips
        value = {"size": np.array([f["diameter"] for f in frames]),
                 "contrast": np.array([f["contrast"] for f in frames]),
                 "speed": np.array([f["speed"] for f in frames])}
        cat = lambda attr, n: np.concatenate([getattr(r, attr)[n] for r in results])  # noqa: E731
        gray_scr, gray_spread = cat("scr", "gray")[:, 0], cat("spread", "gray")[:, 0]
        pd_reps = {}
        for n in self.inputs:
            names = channels.NAMES[n]
            hist = np.concatenate([r.hist[n] for r in results]).astype(np.float64)  # (clips, C + 1, NBINS)
            target = cat("target", n)
            scr, spread = cat("scr", n), cat("spread", n)
            labels = [r.combination[n][0] for r in results]
            self.combination[(fam, n)] = labels[0] if len(set(labels)) == 1 else "/".join(labels)
            bests = [names[r.best[n]] for r in results]
            best = max(set(bests), key=bests.count)
            self.best[(fam, n)] = best
            for j, score in enumerate(list(names) + ["combination"]):
                bg = w @ hist[:, j, :]
                tg_clip = np.zeros((n_clips, measure.NBINS))
                np.add.at(tg_clip, (clip, target[:, j]), 1)
                pd = measure.pd_at(bg, w @ tg_clip)
                for k, metric in enumerate(PD_METRICS):
                    self._add(fam, n, score, metric, pd[:, k])
                if score == "combination":
                    pd_reps[n] = pd
                    for dim, label, lo, hi in BINS:
                        sel = (value[dim] >= lo) & (value[dim] < hi)
                        tb = np.zeros((n_clips, measure.NBINS))
                        np.add.at(tb, (clip[sel], target[sel, j]), 1)
                        self._add(fam, n, score, "pd@1e-04", measure.pd_at(bg, w @ tb, (1e-4,))[:, 0],
                                  bin=f"{dim} {label}")
                    continue
                self._add(fam, n, score, "scr", measure.weighted_median(scr[:, j], clip, w))
                with np.errstate(divide="ignore", invalid="ignore"):
                    gain = np.where(gray_scr > 0, scr[:, j] / gray_scr, np.nan)
                    bsf = np.where(spread[:, j] > 0, gray_spread / spread[:, j], np.nan)
                self._add(fam, n, score, "scr_gain", measure.weighted_median(gain, clip, w))
                self._add(fam, n, score, "bsf", measure.weighted_median(bsf, clip, w))
            j = list(names).index(best)
            self._add(fam, n, "best", "scr", measure.weighted_median(scr[:, j], clip, w))
            for dim, label, lo, hi in BINS:
                sel = (value[dim] >= lo) & (value[dim] < hi)
                vals = np.where(sel, scr[:, j], np.nan)
                self._add(fam, n, "best", "scr", measure.weighted_median(vals, clip, w), bin=f"{dim} {label}")
        for n in self.inputs:
            if n == REFERENCE:
                continue
            for k, metric in enumerate(PD_METRICS):
                self._add(fam, n, f"{REFERENCE} − input", metric, pd_reps[REFERENCE][:, k] - pd_reps[n][:, k],
                          kind="paired")


def cell(r: dict, signed: bool = False) -> str:
    if not np.isfinite(r["estimate"]):
        return "n/a"
    f = "{:+.2f}" if signed else "{:.2f}"
    if not np.isfinite(r["low"]):
        return f.format(r["estimate"])
    return f"{f.format(r['estimate'])} [{f.format(r['low'])}, {f.format(r['high'])}]"


def verdict(r: dict) -> str:
    if not np.isfinite(r["low"]):
        return "n/r"
    return "beats" if r["low"] > 0 else "loses" if r["high"] < 0 else "tie"


def headline(study: Study) -> List[str]:
    """Pd at Fa 1e-4 of each input's combination, per family."""
    fams = study.families
    lines = ["| input | " + " | ".join(f"{FAMILY_LABELS[f]}: Pd at Fa 1e-4" for f in fams) + " |",
             "|---|" + "---:|" * len(fams)]
    for n in study.inputs:
        lines.append(f"| {n} | " + " | ".join(cell(study.get(f, n, "combination", "pd@1e-04")) for f in fams) + " |")
    return lines


def family_table(study: Study, fam: str) -> List[str]:
    lines = ["| input | channels combined (training) | Pd at 1e-3 | Pd at 1e-4 | Pd at 1e-5 | best channel "
             "(training) | its SCR | its SCR gain over gray | its BSF |", "|---|---|---:|---:|---:|---|---:|---:|---:|"]
    for n in study.inputs:
        best = study.best[(fam, n)]
        pds = " | ".join(cell(study.get(fam, n, "combination", m)) for m in PD_METRICS)
        lines.append(f"| {n} | {study.combination[(fam, n)]} | {pds} | {best} | "
                     + " | ".join(cell(study.get(fam, n, best, m)) for m in ("scr", "scr_gain", "bsf")) + " |")
    return lines


def channel_table(study: Study, fam: str) -> List[str]:
    lines = ["| input: channel | SCR | SCR gain over gray | BSF | Pd at 1e-4 |", "|---|---:|---:|---:|---:|"]
    for n in study.inputs:
        for c in channels.NAMES[n]:
            lines.append(f"| {n}: {c} | " + " | ".join(cell(study.get(fam, n, c, m))
                                                       for m in ("scr", "scr_gain", "bsf", "pd@1e-04")) + " |")
    return lines


def paired_table(study: Study, fam: str) -> List[str]:
    lines = [f"| {REFERENCE} − input | Pd at 1e-3 | Pd at 1e-4 | Pd at 1e-5 |", "|---|---:|---:|---:|"]
    for n in study.inputs:
        if n == REFERENCE:
            continue
        rs = [study.get(fam, n, f"{REFERENCE} − input", m) for m in PD_METRICS]
        lines.append(f"| {n} | " + " | ".join(f"{cell(r, True)} {verdict(r)}" for r in rs) + " |")
    return lines


def bins_table(study: Study, fam: str, dim: str, score: str, metric: str) -> List[str]:
    labels = [label for d, label, _, _ in BINS if d == dim]
    lines = [f"| input | " + " | ".join(f"{dim} {x}" for x in labels) + " |", "|---|" + "---:|" * len(labels)]
    for n in study.inputs:
        lines.append(f"| {n} | " + " | ".join(cell(study.get(fam, n, score, metric, f"{dim} {x}")) for x in labels)
                     + " |")
    return lines


def write(out: Path, study: Study, *, settings: dict, seconds: float, command: str) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    for r in study.rows:
        writer.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    atomic_write(out / "intervals.csv", buf.getvalue().encode())
    head = headline(study)
    md = ["# Separability of a tiny drone: no learning", "", f"Command: `{command}` ({seconds:.0f} s).", "",
          "Settings: " + "; ".join(f"{k} {v}" for k, v in settings.items()) + ".", "",
          "Drone frames measured: " + ", ".join(f"{FAMILY_LABELS[f]} {study.drone_frames[f]} "
                                                f"(in {study.clips[f]} test clips)" for f in study.families) + ".",
          "", measure.__doc__.strip(), "",
          "Each input's channels are combined linearly (on their detection statistics, each scaled by its "
          "spread over the training background): the combination is the channel alone or Fisher's "
          "discriminant, whichever has the higher Pd at Fa 1e-3 on the seed's training clips (fitted there "
          "only). Intervals: bootstrap 95 % over seeds and, within each, test clips; paired differences "
          f"`{REFERENCE}` − input use the same replicates (*beats* / *loses*: the interval excludes 0).", "",
          "## Pd at Fa 1e-4 per pixel (each input's combination)", ""] + head
    for fam in study.families:
        md += ["", f"## {FAMILY_LABELS[fam]}", "", "### Per input", ""] + family_table(study, fam)
        md += ["", "### Paired differences", ""] + paired_table(study, fam)
        for dim in ("size", "contrast", "speed"):
            md += ["", f"### Pd at 1e-4 by drone {dim}", ""] + bins_table(study, fam, dim, "combination", "pd@1e-04")
        md += ["", "### Median SCR of the best channel by drone size", ""] + bins_table(study, fam, "size", "best",
                                                                                          "scr")
        md += ["", "### Every channel", ""] + channel_table(study, fam)
    atomic_write(out / "report.md", ("\n".join(md) + "\n").encode())
    _plot(out / "plot.png", study)
    return "\n".join(head)


def _plot(path: Path, study: Study) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fams = study.families
    fig, axes = plt.subplots(2, len(fams), figsize=(5.5 * len(fams), 0.26 * len(study.inputs) + 6.5), squeeze=False)
    y = np.arange(len(study.inputs))
    sizes = [label for d, label, _, _ in BINS if d == "size"]
    for k, fam in enumerate(fams):
        ax = axes[0][k]
        rs = [study.get(fam, n, "combination", "pd@1e-04") for n in study.inputs]
        est = np.array([r["estimate"] for r in rs])
        err = [np.nan_to_num(est - [r["low"] for r in rs]), np.nan_to_num([r["high"] for r in rs] - est)]
        ax.barh(y, np.nan_to_num(est), xerr=err, capsize=2,
                color=["#c44e52" if n == REFERENCE else "#4c72b0" for n in study.inputs])
        ax.set_yticks(y, study.inputs, fontsize=8)
        ax.invert_yaxis()
        ax.set_xlim(0, 1)
        ax.set_title(f"{FAMILY_LABELS[fam]}: Pd at Fa 1e-4 per pixel", fontsize=9)
        ax = axes[1][k]
        flows = [n for n in study.inputs if n not in ("gray", "diff") and not n.startswith("rf")]
        show = ["gray", "diff"]
        if flows:
            show.append(max(flows, key=lambda n: study.get(fam, n, "combination", "pd@1e-04")["estimate"]))
        show.append(REFERENCE)
        for n in dict.fromkeys(show):
            rs = [study.get(fam, n, "combination", "pd@1e-04", f"size {s}") for s in sizes]
            est = np.array([r["estimate"] for r in rs])
            ax.errorbar(np.arange(len(sizes)) + 0.04 * show.index(n), est, capsize=2, marker="o", label=n,
                        yerr=[np.nan_to_num(est - [r["low"] for r in rs]), np.nan_to_num([r["high"] for r in rs] - est)])
        ax.set_xticks(np.arange(len(sizes)), sizes)
        ax.set_ylim(0, 1)
        ax.set_xlabel("drone diameter")
        ax.set_ylabel("Pd at Fa 1e-4")
        ax.legend(fontsize=8)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    plt.close(fig)
    atomic_write(path, buf.getvalue())

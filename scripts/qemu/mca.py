#!/usr/bin/env python3
"""Modelled cycles of the engine's window on an out-of-order or dual-issue
core (Cortex-A72, A76, M7) with LLVM's scheduling models (`llvm-mca`),
weighted by the instruction counter's window profile (insncount.c
`wprofile=`).

The executed instructions are cut into straight runs (consecutive
addresses, one execution count, no taken exit before the last); each run
that carries instructions is handed to `llvm-mca` as a loop body, and its
steady-state cycles per iteration (`Total Cycles` over the iterations)
times its executions is its share. Runs under `--cover` of the
instructions (the coldest) are charged the covered runs' average cycles
per instruction. A model, not a measurement: llvm-mca assumes every load
hits L1 and every branch is predicted, and a run that is not a loop body
is taken at its throughput, as if repeated.

  mca.py --objdump llvm-objdump --mca llvm-mca --triple aarch64 --mcpu cortex-a72 \\
      ELF WPROFILE PIXELS

Prints `cycles=N cycles_per_px=X insns=N cpi=X mcpu=...`.
"""

import argparse
import re
import subprocess
import sys
from collections import defaultdict

ADDRESS = re.compile(r"(?<![#\w])0x[0-9a-f]+\s*<[^>]*>|(?<![#\w])0x[0-9a-f]+(?=\s*$)")


def disassembly(objdump, elf, mcpu):
    """Sorted [(address, text)] of every instruction."""
    args = [objdump, "-d", "--no-show-raw-insn", elf]
    if mcpu.startswith("cortex-m"):
        args.insert(3, f"--mcpu={mcpu}")
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
    line_re = re.compile(r"^\s*([0-9a-f]+):\s+(\S+)\s*(.*)$")
    insns = []
    for line in out.splitlines():
        m = line_re.match(line)
        if m:
            operands = m.group(3).split("//")[0].split("@")[0].strip()
            # Branch and literal targets become the run's own label: llvm-mca
            # reads no control flow.
            operands = ADDRESS.sub(".Lrun", operands)
            insns.append((int(m.group(1), 16), f"{m.group(2)} {operands}".strip()))
    return insns


def runs(insns, counts):
    """[(executions, [text])] of the straight runs of executed instructions."""
    out, current, last = [], None, None
    for i, (pc, text) in enumerate(insns):
        if pc not in counts:
            current = None
            continue
        count, taken = counts[pc]
        contiguous = current is not None and last is not None and last == i - 1
        if not contiguous or current[0] != count or counts[insns[i - 1][0]][1]:
            current = [count, []]
            out.append(current)
        current[1].append(text)
        last = i
    return out


def mca_cycles(mca, triple, mcpu, body, iterations=100):
    """llvm-mca's cycles per iteration of `body`, or None if it cannot read it."""
    src = ".Lrun:\n" + "\n".join(body) + "\n"
    if triple.startswith("thumb"):
        src = ".syntax unified\n.thumb\n" + src
    r = subprocess.run([mca, f"-mtriple={triple}", f"-mcpu={mcpu}", f"-iterations={iterations}"],
                       input=src, capture_output=True, text=True)
    m = re.search(r"Total Cycles:\s+(\d+)", r.stdout)
    return int(m.group(1)) / iterations if m else None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--objdump", default="llvm-objdump")
    ap.add_argument("--mca", default="llvm-mca")
    ap.add_argument("--triple", required=True)
    ap.add_argument("--mcpu", required=True)
    ap.add_argument("--cover", type=float, default=0.995)
    ap.add_argument("elf")
    ap.add_argument("profile")
    ap.add_argument("pixels", type=int)
    args = ap.parse_args()
    counts = defaultdict(lambda: [0, 0])
    for line in open(args.profile):
        pc, count, taken = line.split()
        counts[int(pc, 16)][0] += int(count)
        counts[int(pc, 16)][1] += int(taken)
    insns = disassembly(args.objdump, args.elf, args.mcpu)
    all_runs = sorted(runs(insns, dict(counts)), key=lambda r: -r[0] * len(r[1]))
    total = sum(c for c, _ in counts.values())
    covered_insns = covered_cycles = 0
    unread = 0
    for count, body in all_runs:
        if covered_insns >= args.cover * total:
            break
        per = mca_cycles(args.mca, args.triple, args.mcpu, body)
        if per is None:
            unread += count * len(body)
            continue
        covered_insns += count * len(body)
        covered_cycles += count * per
    if covered_insns == 0:
        sys.exit("mca.py: llvm-mca read none of the runs")
    cpi = covered_cycles / covered_insns
    cycles = covered_cycles + (total - covered_insns) * cpi
    print(f"cycles={cycles:.0f} cycles_per_px={cycles / args.pixels:.0f} insns={total} "
          f"cpi={cpi:.3f} mcpu={args.mcpu}")
    print(f"  modelled runs: {covered_insns / total:.1%} of the instructions "
          f"({unread / total:.1%} in runs llvm-mca could not read)", file=sys.stderr)


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Instructions and cycles per pixel of each stage of the engine pass as it
ships on x86-64 (scripts/profile-stages runs this).

  profile_stages.py --elf BIN --callgrind CG --pixels N [--baseline CG2]

CG is `valgrind --tool=callgrind --dump-instr=yes` of BIN (one or more
engine passes, the runtime-dispatched AVX2 build); every executed
instruction is attributed to the chain of source functions inlined at its
address (scripts/qemu/profile.py, from the DWARF), so the stages split even
though the build that ships inlines them all into one function.

Cycles are estimated, not measured (this machine's `perf` has no cycle
counter): each basic block's steady-state cycles per execution from
llvm-mca on the CPU LLVM takes this machine for (`-mcpu=native`), times
the block's executions. llvm-mca models the core (ports, latencies,
dependencies) with every load hitting L1, so the figures are the pass's
floor on this core: where the timing is well above them, the time is lost
to memory or front-end stalls the model does not see.
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LLVM = os.path.join(
    subprocess.run(["rustc", "--print", "sysroot"], capture_output=True, text=True, check=True).stdout.strip(),
    "lib", "rustlib",
    re.search(r"host: (\S+)", subprocess.run(["rustc", "-vV"], capture_output=True, text=True, check=True).stdout).group(1),
    "bin")

# Stage rows: (source function under `push`, label, parent) in table order.
STAGES = [
    ("load_row", "`load_row` (p0, d)", None),
    ("boundary_minus_domain", "`boundary_minus_domain` (d → E, E's horizontal G)", None),
    ("smooth", "`smooth` (E's vertical G → V)", None),
    ("structure_row", "`structure_row` (Sobel, `Dn′`, 5 products, horizontal G)", None),
    ("emit", "`emit` (per output row), of which:", None),
    ("structure_sums", "– vertical G of the 5 sums", "emit"),
    ("tail_row", "– tail (`f32` solve, both magnitudes)", "emit"),
    ("row", "– the bytes (`RgbSink`)", "emit"),
]

# The core's AVX2 kernels (`core/src/kernels/avx2.rs`), out-of-line functions of
# their own: (symbol part, their stage keys given the frames inlined there).
KERNELS = [
    ("avx2::horizontal_sums_avx2", lambda frames: ["structure_row"]),
    ("avx2::tail_row_avx2",
     lambda frames: ["emit", "emit/structure_sums" if "block_sums" in frames else "emit/tail_row"]),
]


def callgrind_counts(path, binary):
    """{address: executions} of the instructions of `binary` in a callgrind
    file with --dump-instr=yes (positions `instr line`)."""
    counts = {}
    objects = {}
    current_ob = None
    addr = line = 0
    skip_next = False
    main = os.path.realpath(binary)
    for raw in open(path, encoding="utf-8", errors="replace"):
        raw = raw.rstrip("\n")
        if not raw:
            continue
        head = raw[0]
        if raw.startswith(("ob=", "cob=")):
            # An object's name comes with its first id, in either line.
            m = re.match(r"c?ob=\((\d+)\)(?: (.*))?", raw)
            if m.group(2):
                objects[m.group(1)] = m.group(2)
            if raw.startswith("ob="):
                current_ob = m.group(1)
            continue
        if raw.startswith("calls="):
            skip_next = True
            continue
        if head.isdigit() and not raw.startswith("0x") or head.isalpha():
            continue
        if head in "0+-*":
            parts = raw.split()
            if len(parts) < 3:
                continue
            a, l, cost = parts[0], parts[1], parts[2]
            if a.startswith("0x"):
                addr = int(a, 16)
            elif a[0] in "+-":
                # A relative position is decimal unless it says 0x.
                step = a[1:]
                step = int(step, 16) if step.startswith("0x") else int(step)
                addr += step if a[0] == "+" else -step
            if skip_next:
                skip_next = False
                continue
            name = objects.get(current_ob, "")
            if name and os.path.realpath(name) == main:
                counts[addr] = counts.get(addr, 0) + int(cost)
    return counts


BRANCH = re.compile(r"^(j[a-z]+|call\w*|ret\w*|jmp\w*|ud2|int3|nop\w*)\b")


def disassembly(binary, lo, hi):
    """[(address, AT&T text)] of the instructions in [lo, hi)."""
    out = subprocess.run(
        [os.path.join(LLVM, "llvm-objdump"), "-d", "--no-show-raw-insn",
         f"--start-address={lo:#x}", f"--stop-address={hi:#x}", binary],
        capture_output=True, text=True, check=True).stdout
    insns = []
    for text in out.splitlines():
        m = re.match(r"\s*([0-9a-f]+):\s+(.*)$", text)
        if m:
            insns.append((int(m.group(1), 16), m.group(2).split("#")[0].split("<")[0].strip()))
    return insns


def mca_cycles(lines):
    """Steady-state cycles of one execution of a straight-line block, or
    None when llvm-mca cannot read it."""
    body = [l for l in lines if not BRANCH.match(l)]
    if not body:
        return 0.0
    with tempfile.NamedTemporaryFile("w", suffix=".s", delete=False) as f:
        f.write("\n".join(body) + "\n")
        name = f.name
    try:
        r = subprocess.run(["llvm-mca", "-mcpu=native", "-iterations=200", "-all-views=false", "-summary-view", name],
                           capture_output=True, text=True)
    finally:
        os.unlink(name)
    m = re.search(r"Total Cycles:\s+(\d+)", r.stdout)
    return int(m.group(1)) / 200 if m and r.returncode == 0 else None


def cycle_weights(binary, counts):
    """{address: estimated cycles}: each executed loop (a backward branch
    and the code up to it; innermost first) as llvm-mca's steady state of
    its body times its iterations, spread over its instructions by their
    counts; the straight-line code between loops by block (instructions
    executed equally often, up to a branch) the same way."""
    if not counts:
        return {}
    addresses = sorted(counts)
    insns = disassembly(binary, addresses[0], addresses[-1] + 16)
    index = {a: k for k, (a, _) in enumerate(insns)}
    total = sum(counts.values())
    weights = {}

    def assign(body, executions):
        cycles = None
        if sum(counts.get(a, 0) for a, _ in body) > total * 1e-4:
            cycles = mca_cycles([t for _, t in body])
        work = sum(counts.get(a, 0) for a, _ in body)
        if cycles is None or work == 0:
            for a, _ in body:  # one a cycle where the model cannot say
                weights[a] = float(counts.get(a, 0))
            return
        for a, _ in body:
            weights[a] = cycles * executions * counts.get(a, 0) / work

    loops = []
    for k, (a, text) in enumerate(insns):
        m = re.match(r"^j\w+\s+0x([0-9a-f]+)", text)
        if m and counts.get(a, 0) and int(m.group(1), 16) <= a and int(m.group(1), 16) in index:
            loops.append((k - index[int(m.group(1), 16)], index[int(m.group(1), 16)], k))
    for _, first, last in sorted(loops):
        body = insns[first:last + 1]
        if any(a in weights for a, _ in body):
            continue
        assign(body, counts[insns[last][0]])
    block = []

    def flush():
        if block:
            assign(list(block), counts[block[0][0]])
            block.clear()

    for a, text in insns:
        n = counts.get(a, 0)
        if n == 0 or a in weights or (block and counts[block[0][0]] != n):
            flush()
        if n and a not in weights:
            block.append((a, text))
            if BRANCH.match(text):
                flush()
    flush()
    return weights


def load_profile_module():
    """scripts/qemu/profile.py, whose DWARF walk attributes an address to
    the chain of source functions inlined there."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("profile", os.path.join(ROOT, "scripts", "qemu", "profile.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def stage_sums(binary, weights_list):
    """For each weight map, {stage: weight} by the stage each address is
    inlined in (the source function under `push`, and under `emit` its
    parts, keyed `emit/part`), and the total."""
    import bisect
    profile = load_profile_module()
    funcs = profile.functions(os.path.join(LLVM, "llvm-nm"), binary)
    starts = [f[0] for f in funcs]
    with open(binary, "rb") as f:
        ranges = profile.inlined_ranges(f, ROOT)
    ranges.sort()
    range_starts = [r[0] for r in ranges]
    stage_of, in_pass = {}, set()
    for pc in set().union(*(w.keys() for w in weights_list)):
        i = bisect.bisect_right(starts, pc) - 1
        if i < 0 or pc >= funcs[i][1]:
            continue
        # The pass: the runtime-dispatched function everything is inlined
        # in, and the core's AVX2 kernels it calls out of line.
        kernel = next((keys for name, keys in KERNELS if name in funcs[i][2]), None)
        if "dispatch::" in funcs[i][2] or kernel is not None:
            in_pass.add(pc)
        j = bisect.bisect_right(range_starts, pc)
        frames = [name for _, name in sorted((d, name) for lo, hi, d, name in ranges[max(0, j - 4000):j] if lo <= pc < hi)]
        keys = []
        if kernel is not None:
            keys = kernel(frames)
        elif "push" in frames:
            k = frames.index("push")
            if k + 1 < len(frames):
                # The sums' rings take the products' horizontal G (`store_row`).
                keys.append("structure_row" if frames[k + 1] == "store_row" else frames[k + 1])
                if frames[k + 1] == "emit" and k + 2 < len(frames):
                    # The portable layout's tail starts with the vertical G.
                    part = "structure_sums" if "vertical_binomial" in frames[k + 2:] else frames[k + 2]
                    keys.append("emit/" + part)
        stage_of[pc] = keys
    results = []
    for weights in weights_list:
        sums = {}
        for pc, w in weights.items():
            for key in stage_of.get(pc, []):
                sums[key] = sums.get(key, 0.0) + w
        results.append((sums, sum(w for pc, w in weights.items() if pc in in_pass)))
    return results


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--elf", required=True)
    ap.add_argument("--callgrind", required=True)
    ap.add_argument("--baseline", help="callgrind file of the baseline (SSE2) build's pass")
    ap.add_argument("--pixels", type=int, required=True)
    ap.add_argument("--size", default="")
    args = ap.parse_args()

    counts = callgrind_counts(args.callgrind, args.elf)
    cycles = cycle_weights(args.elf, counts)
    per_pixel = lambda sums: {k: v / args.pixels for k, v in sums.items()}
    (insns, insn_total), (cyc, cycle_total) = stage_sums(args.elf, [counts, cycles])
    insn_nodes, cycle_nodes = per_pixel(insns), per_pixel(cyc)
    insn_total, cycle_total = insn_total / args.pixels, cycle_total / args.pixels
    cpu = re.search(r"Host CPU: (\S+)", subprocess.run(["llc", "--version"], capture_output=True, text=True).stdout)
    cpu = cpu.group(1) if cpu else "native"

    print(f"Per pixel, {args.size}, textured moving pair, host engine strips, the pass that ships")
    print(f"(runtime dispatch: AVX2 here); instructions by callgrind, cycles estimated by llvm-mca -mcpu={cpu}:\n")
    print("| stage | instructions/px | cycles/px (llvm-mca) | share of cycles |")
    print("|---|---:|---:|---:|")
    for key, label, parent in STAGES:
        k = f"{parent}/{key}" if parent else key
        i, c = insn_nodes.get(k, 0.0), cycle_nodes.get(k, 0.0)
        print(f"| {label} | {i:.1f} | {c:.1f} | {100 * c / cycle_total:.1f} % |")
    stage_i = sum(insn_nodes.get(k, 0.0) for k, _, p in STAGES if not p)
    stage_c = sum(cycle_nodes.get(k, 0.0) for k, _, p in STAGES if not p)
    print(f"| ring bookkeeping, calls | {insn_total - stage_i:.1f} | {cycle_total - stage_c:.1f} | "
          f"{100 * (cycle_total - stage_c) / cycle_total:.1f} % |")
    print(f"| **engine pass** | **{insn_total:.1f}** | **{cycle_total:.1f}** | 100 % |")
    if args.baseline:
        (_, base), = stage_sums(args.elf, [callgrind_counts(args.baseline, args.elf)])
        print(f"\nThe same pass compiled for the baseline (SSE2): {base / args.pixels:.1f} instructions/px.")


if __name__ == "__main__":
    main()

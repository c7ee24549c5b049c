#!/usr/bin/env python3
"""Modelled cycles of the engine's window on a Cortex-M4F or M33, from the
instruction counter's window profile (insncount.c `wprofile=`: every address
executed between the markers, its executions and its taken exits).

Each executed instruction is classed from the ELF's disassembly and given
the cycles of the Cortex-M4 Technical Reference Manual's instruction timings
(r0p1: the instruction table, 3.3.1, its load/store pairing rules, 3.3.2,
and the FPU's table); the M33 is given the same (no published M33
timings were found).
scripts/qemu/validate.py checks the model against the TRM's worked
examples and tables (docs/PERFORMANCE.md, "Validation of the cycle model").

  class                          cycles
  ALU, shifts, DSP (SADD16...)   1
  MUL, MLA, MLS, SMULL/UMULL,    1
    SMLAL/UMLAL
  SDIV, UDIV                     12 (2 to 12: the worst case)
  LDR* (one register)            2; 1 right after a single load whose
                                    result is not its address (pipelined)
  STR* (one register), immediate 1 ("always one cycle")
    offset
  STR* with a register offset    2; 1 right after a single load
  LDRD/STRD                      3
  LDM/STM/PUSH/POP of N regs     1 + N
  VLDR/VSTR                      2; 1 after another single load or store
  VLDM/VSTM/VPUSH/VPOP of N regs 1 + N
  VMLA/VMLS/VFMA/VFMS/VNMLA...   3
  VDIV, VSQRT                    14
  other VFP (VADD, VMUL, VCVT,   1
    VMOV, VCMP, VMRS, ...)
  IT                             1 (not folded)
  branch, not taken              1
  every taken exit (branches,    + P = 2 (the pipeline refill, 1 to 3:
    POP {pc}, BX, calls)            the middle), + the flash wait states
  a load or store whose address  + 1 (no forwarding path to the address
    register the instruction        generation)
    before wrote (data processing)

"Right after" and "the instruction before" hold for the executions that
fell through from the previous address (its executions less its taken
exits); the others entered by a branch and pair with nothing.

Flash wait states (`--flash-ws`): 0 for code in RAM or hits of a flash
accelerator (the STM32 ART); with N, every taken exit and every literal
load (PC-relative LDR) waits N more cycles for its line (sequential fetches
are taken as hidden by the prefetch buffer). A model, not a measurement:
no bus contention, no FPU register dependencies (the M4's VFP pipelines
back-to-back operations), no interrupts.

  cycles.py --objdump llvm-objdump [--mcpu cortex-m4] [--nm llvm-nm [--parts [--min P]]]
            ELF WPROFILE PIXELS [--flash-ws N]

Prints `cycles=N cycles_per_px=X insns=N cpi=X`, and to stderr the cycles
by class, by function (`--nm`) and by inlined source function (`--parts`:
the tree of scripts/qemu/profile.py, whose DWARF walk needs pyelftools).
"""

import argparse
import bisect
import os
import re
import subprocess
import sys
from collections import defaultdict

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from symbols import functions  # noqa: E402

BRANCH_REFILL = 2

MEMORY_SINGLE = re.compile(r"^(ldr|str|vldr|vstr)(b|h|sb|sh|ex|exb|exh|t|bt|ht)?$")


def disassembly(objdump, elf, mcpu):
    """{address: (mnemonic, operands)} of every instruction."""
    out = subprocess.run([objdump, "-d", "--no-show-raw-insn", f"--mcpu={mcpu}", elf],
                         check=True, capture_output=True, text=True).stdout
    insns = {}
    line_re = re.compile(r"^\s*([0-9a-f]+):\s+(\S+)\s*(.*)$")
    for line in out.splitlines():
        m = line_re.match(line)
        if m:
            operands = m.group(3).split("@")[0].split("//")[0].strip()
            insns[int(m.group(1), 16)] = (m.group(2).lower(), operands)
    return insns


def base(mnemonic):
    """The mnemonic without width qualifiers, data types and condition."""
    name = mnemonic.split(".")[0]
    return name


CONDITIONS = ("eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc",
              "hi", "ls", "ge", "lt", "gt", "le", "al")


def registers(operands):
    """Registers in a register list `{r4, r5, ...}` (ranges counted)."""
    m = re.search(r"\{([^}]*)\}", operands)
    if not m:
        return 0
    n = 0
    for part in m.group(1).split(","):
        part = part.strip()
        r = re.match(r"([rsd])(\d+)\s*-\s*[rsd](\d+)", part)
        if r:
            n += int(r.group(3)) - int(r.group(2)) + 1
            if r.group(1) == "d":
                n += int(r.group(3)) - int(r.group(2)) + 1
        elif part:
            n += 2 if part.startswith("d") else 1
    return n


def classify(mnemonic, operands):
    """(class, cycles before the taken-exit penalty, is a single load/store)."""
    name = base(mnemonic)
    # Conditional forms of branches: bne, bne.w, ...
    if name in ("b", "bl", "blx", "bx", "cbz", "cbnz") or (
            name.startswith("b") and name[1:] in CONDITIONS):
        return "branch", 1, False
    if name in ("tbb", "tbh"):
        return "branch", 2, False
    if name in ("push", "pop", "vpush", "vpop") or re.match(r"^v?(ldm|stm)", name):
        return "ldm/stm", 1 + registers(operands), False
    if name in ("ldrd", "strd"):
        return "load/store", 3, False
    if MEMORY_SINGLE.match(name):
        literal = "pc" in operands.split(",", 1)[-1]
        return ("literal" if literal else "load/store"), 2, True
    if name in ("vdiv", "vsqrt"):
        return "vdiv/vsqrt", 14, False
    if name in ("vmla", "vmls", "vnmla", "vnmls", "vfma", "vfms", "vfnma", "vfnms"):
        return "vfp mac", 3, False
    if name.startswith("v"):
        return "vfp", 1, False
    if name in ("sdiv", "udiv"):
        return "divide", 12, False
    if name in ("mul", "mla", "mls", "muls", "smull", "umull", "smlal", "umlal") or name.startswith("smla") \
            or name.startswith("smul") or name.startswith("smlal"):
        return "multiply", 1, False
    if name.startswith("it"):
        return "it", 1, False
    return "alu", 1, False


REGISTER = re.compile(r"\b(r\d{1,2}|sp|lr|pc|ip|fp|sb|sl)\b")
NO_DESTINATION = ("cmp", "cmn", "tst", "teq", "nop", "msr", "dmb", "dsb", "isb", "bkpt", "svc", "cpsid", "cpsie")
MEMORY = ("load/store", "literal", "ldm/stm")


def address_registers(mnemonic, operands):
    """Core registers an instruction's address is made from."""
    name = base(mnemonic)
    m = re.search(r"\[([^\]]*)\]", operands)
    if m:
        return set(REGISTER.findall(m.group(1)))
    if name in ("push", "pop", "vpush", "vpop"):
        return {"sp"}
    if re.match(r"^v?(ldm|stm)", name):
        return set(REGISTER.findall(operands.split(",")[0]))
    return set()


def written(mnemonic, operands, cls):
    """Core registers a data-processing instruction writes."""
    name = base(mnemonic)
    if cls not in ("alu", "multiply", "divide") or name in NO_DESTINATION or name.startswith("it"):
        return set()
    regs = REGISTER.findall(operands)
    if name in ("smull", "umull", "smlal", "umlal") or name.startswith("smlal"):
        return set(regs[:2])
    return set(regs[:1])


def loaded(mnemonic, operands):
    """The register a single load writes: its first operand."""
    regs = REGISTER.findall(operands.split("[")[0])
    return set(regs[:1])


def single_cycles(mnemonic, operands, before):
    """Cycles of a single load or store (LDR*, STR*, VLDR, VSTR) after the
    instruction `before` ((mnemonic, operands) it fell through from, or
    None): the TRM's pairing rules (3.3.2)."""
    name = base(mnemonic)
    fp = name.startswith("v")
    store = name.startswith("str") or name.startswith("vstr")
    address = address_registers(mnemonic, operands)
    if store and not fp and len(address) == 1:
        return 1  # STR Rx,[Ry,#imm] is always one cycle
    if before is None:
        return 2
    b_name = base(before[0])
    b_single = bool(MEMORY_SINGLE.match(b_name))
    if fp:
        return 1 if b_single else 2
    b_load = b_single and (b_name.startswith("ldr") or b_name.startswith("vldr"))
    if b_load and not loaded(*before) & address:
        return 1
    return 2


def function_of(funcs, starts, pc):
    i = bisect.bisect_right(starts, pc) - 1
    if i >= 0 and funcs[i][0] <= pc < funcs[i][1]:
        # Rust's hash suffix says nothing to a reader.
        return re.sub(r"::h[0-9a-f]{16}$", "", funcs[i][2])
    return "?"


def model(insns, profile, flash_ws, funcs=None):
    counts = defaultdict(lambda: [0, 0])
    for line in open(profile):
        pc, count, taken = line.split()
        entry = counts[int(pc, 16)]
        entry[0] += int(count)
        entry[1] += int(taken)
    by_class = defaultdict(lambda: [0, 0])  # class -> [instructions, cycles]
    by_function = defaultdict(lambda: [0, 0])
    by_pc = {}  # pc -> [instructions, cycles]
    starts = [f[0] for f in funcs or []]
    total_insns = total_cycles = 0
    addresses = sorted(insns)
    previous = {a: b for b, a in zip(addresses, addresses[1:])}
    for pc, (count, taken) in counts.items():
        if pc not in insns:
            sys.exit(f"cycles.py: {pc:#x} executed but not in the disassembly")
        mnemonic, operands = insns[pc]
        if mnemonic.startswith("<unknown"):
            sys.exit(f"cycles.py: {pc:#x} executed but not decoded (--mcpu?)")
        cls, cycles, single = classify(mnemonic, operands)
        # The executions that fell through from the previous address (its
        # executions less its taken exits) follow it: they pair with it.
        # The others entered by a branch and pair with nothing.
        before = previous.get(pc)
        follow = 0
        if before is not None and before in counts:
            b_count, b_taken = counts[before]
            follow = max(0, min(count, b_count - b_taken))
        b_insn = insns[before] if follow else None
        alone = after = cycles
        if single:
            alone = single_cycles(mnemonic, operands, None)
            after = single_cycles(mnemonic, operands, b_insn) if b_insn else alone
        if b_insn and cls in MEMORY and written(*b_insn, classify(*b_insn)[0]) \
                & address_registers(mnemonic, operands):
            after += 1  # its address waits for the register bank
        c = follow * after + (count - follow) * alone + taken * (BRANCH_REFILL + flash_ws)
        if cls == "literal":
            c += count * flash_ws
        by_class[cls][0] += count
        by_class[cls][1] += c
        if funcs:
            f = by_function[function_of(funcs, starts, pc)]
            f[0] += count
            f[1] += c
        by_pc[pc] = [count, c]
        total_insns += count
        total_cycles += c
    return total_insns, total_cycles, by_class, by_function, by_pc


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--objdump", default="llvm-objdump")
    ap.add_argument("--flash-ws", type=int, default=0)
    ap.add_argument("--nm", help="llvm-nm: also the cycles by function")
    ap.add_argument("--mcpu", default="cortex-m4", help="the core, for the disassembler")
    ap.add_argument("--parts", action="store_true",
                    help="with --nm: also the instructions and cycles by function and inlined source "
                         "function (profile.py's tree; needs pyelftools)")
    ap.add_argument("--root", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."),
                    help="--parts: repository root, under which the project's functions are declared")
    ap.add_argument("--min", type=float, default=1.0, help="--parts: hide nodes below this percent of the cycles")
    ap.add_argument("elf")
    ap.add_argument("profile")
    ap.add_argument("pixels", type=int)
    args = ap.parse_args()
    funcs = functions(args.nm, args.elf) if args.nm else None
    insns, cycles, by_class, by_function, by_pc = model(
        disassembly(args.objdump, args.elf, args.mcpu), args.profile, args.flash_ws, funcs)
    if insns == 0:
        sys.exit("cycles.py: empty window profile")
    print(f"cycles={cycles} cycles_per_px={cycles / args.pixels:.0f} insns={insns} "
          f"cpi={cycles / insns:.3f} flash_ws={args.flash_ws}")
    for cls, (n, c) in sorted(by_class.items(), key=lambda kv: -kv[1][1]):
        print(f"  {cls:12s} {n / args.pixels:8.1f} insns/px {c / args.pixels:8.1f} cycles/px",
              file=sys.stderr)
    for name, (n, c) in sorted(by_function.items(), key=lambda kv: -kv[1][1]):
        if c >= 0.005 * cycles:
            print(f"  {n / args.pixels:8.1f} insns/px {c / args.pixels:8.1f} cycles/px  {name}",
                  file=sys.stderr)
    if args.parts and args.nm:
        from profile import attribution, show_tree, tree_of
        tree, totals = tree_of(by_pc, attribution(args.nm, args.elf, args.root))
        print(f"  insns/px cycles/px (share of the cycles) by function and inlined source function "
              f"(nodes under {args.min}% hidden):", file=sys.stderr)
        show_tree(tree, totals, args.pixels, args.min, share=1, out=sys.stderr)


if __name__ == "__main__":
    main()

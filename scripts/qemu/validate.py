#!/usr/bin/env python3
"""Validates the Cortex-M4/M33 cycle model (cycles.py) against the cycle
counts the Cortex-M4 Technical Reference Manual publishes for short
instruction sequences: its load/store pairing examples and rules, and its
instruction and FPU tables.

Builds validate/loops.S for the M4F (mps2-an386) and the M33 (mps2-an505),
runs every sequence N times under QEMU with the instruction counter
(insncount.c, the window between <test>_start and <test>_stop), models the
window with cycles.py and prints, per sequence, the published cycles, the
modelled cycles on each board and the error. Exits 1 where a modelled
figure lies outside the published one (or its published range).

  validate.py --plugin libinsncount.so --objdump llvm-objdump [--out DIR] [--markdown]
"""

import argparse
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from cycles import disassembly, model  # noqa: E402

N = 100  # loops.S's repetitions of every sequence

# Where the published figures are. The TI manual reproduces the Cortex-M4
# TRM's sections (its processor is a Cortex-M4F).
SOURCES = {
    "LS": "Cortex-M4 TRM r0p1 (Arm DDI 0439B) 3.3.2 \"Load/store timings\"; reproduced in TI SWCU192, "
          "https://ti.com/document-viewer/lit/html/SWCU192/GUID-43FDD803-0838-46E1-A6C0-28C71F822F9C.html",
    "T": "Cortex-M4 TRM r0p1 Table 3-1 (the Cortex-M4F instruction cycle counts); TI SWCU192 Table 3-25, "
         "https://ti.com/document-viewer/lit/html/SWCU192/GUID-86361CC6-93E0-4EA8-90CF-AF757C93D80D",
    "FPU": "Cortex-M4 TRM r0p1 FPU instruction set table; TI SWCU192 Table 3-27, "
           "https://www.ti.com/document-viewer/ja-jp/lit/html/SWCU192/GUID-D95473EB-E5C1-45ED-93D0-B6EB1B58EEB2",
}

# test, sequence, published cycles (low, high), source, how the figure is made
TESTS = [
    ("ldr_ldr", "LDR R0,[R1]; LDR R1,[R2]", (3, 3), "LS", "worked example"),
    ("ldr_str_imm", "LDR R0,[R1,R2]; STR R0,[R3,#20]", (3, 3), "LS", "worked example"),
    ("ldr_str_reg", "LDR R0,[R1,R2]; STR R1,[R3,R2]", (3, 3), "LS", "worked example"),
    ("ldr_ldr_ldr", "LDR R0,[R1,R5]; LDR R1,[R2]; LDR R2,[R3,#4]", (4, 4), "LS", "worked example"),
    ("ldr_chain", "LDR R1,[R1]; LDR R0,[R1]", (4, 4), "LS", "2 + 2: address from the first LDR"),
    ("str_imm", "STR R0,[R1,#4]", (1, 1), "LS", "\"always one cycle\""),
    ("str_ldr", "STR R0,[R1,#4]; LDR R2,[R3]", (3, 3), "LS", "1 + 2: nothing pipelines after a store"),
    ("alu_ldr", "ADD R1,R2,#4; LDR R0,[R1]", (4, 4), "LS", "1 + 2 + 1: address from the ADD"),
    ("ldrd", "LDRD R4,R5,[R1]", (3, 3), "LS", "three cycles"),
    ("ldm3", "LDM R1,{R4-R6}", (4, 4), "T", "1 + N"),
    ("stm8", "STM R1,{R2-R9}", (9, 9), "T", "1 + N"),
    ("mul_smlal", "MUL; SMLAL", (2, 2), "T", "1 + 1"),
    ("mla_mls", "MLA; MLS", (2, 2), "T", "1 + 1"),
    ("branch", "B (taken)", (2, 4), "T", "1 + P, P = 1 to 3"),
    ("mac_loop", "4 x (LDR; LDR; MLA; SUBS; BNE)", (27, 33), "T", "4 x (2+1+1+1+1) + 3P"),
    ("vadd_vmul", "VADD.F32; VMUL.F32", (2, 2), "FPU", "1 + 1"),
    ("vmla", "VMLA.F32", (3, 3), "FPU", "3"),
    ("vdiv", "VDIV.F32", (14, 14), "FPU", "14"),
    ("vsqrt", "VSQRT.F32", (14, 14), "FPU", "14"),
    ("vldr_vldr", "VLDR; VLDR", (3, 3), "FPU", "2 + 1 (pipelined as LDR)"),
    ("vldm4", "VLDM R1,{S0-S3}", (5, 5), "FPU", "1 + N"),
]

# QEMU machine: (cpu, FPU, code address, RAM address)
BOARDS = {
    "mps2-an386": ("cortex-m4", "fpv4-sp-d16", 0x00000000, 0x20000000),
    "mps2-an505": ("cortex-m33", "fpv5-sp-d16", 0x10000000, 0x38000000),
}


def build(board, out):
    cpu, fpu, code, ram = BOARDS[board]
    elf = os.path.join(out, f"loops-{board}.elf")
    subprocess.run(["arm-none-eabi-gcc", f"-mcpu={cpu}", "-mthumb", "-mfloat-abi=hard", f"-mfpu={fpu}",
                    "-nostdlib", f"-DRAM={ram:#x}", f"-Wl,-Ttext={code:#x}", "-Wl,-e,reset",
                    "-o", elf, os.path.join(HERE, "validate", "loops.S")], check=True)
    return elf


def symbols(elf):
    out = subprocess.run(["readelf", "-sW", elf], check=True, capture_output=True, text=True).stdout
    syms = {}
    for line in out.splitlines():
        f = line.split()
        if len(f) >= 8 and re.fullmatch(r"[0-9a-f]{8}", f[1]):
            syms.setdefault(f[7], int(f[1], 16))
    return syms


def modelled(board, elf, plugin, objdump, out):
    """{test: modelled cycles of one pass of its sequence}"""
    cpu = BOARDS[board][0]
    syms = symbols(elf)
    insns = disassembly(objdump, elf, cpu)
    cycles = {}
    for test, *_ in TESTS:
        wprofile = os.path.join(out, f"wprofile-{board}-{test}.txt")
        run = subprocess.run(
            ["qemu-system-arm", "-machine", board, "-cpu", cpu, "-nographic", "-monitor", "none",
             "-serial", "none", "-semihosting-config", "enable=on,target=native", "-icount", "shift=0",
             "-plugin", f"{plugin},start={syms[test + '_start']:#x},stop={syms[test + '_stop']:#x},"
                        f"wprofile={wprofile}",
             "-kernel", elf], capture_output=True, text=True, timeout=60)
        if run.returncode != 0:
            sys.exit(f"validate.py: {board} exited with {run.returncode}: {run.stderr}")
        _, c, *_ = model(insns, wprofile, 0)
        cycles[test] = c / N
    return cycles


def error(value, low, high):
    """Percent off the published figure: 0 inside a published range,
    else off its nearest end."""
    if value < low:
        return 100 * (value - low) / low
    if value > high:
        return 100 * (value - high) / high
    return 0.0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--plugin", required=True, help="libinsncount.so (build-plugin.sh)")
    ap.add_argument("--objdump", default="llvm-objdump")
    ap.add_argument("--out", default="target/validate-model")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    results = {board: modelled(board, build(board, args.out), args.plugin, args.objdump, args.out)
               for board in BOARDS}
    print("| sequence | published cycles | source | modelled, M4F | modelled, M33 | error |")
    print("|---|---:|---|---:|---:|---:|")
    bad = 0
    errors = []
    for test, sequence, (low, high), source, how in TESTS:
        m4, m33 = results["mps2-an386"][test], results["mps2-an505"][test]
        e = max((error(m, low, high) for m in (m4, m33)), key=abs)
        errors.append(abs(e))
        published = f"{low}" if low == high else f"{low}-{high}"
        print(f"| `{sequence}` | {published} ({how}) | {source} | {m4:g} | {m33:g} | {e:+.0f} % |")
        bad += e != 0
    print(f"\nsequences: {len(TESTS)}; outside the published figure: {bad}; "
          f"mean |error| {sum(errors) / len(errors):.1f} %, largest {max(errors):.0f} %")
    for key, text in SOURCES.items():
        print(f"{key}: {text}")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Panic-path check: walk the call graph of a firmware ELF from an entry symbol.

Reads `llvm-objdump -d -C -l` output, follows every direct call or branch
(`bl`, `b.w`, `jal`, `j`, `call`, `tail`, conditional branches, ...) whose
target is another function, transitively, and fails if a panic-family
function is reachable. Indirect calls cannot be followed, so any in a
reachable function also fail the check. Prints what it found:

  - every panic call site reached: the caller chain of functions from the
    entry and the source line of the call (code inlined into one function
    shows up as that function plus the line);
  - the code size of everything reachable (`--size-out`), which is what
    the entry costs in flash, core functions and compiler builtins alike.

  callgraph.py --objdump DIR/llvm-objdump --nm DIR/llvm-nm ELF ENTRY
               [--stop SYMBOL]... [--callback-in FUNCTION]...
               [--expect-panic-in FUNCTION] [--size-out FILE]

`--stop` names functions the walk does not enter (the harness boundary).
`--callback-in F` allows the indirect calls of functions whose name contains
F: where the harness boundary is a caller's function pointer (the C API's
row callback), which the walk cannot enter anyway.
`--expect-panic-in F` inverts the verdict: the walk from the entry must
find a panic call in function F (a deliberately panicking canary, so a
check that cannot fail is caught). Exit status 0 means the verdict held.
"""

import argparse
import os
import re
import subprocess
import sys
from collections import deque

# Demangled names of the functions that lead to the panic handler.
PANIC = re.compile(
    r"core::panicking::|panic_bounds_check|slice_(start_|end_)?index_.*fail|"
    r"slice_index_order_fail|str_index_overflow_fail|len_mismatch_fail|"
    r"unwrap_failed|expect_failed|assert_failed|panic_const|panic_fmt|"
    r"rust_begin_unwind|core::option::unwrap|core::result::unwrap|"
    r"\bpanic\b|panic_nounwind|panic_in_cleanup|abort"
)
HEADER = re.compile(r"^([0-9a-f]+) <(.*)>:$")
INSN = re.compile(r"^\s*([0-9a-f]+):\s+(\S+)\s*(.*)$")
TARGET = re.compile(r"\s<(.*)>\s*(?:@.*)?$")
OFFSET = re.compile(r"\+0x[0-9a-f]+$")
LINE = re.compile(r"^; (/.*:\d+)$")
# Mnemonics that transfer control (Arm Thumb and RISC-V).
BRANCH = re.compile(
    r"^(bl|blx|b|bx|cb|cbn|b[a-z]{2}|b\.w|b[a-z]{2}\.w|b\.n|b[a-z]{2}\.n|cbz|cbnz|"
    r"jal|jalr|j|jr|call|tail|beq|bne|blt|bge|bltu|bgeu|beqz|bnez|blez|bgez|bltz|bgtz|"
    r"bgt|ble|bgtu|bleu|c\.j|c\.jal|c\.beqz|c\.bnez)$"
)
# Indirect: register targets. `bx lr` / `ret` / `jr ra` are returns.
INDIRECT_ARM = re.compile(r"^(blx|bx)$")
INDIRECT_RV = re.compile(r"^(jalr|jr|c\.jalr|c\.jr)$")


def disassemble(objdump, elf):
    """{function: {"calls": [(target, address, line)], "indirect": [(address, text, line)],
    "jumps": [(address, target address, line)], "insns": [(address, mnemonic)]}}"""
    out = subprocess.run(
        [objdump, "-d", "-C", "-l", "--no-show-raw-insn", elf],
        check=True, capture_output=True, text=True,
    ).stdout
    funcs, current, line = {}, None, "?"
    for raw in out.splitlines():
        m = HEADER.match(raw)
        if m:
            current = m.group(2)
            funcs[current] = {"calls": [], "indirect": [], "jumps": [], "insns": []}
            line = "?"
            continue
        m = LINE.match(raw)
        if m:
            line = m.group(1)
            continue
        if current is None:
            continue
        m = INSN.match(raw)
        if not m:
            continue
        addr, mnemonic, operands = m.groups()
        funcs[current]["insns"].append((int(addr, 16), mnemonic))
        if not BRANCH.match(mnemonic):
            continue
        t = TARGET.search(operands)
        if t:
            target = OFFSET.sub("", t.group(1))
            if target != current:
                funcs[current]["calls"].append((target, addr, line))
            else:
                to = re.search(r"(?:0x)?([0-9a-f]+) <", operands)
                if to:
                    funcs[current]["jumps"].append((int(addr, 16), int(to.group(1), 16), line))
            continue
        ops = operands.replace(" ", "")
        returns = ops in ("lr", "ra", "zero,0(ra)")
        if (INDIRECT_ARM.match(mnemonic) or INDIRECT_RV.match(mnemonic)) and not returns:
            funcs[current]["indirect"].append((addr, f"{mnemonic} {operands}", line))
    return funcs


def branch_sites(func, call_addr):
    """Branches in `func` into the cold block that ends in the call at
    `call_addr`: the block starts after the previous control transfer."""
    insns = func["insns"]
    idx = next(i for i, (a, _) in enumerate(insns) if a == call_addr)
    start = call_addr
    for a, mnemonic in reversed(insns[:idx]):
        if BRANCH.match(mnemonic) or mnemonic in ("ret", "pop", "pop.w", "udf", "unimp"):
            break
        start = a
    return [(a, line) for a, to, line in func["jumps"] if start <= to <= call_addr]


def inline_chains(elf, root):
    """pc -> [function names, outermost first] from DWARF (pyelftools), or None."""
    try:
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        import profile as prof  # scripts/qemu/profile.py
        with open(elf, "rb") as f:
            ranges = prof.inlined_ranges(f, root)
    except Exception:  # pyelftools missing: source lines only
        return None

    def at(pc):
        return [name for _, name in sorted((d, n) for lo, hi, d, n in ranges if lo <= pc < hi)]
    return at


def sizes(nm, elf):
    """{function: bytes} from the symbol table."""
    out = subprocess.run(
        [nm, "-C", "-S", "--defined-only", elf], check=True, capture_output=True, text=True
    ).stdout
    result = {}
    for raw in out.splitlines():
        parts = raw.split(" ", 3)
        if len(parts) == 4 and parts[2] in "tTwW":
            result[parts[3]] = max(result.get(parts[3], 0), int(parts[1], 16))
    return result


def walk(funcs, entry, stops):
    """Breadth-first from `entry`: parent links give the shortest caller chain."""
    parent = {entry: None}
    queue = deque([entry])
    while queue:
        f = queue.popleft()
        if f in stops or PANIC.search(f):
            continue
        for target, _, _ in funcs.get(f, {}).get("calls", []):
            if target not in parent:
                parent[target] = f
                queue.append(target)
    return parent


def chain(parent, f):
    names = []
    while f is not None:
        names.append(f)
        f = parent[f]
    return " -> ".join(reversed(names))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--objdump", required=True)
    ap.add_argument("--nm", required=True)
    ap.add_argument("--stop", action="append", default=[])
    ap.add_argument("--callback-in", action="append", default=[])
    ap.add_argument("--expect-panic-in", metavar="FUNCTION")
    ap.add_argument("--size-out")
    ap.add_argument("elf")
    ap.add_argument("entry")
    args = ap.parse_args()

    funcs = disassemble(args.objdump, args.elf)
    if args.entry not in funcs:
        print(f"callgraph: entry {args.entry} not found in {args.elf}", file=sys.stderr)
        return 2
    stops = set(args.stop)
    parent = walk(funcs, args.entry, stops)
    reached = [f for f in parent if f not in stops]

    panic_sites = []
    for f in reached:
        if PANIC.search(f):
            continue
        for target, addr, line in funcs.get(f, {}).get("calls", []):
            if PANIC.search(target):
                panic_sites.append((f, target, addr, line))
    indirect = [(f, *site) for f in reached for site in funcs.get(f, {}).get("indirect", [])
                if not any(c in f for c in args.callback_in)]

    size_of = sizes(args.nm, args.elf)
    code = sum(size_of.get(f, 0) for f in reached if not PANIC.search(f))
    if args.size_out:
        with open(args.size_out, "w") as out:
            out.write(f"{code}\n")

    print(f"entry {args.entry}: {len(reached)} functions reachable "
          f"(not entering {', '.join(sorted(stops)) or 'nothing'}), {code} bytes of code, "
          f"{len(panic_sites)} panic call sites, {len(indirect)} indirect calls")
    for f in sorted(reached, key=lambda f: -size_of.get(f, 0)):
        if not PANIC.search(f):
            print(f"  {size_of.get(f, 0):6d}  {f}")
    chains = inline_chains(args.elf, os.path.realpath(os.path.join(os.path.dirname(__file__), "..", ".."))) \
        if panic_sites else None
    for f, target, addr, line in panic_sites:
        print(f"  PANIC {target}\n        called at 0x{addr} ({line})\n        chain: {chain(parent, f)}")
        for at, jline in branch_sites(funcs[f], int(addr, 16)):
            inlined = " -> ".join(chains(at)) if chains else ""
            print(f"        from branch at 0x{at:x} ({jline}){': ' + inlined if inlined else ''}")
    for f, addr, text, line in indirect:
        print(f"  INDIRECT {text} at 0x{addr} ({line}) in {chain(parent, f)}")

    bad = bool(panic_sites) or bool(indirect)
    if args.expect_panic_in:
        found = [site for site in panic_sites if site[0] == args.expect_panic_in]
        print(f"expected a panic path from {args.entry} through {args.expect_panic_in}: "
              f"{'found: ' + chain(parent, args.expect_panic_in) + ' -> ' + found[0][1] if found else 'NOT FOUND'}")
        return 0 if found else 1
    print(f"panic-free from {args.entry}: {'no' if bad else 'yes'}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

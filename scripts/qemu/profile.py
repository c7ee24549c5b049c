#!/usr/bin/env python3
"""Per-stage instruction breakdown from the insncount plugin's `profile=` file.

Every executed address is attributed to its function (symbol table) and to
the chain of project functions (declared under the repository root) inlined
at that address (DWARF inlined-subroutine ranges; frames from Rust's library,
such as array `map` or integer helpers, count toward the project frame that
used them), so
code the optimiser merged into one function still splits into the source
functions it came from. Prints that tree, each node with its instructions per
output pixel (inlined code included) and share of all executed instructions,
hiding nodes under `--min` percent.

  profile.py --nm llvm-nm ELF PROFILE PIXELS [--min 1.0]

Needs pyelftools (scripts/install-embedded installs it into scripts/py-tools'
environment: run it with that python).
"""

import argparse
import bisect
import os
import sys
from collections import defaultdict

from elftools.elf.elffile import ELFFile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from symbols import functions  # noqa: E402


def origin(die):
    """The DIE that names an inlined subroutine (through its abstract origin)."""
    for attr in ("DW_AT_abstract_origin", "DW_AT_specification"):
        if attr in die.attributes:
            return origin(die.get_DIE_from_attribute(attr))
    return die


def short(name):
    """`push<334, firmware::RgbRows>` -> `push`: generics make the tree unreadable."""
    depth, out = 0, []
    for ch in name:
        depth += ch == "<"
        if depth == 0:
            out.append(ch)
        depth -= ch == ">"
    return "".join(out) or name


def declared_in_project(dwarf, cu, die, root, cache):
    """Whether the function's source file lies under the repository `root`."""
    index = die.attributes.get("DW_AT_decl_file")
    if index is None:
        return False
    key = (cu.cu_offset, index.value)
    if key not in cache:
        lp = dwarf.line_program_for_CU(cu)
        files, dirs = lp["file_entry"], lp["include_directory"]
        comp_dir = cu.get_top_DIE().attributes.get("DW_AT_comp_dir")
        comp_dir = comp_dir.value.decode() if comp_dir else ""
        # DWARF 5 numbers files and directories from 0 (directory 0 is the
        # compilation directory); earlier versions from 1, with 0 meaning it.
        base = 0 if lp.header.version >= 5 else 1
        i = index.value - base
        path = ""
        if 0 <= i < len(files):
            d = files[i].dir_index - base
            directory = dirs[d].decode() if 0 <= d < len(dirs) else comp_dir
            path = os.path.join(comp_dir, directory, files[i].name.decode())
        cache[key] = os.path.normpath(path).startswith(root + os.sep)
    return cache[key]


def die_ranges(dwarf, cu, die):
    attrs = die.attributes
    if "DW_AT_low_pc" in attrs and "DW_AT_high_pc" in attrs:
        lo = attrs["DW_AT_low_pc"].value
        hi = attrs["DW_AT_high_pc"]
        return [(lo, hi.value if hi.form == "DW_FORM_addr" else lo + hi.value)]
    if "DW_AT_ranges" not in attrs:
        return []
    lists = dwarf.range_lists()
    if lists is None:
        return []
    attr = attrs["DW_AT_ranges"]
    if attr.form == "DW_FORM_rnglistx":
        entries = lists.get_range_list_at_offset_ex(
            lists.get_range_list_offset_from_index(cu, attr.value) if hasattr(
                lists, "get_range_list_offset_from_index") else attr.value)
    else:
        entries = lists.get_range_list_at_offset(attr.value, cu=cu)
    top = cu.get_top_DIE().attributes.get("DW_AT_low_pc")
    base = top.value if top else 0
    result = []
    for e in entries:
        if hasattr(e, "base_address"):
            base = e.base_address
        elif hasattr(e, "begin_offset"):
            absolute = getattr(e, "is_absolute", False)
            lo = e.begin_offset if absolute else base + e.begin_offset
            hi = e.end_offset if absolute else base + e.end_offset
            result.append((lo, hi))
    return result


def inlined_ranges(elf, root):
    """[(lo, hi, depth, name)] of every inlined project subroutine."""
    dwarf = ELFFile(elf).get_dwarf_info()
    result, cache = [], {}
    for cu in dwarf.iter_CUs():
        def visit(die, depth):
            for child in die.iter_children():
                d = depth
                if child.tag == "DW_TAG_inlined_subroutine":
                    d = depth + 1
                    named = origin(child)
                    if declared_in_project(dwarf, cu, named, root, cache):
                        name = named.attributes.get("DW_AT_name")
                        name = short(name.value.decode()) if name else "?"
                        for lo, hi in die_ranges(dwarf, cu, child):
                            result.append((lo, hi, d, name))
                visit(child, d)
        visit(cu.get_top_DIE(), 0)
    return result


def attribution(nm, elf, root):
    """A function from an executed address to its path: (function, the
    project functions inlined there, outermost first), or None outside
    every function."""
    funcs = functions(nm, elf)
    starts = [f[0] for f in funcs]
    with open(elf, "rb") as f:
        ranges = inlined_ranges(f, os.path.realpath(root))
    # Only ranges that hold executed addresses matter: index them by start.
    ranges.sort()
    range_starts = [r[0] for r in ranges]

    def path_of(pc):
        i = bisect.bisect_right(starts, pc) - 1
        if i < 0 or pc >= funcs[i][1]:
            return None
        func = short(funcs[i][2])
        # Inlined frames containing pc: ranges start at or before pc.
        j = bisect.bisect_right(range_starts, pc)
        frames = sorted((d, name) for lo, hi, d, name in ranges[max(0, j - 4000):j] if lo <= pc < hi)
        return (func,) + tuple(name for _, name in frames)
    return path_of


def tree_of(weights, path_of):
    """{path prefix: [sum of each weight column]} over `weights`
    ({pc: [w, ...]}), and the columns' totals."""
    tree = defaultdict(lambda: None)
    width = len(next(iter(weights.values()), []))
    totals = [0] * width
    for pc, ws in weights.items():
        path = path_of(pc)
        if path is None:
            continue
        for k in range(1, len(path) + 1):
            node = tree[path[:k]]
            if node is None:
                node = tree[path[:k]] = [0] * width
            for c, w in enumerate(ws):
                node[c] += w
        for c, w in enumerate(ws):
            totals[c] += w
    return tree, totals


def show_tree(tree, totals, pixels, minimum, share=0, out=sys.stdout):
    """The tree, each node's columns per pixel and its share of column
    `share`'s total, nodes under `minimum` percent of it hidden."""
    def show(prefix, depth):
        children = sorted((p for p in tree if len(p) == len(prefix) + 1 and p[:len(prefix)] == prefix),
                          key=lambda p: -tree[p][share])
        for p in children:
            pct = 100.0 * tree[p][share] / totals[share]
            if pct < minimum:
                continue
            cells = "".join(f"{v / pixels:8.1f}" for v in tree[p])
            print(f"{'  ' * depth}{cells}  {pct:5.1f}%  {p[-1]}", file=out)
            show(p, depth + 1)
    show((), 0)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--nm", required=True)
    ap.add_argument("--root", default=os.path.join(os.path.dirname(__file__), "..", ".."),
                    help="repository root: functions declared under it are the project's")
    ap.add_argument("--min", type=float, default=1.0, help="hide nodes below this percent")
    ap.add_argument("elf")
    ap.add_argument("profile")
    ap.add_argument("pixels", type=int)
    args = ap.parse_args()

    counts = {}
    with open(args.profile) as f:
        for line in f:
            pc, n = line.split()
            counts[int(pc, 16)] = [int(n)]
    tree, [total] = tree_of(counts, attribution(args.nm, args.elf, args.root))

    print(f"instructions per output pixel by function and inlined source function "
          f"(all code executed, {total / args.pixels:.1f}/px; nodes under {args.min}% hidden):")
    show_tree(tree, [total], args.pixels, args.min)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The code symbols of an ELF file, as the QEMU profiles and the cycle
model name the functions their counts fall in (llvm-nm, no DWARF)."""

import subprocess


def functions(nm, elf):
    """Sorted [(start, end, demangled name)] of the code symbols."""
    out = subprocess.run([nm, "-C", "-S", "--defined-only", elf],
                         check=True, capture_output=True, text=True).stdout
    funcs = []
    for raw in out.splitlines():
        parts = raw.split(" ", 3)
        if len(parts) == 4 and parts[2] in "tTwW":
            start = int(parts[0], 16) & ~1  # Thumb bit
            funcs.append((start, start + int(parts[1], 16), parts[3]))
    return sorted(funcs)

#!/usr/bin/env bash
# Cargo runner for bare-metal ELFs under QEMU with semihosting.
#   runner = "scripts/qemu/qemu-run.sh qemu-system-arm -machine mps2-an386 -cpu cortex-m4 --"
# Cargo appends: <elf> [args...]. Exit status = guest's semihosting exit status.
# - ELF with a .defmt section: stdout is piped through `defmt-print -e <elf>`.
# - QEMU_INSNS=1: load the insncount TCG plugin; counts insns between the
#   bench_start/bench_stop symbols (printed to stderr as "insncount: ... window=N").
#   The plugin is QEMU_INSNS_PLUGIN, default target/qemu/libinsncount.so at
#   the repository root (scripts/embedded-check builds it with build-plugin.sh).
#   QEMU_INSNS_PROFILE=FILE also writes per-instruction counts there;
#   QEMU_INSNS_WPROFILE=FILE the window's counts and taken exits
#   (scripts/qemu/cycles.py).
set -euo pipefail
qemu=()
while [ "$1" != "--" ]; do qemu+=("$1"); shift; done
shift
elf=$1; shift
qemu+=(-nographic -monitor none -serial none -semihosting-config enable=on,target=native)
if [ -n "${QEMU_INSNS:-}" ]; then
  plugin=${QEMU_INSNS_PLUGIN:-$(dirname "$0")/../../target/qemu/libinsncount.so}
  sym() { readelf -sW "$elf" | awk -v n="$1" '$8==n && !f {print "0x"$2; f=1}'; }
  qemu+=(-icount shift=0 -plugin "$plugin,start=$(sym bench_start),stop=$(sym bench_stop)${QEMU_INSNS_PROFILE:+,profile=$QEMU_INSNS_PROFILE}${QEMU_INSNS_WPROFILE:+,wprofile=$QEMU_INSNS_WPROFILE}")
fi
if readelf -SW "$elf" | grep -c '\.defmt' >/dev/null; then   # not grep -q: SIGPIPE + pipefail
  "${qemu[@]}" -kernel "$elf" "$@" | defmt-print -e "$elf"
else
  exec "${qemu[@]}" -kernel "$elf" "$@"
fi

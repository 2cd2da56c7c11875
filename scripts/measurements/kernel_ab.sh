#!/usr/bin/env bash
# Kernel A/B on a noisy machine: runs each sphaptics binary with --profile-kernels on one scene,
# ROUNDS rounds, the binaries' order rotated each round, and prints per kernel the minimum and the
# median wall ms per step of each binary, and the median over the rounds of the kernel's time divided
# by a reference kernel's in the same run (REF, default dfsph_pressure_accel: choose one that no
# binary changes). This VM's speed drifts by 10-15 % within minutes (docs/dfsph.md, sessions 52-53);
# the ratio cancels most of that drift (identical binaries then agree within ~3 %).
# Writes CSV to stdout after the table: binary,run,kernel,ms_per_step,ratio_to_ref
#   scripts/measurements/kernel_ab.sh ROUNDS DURATION BIN_A BIN_B [BIN_C ...]
# Environment: SCENE (default scenes/peer/dam_break_50k.yaml), SETS (default "--set fluid.dfsph.cfl=0.8"),
# REF (default dfsph_pressure_accel), TOP (rows of the table, default 16).
set -euo pipefail
[ $# -ge 4 ] || { echo "usage: $0 ROUNDS DURATION BIN_A BIN_B [BIN_C ...]" >&2; exit 2; }
rounds=$1; dur=$2; shift 2
bins=("$@"); nb=${#bins[@]}
top=$(cd "$(dirname "$0")/../.." && pwd)
scene=${SCENE:-$top/scenes/peer/dam_break_50k.yaml}
sets=${SETS:---set fluid.dfsph.cfl=0.8}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for r in $(seq 1 "$rounds"); do
  for o in $(seq 0 $((nb - 1))); do
    k=$(((o + r) % nb))
    # shellcheck disable=SC2086
    "${bins[$k]}" run "$scene" -o "$work/out" --duration "$dur" --profile-kernels $sets > "$work/log" 2>&1 ||
      { echo "run failed: ${bins[$k]} (round $r)" >&2; tail -n 3 "$work/log" >&2; exit 1; }
    grep '^kernels (wall' "$work/log" > "$work/prof_${k}_$r.txt"
  done
done
python3 - "$work" "$rounds" "${REF:-dfsph_pressure_accel}" "${TOP:-16}" "${bins[@]}" <<'PY'
import re, statistics, sys
work, rounds, ref, top, bins = sys.argv[1], int(sys.argv[2]), sys.argv[3], int(sys.argv[4]), sys.argv[5:]
runs = []  # per binary: list of {kernel: ms per step}
for k in range(len(bins)):
    rs = []
    for r in range(1, rounds + 1):
        text = open(f"{work}/prof_{k}_{r}.txt").read().split(":", 1)[1]
        one = {}
        for part in text.split(";"):
            m = re.match(r"\s*(\S+) ([0-9.]+)", part)
            if m: one[m.group(1)] = float(m.group(2))
        rs.append(one)
    runs.append(rs)
names = list(runs[0][0].keys())[:top]
print("kernel (wall ms/step: min / median per binary; then the median ratio to %s)" % ref)
for i, b in enumerate(bins): print("  [%d] %s" % (i, b))
for n in names:
    cells = "".join("%8.2f/%6.2f" % (min(o.get(n, 0) for o in rs), statistics.median(o.get(n, 0) for o in rs)) for rs in runs)
    ratios = "".join("%7.3f" % statistics.median(o.get(n, 0) / o[ref] for o in rs) if all(ref in o for o in rs) else "   n/a"
                     for rs in runs)
    print("%-28s%s   ratio:%s" % (n, cells, ratios))
print("binary,run,kernel,ms_per_step,ratio_to_ref")
for i, rs in enumerate(runs):
    for r, o in enumerate(rs, 1):
        for n, v in o.items():
            print("%s,%d,%s,%.3f,%s" % (bins[i], r, n, v, "%.4f" % (v / o[ref]) if ref in o and o[ref] > 0 else ""))
PY

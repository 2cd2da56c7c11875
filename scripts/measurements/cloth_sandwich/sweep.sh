#!/usr/bin/env bash
# Session 17 (issue 14): the sealed-sheet column, scenes/tests/dfsph_cloth_sandwich.yaml, with DFSPH at
# several largest steps and both cloth couplings. Prints per run: coupling, max_time_step, exit code
# (4 = the flow blew up), steps, the cloth's largest kinetic energy and its largest over the last 0.2 s
# (unit: J; cloth.csv). The free fall through the 1.5 cm gap bounds the first by m g d = 7.4e-3 J.
#   scripts/measurements/cloth_sandwich/sweep.sh [DURATION] [OUT_DIR]
set -uo pipefail
top=$(cd "$(dirname "$0")/../../.." && pwd)
sph=${SPHAPTICS:-$top/build/cli/sphaptics}
duration=${1:-1.0}
out=${2:-$(mktemp -d)}
mkdir -p "$out"
for coupling in staggered strong; do
  for step in 0.001 0.002 0.003 0.005; do
    dir="$out/${coupling}_$step"
    "$sph" run "$top/scenes/tests/dfsph_cloth_sandwich.yaml" --set simulation.duration="$duration" \
      --set fluid.dfsph.max_time_step="$step" --set fluid.dfsph.cloth_coupling="$coupling" -o "$dir" --quiet > "$dir.log" 2>&1
    rc=$?
    steps=$(grep -o '"steps": *[0-9]*' "$dir/run.json" 2>/dev/null | grep -o '[0-9]*$')
    awk -F, -v c="$coupling" -v s="$step" -v rc="$rc" -v n="${steps:-?}" -v d="$duration" '
      /^#/ || $1 == "time" { next }
      { if ($3 > m) m = $3; if ($1 > d - 0.2 + 1e-9 && $3 > l) l = $3 }
      END { printf "%-9s max_time_step %s rc=%d steps %s  KE largest %.3g J  last 0.2 s %.3g J\n", c, s, rc, n, m, l }' "$dir/cloth.csv"
  done
done

#!/usr/bin/env bash
# Session 22 (docs/dfsph.md): the settle before t = 0 (simulation.settle_time) on the hydrostatic tank
# (scenes/tests/hydrostatic.yaml, 0.2 m of water at dx = 1 cm) with gravity on from t = 0: for each
# solver, settle time and damping, the largest change of the probes p02, p05, p08 between consecutive
# steps in windows after t = 0, the bottom probe's range there, and the settle's steps and wall time.
# Prints a table and writes OUT/settle_tank.csv.
#   scripts/measurements/settle/tank.sh [OUT_DIR] ["SOLVER:SETTLE:DAMPING" ...]
# Default variants: the table of docs/dfsph.md, session 22.
set -uo pipefail
top=$(cd "$(dirname "$0")/../../.." && pwd)
sph=${SPHAPTICS:-$top/build/cli/sphaptics}
out=${1:-$(mktemp -d)}
shift || true
variants=("$@")
[ ${#variants[@]} -gt 0 ] || variants=(dfsph:0:0.2 dfsph:0.5:0.2 dfsph:0.8:0.2 dfsph:1.0:0.05 dfsph:1.0:0.2 dfsph:1.0:0.5
                                     dfsph:1.5:0.2 wcsph:0:0.2 wcsph:0.5:0.2 wcsph:1.0:0.2)
mkdir -p "$out"
csv="$out/settle_tank.csv"
echo "solver,settle_s,damping_s,settle_steps,settle_wall_s,window_s,max_step_change_Pa,p02_min_Pa,p02_max_Pa" > "$csv"
for v in "${variants[@]}"; do
  IFS=: read -r solver settle damping <<< "$v"
  dir="$out/${solver}_${settle}_${damping}"
  "$sph" run "$top/scenes/tests/hydrostatic.yaml" --set fluid.solver="$solver" --set simulation.gravity_ramp=0 \
    --set simulation.settle_time="$settle" --set simulation.settle_damping="$damping" --set probes.rate=1000 \
    --set output.particles=false --duration 1.5 -o "$dir" --quiet > "$dir.log" 2>&1
  rc=$?
  if [ $rc -ne 0 ]; then echo "$v: exit $rc (see $dir.log)"; continue; fi
  steps=$(grep -o '"settle": {"steps": *[0-9]*' "$dir/run.json" | grep -o '[0-9]*$')
  wall=$(grep -o '"settle": {[^}]*' "$dir/run.json" | grep -o '"wall_seconds": *[0-9.e+-]*' | grep -o '[0-9.e+-]*$')
  awk -F, -v pre="$solver,$settle,$damping,$steps,$wall" '
    /^#/ { next }
    $1 == "time" { for (c = 1; c <= NF; ++c) { if ($c == "p02_pressure") a = c; if ($c == "p05_pressure") b = c; if ($c == "p08_pressure") e = c } next }
    { n = split("0 0.1 0.25 0.5 0.75 1.0 1.5", w, " ")
      for (k = 1; k < n; ++k) if ($1 >= w[k] && $1 < w[k + 1]) {
        if (have) for (q = 1; q <= 3; ++q) { col = q == 1 ? a : (q == 2 ? b : e); d = $col - last[q]; if (d < 0) d = -d; if (d > mx[k]) mx[k] = d }
        if (!(k in lo) || $a < lo[k]) lo[k] = $a
        if (!(k in hi) || $a > hi[k]) hi[k] = $a }
      last[1] = $a; last[2] = $b; last[3] = $e; have = 1 }
    END { for (k = 1; k < n; ++k) printf "%s,%s-%s,%.1f,%.0f,%.0f\n", pre, w[k], w[k + 1], mx[k], lo[k], hi[k] }' \
    "$dir/probes.csv" >> "$csv"
done
column -s, -t "$csv"
echo "written: $csv"

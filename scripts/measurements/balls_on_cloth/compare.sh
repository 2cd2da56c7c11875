#!/usr/bin/env bash
# Session 18 (issue 14): scenes/balls_on_cloth.yaml (the paper's first demo) with both solvers, side by
# side: where the balls rest, how far the cloth stretches, whether it has come to rest, and the wall
# time (no particle or isosurface output). Prints a table and writes OUT/compare.csv.
#   scripts/measurements/balls_on_cloth/compare.sh [DURATION] [OUT_DIR]
# Extra --set arguments for the DFSPH run can be given in DFSPH_SET (e.g. "cloth[0].max_time_step=.inf");
# SOLVERS="dfsph" runs one solver only (default: "wcsph dfsph").
set -uo pipefail
top=$(cd "$(dirname "$0")/../../.." && pwd)
sph=${SPHAPTICS:-$top/build/cli/sphaptics}
duration=${1:-2.0}
out=${2:-$(mktemp -d)}
mkdir -p "$out"
csv="$out/compare.csv"
echo "solver,wall_s,steps,wood_z_m,plastic_z_m,metal_z_m,max_strain,cloth_ke_last_quarter_J,anchor_fz_N" > "$csv"
for solver in ${SOLVERS:-wcsph dfsph}; do
  extra=()
  if [ "$solver" = dfsph ]; then for s in ${DFSPH_SET:-}; do extra+=(--set "$s"); done; fi
  dir="$out/$solver"
  "$sph" run "$top/scenes/balls_on_cloth.yaml" --set fluid.solver="$solver" --set simulation.duration="$duration" \
    --set output.particles=false --set output.isosurface.enabled=false "${extra[@]}" -o "$dir" --quiet > "$dir.log" 2>&1
  rc=$?
  if [ $rc -ne 0 ]; then echo "$solver: exit $rc (see $dir.log)"; continue; fi
  wall=$(grep -o '"wall_seconds": *[0-9.]*' "$dir/run.json" | grep -o '[0-9.]*$')
  steps=$(grep -o '"steps": *[0-9]*' "$dir/run.json" | head -1 | grep -o '[0-9]*$')
  z=$(for b in wood plastic metal; do grep ",$b," "$dir/bodies.csv" | tail -1 | cut -d, -f5; done | paste -sd, -)
  cl=$(awk -F, -v d="$duration" '/^#/ || $1 == "time" { next }
         { if ($1 > 0.75 * d + 1e-9 && $3 > ke) ke = $3; s = $7; a = $11 } END { printf "%s,%.3g,%s", s, ke, a }' "$dir/cloth.csv")
  echo "$solver,$wall,$steps,$z,$cl" >> "$csv"
done
column -s, -t "$csv"
echo "written: $csv"

#!/usr/bin/env bash
# Session 24 (docs/dfsph.md): DFSPH's coarse operator reused over steps at rest
# (fluid.dfsph.coarse_reuse). For each scene and setting, REPEATS whole runs (kernel build included):
# wall time, steps, density iterations and corrections per step, the corrections that reused an
# operator, and the mean fluid force along x (towed ball) or z (others) on the first body over the
# second half of the run. Prints a table and writes OUT/coarse_reuse.csv.
#   scripts/measurements/coarse_reuse/reuse.sh [OUT_DIR] [REPEATS]
set -uo pipefail
top=$(cd "$(dirname "$0")/../../.." && pwd)
sph=${SPHAPTICS:-$top/build/cli/sphaptics}
out=${1:-$(mktemp -d)}
repeats=${2:-3}
mkdir -p "$out"
csv="$out/coarse_reuse.csv"
echo "scene,coarse_reuse,run,wall_s,steps,density_iterations_per_step,corrections_per_step,corrections_reused,mean_force_N" > "$csv"
# name|scene|axis column|sets
cases=(
  "stokes_tow|scenes/tests/stokes_tow.yaml|fluid_fx|--set fluid.solver=dfsph --set fluid.boundary_velocity=ghost --set simulation.gravity=[0,0,-9.81]"
  "haptic_balls|scenes/haptic_balls.yaml|fluid_fz|--set fluid.solver=dfsph --set output.step_forces=true"
)
for c in "${cases[@]}"; do
  IFS='|' read -r name scene col sets <<< "$c"
  for reuse in 0 8; do
    for run in $(seq 1 "$repeats"); do
      dir="$out/${name}_${reuse}_$run"
      # shellcheck disable=SC2086
      "$sph" run "$top/$scene" $sets --set fluid.dfsph.coarse_reuse=$reuse --set output.particles=false \
        -o "$dir" > "$dir.log" 2>&1 || { echo "$name reuse $reuse: exit $? (see $dir.log)"; continue; }
      wall=$(grep -o 'simulated in [0-9.]* s wall' "$dir.log" | grep -o '[0-9.]* s wall' | grep -o '^[0-9.]*')
      steps=$(grep -o '[0-9]* steps, [0-9]* particles' "$dir.log" | head -1 | grep -o '^[0-9]*')
      its=$(grep -o 'DFSPH: [0-9.]* density' "$dir.log" | grep -o '[0-9.]*' | head -1)
      corr=$(grep -o '; [0-9.]* density and' "$dir.log" | grep -o '[0-9.]*' | head -1)
      reused=$(grep -o '[0-9]* with a reused operator' "$dir.log" | grep -o '^[0-9]*')
      force=$(awk -F, -v col="$col" '/^#/ { next } $1 == "time" { for (k = 1; k <= NF; ++k) if ($k == col) f = k; next }
        { t[NR] = $1; v[NR] = $f; n = NR; if ($1 > tmax) tmax = $1 }
        END { for (k in t) if (t[k] >= tmax / 2) { s += v[k]; m++ } if (m) printf "%.5f", s / m }' "$dir/forces.csv")
      echo "$name,$reuse,$run,$wall,$steps,$its,${corr:-0},${reused:-0},$force" >> "$csv"
    done
  done
done
column -s, -t "$csv"
echo "written: $csv"

#!/usr/bin/env bash
# Session 26 (docs/forces.md): what DFSPH's strong body coupling (the default since session 26) costs
# against the staggered one on scenes with free bodies. Each scene runs with fluid.solver dfsph under
# both couplings, RUNS times each (alternating, one sitting), and the script prints per scene and
# coupling the median wall time of the runs, the steps and the density iterations per step, and the
# strong/staggered ratio of the medians; it writes OUT/default_cost.csv (one row per run).
#   scripts/measurements/body_coupling/default_cost.sh [OUT_DIR]
# Environment: SPHAPTICS (the binary; default build/cli/sphaptics), RUNS (default 3), DURATION
# (simulated seconds per run; default 0.5).
set -uo pipefail
top=$(cd "$(dirname "$0")/../../.." && pwd)
sph=${SPHAPTICS:-$top/build/cli/sphaptics}
out=${1:-$(mktemp -d)}
runs=${RUNS:-3}
duration=${DURATION:-0.5}
scenes=(scenes/tests/floating_block.yaml scenes/floating_bodies.yaml scenes/balls_in_bowl.yaml
        scenes/haptic_balls.yaml scenes/haptic_stir_live.yaml)
mkdir -p "$out"
csv="$out/default_cost.csv"
echo "scene,coupling,run,wall_s,steps,density_iterations_per_step,exit" > "$csv"
for scene in "${scenes[@]}"; do
  name=$(basename "$scene" .yaml)
  for ((r = 1; r <= runs; ++r)); do
    for coupling in strong staggered; do
      log="$out/$name-$coupling-$r.log"
      "$sph" run "$top/$scene" --set fluid.solver=dfsph --set fluid.dfsph.body_coupling=$coupling \
        --set output.particles=false --duration "$duration" -o "$out/$name-$coupling" > "$log" 2>&1
      rc=$?
      wall=$(grep -o 'simulated in [0-9.]* s wall' "$log" | grep -o '[0-9.]* s wall' | grep -o '^[0-9.]*')
      steps=$(grep -o 'wall ([0-9.]* frames/s), [0-9]* steps' "$log" | grep -o '[0-9]* steps' | grep -o '^[0-9]*')
      its=$(grep -o 'DFSPH: [0-9.]* density' "$log" | grep -o '[0-9.]*' | head -1)
      echo "$name,$coupling,$r,${wall:-nan},${steps:-0},${its:-0},$rc" >> "$csv"
    done
  done
done
# Medians per scene and coupling, and the ratio.
python3 - "$csv" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
print(f"{'scene':<18} {'coupling':<10} {'median wall s':>13} {'steps':>6} {'dens it/step':>12}  runs (exit)")
for scene in dict.fromkeys(r['scene'] for r in rows):
    med = {}
    for c in ('strong', 'staggered'):
        rs = [r for r in rows if r['scene'] == scene and r['coupling'] == c]
        ok = [float(r['wall_s']) for r in rs if r['exit'] == '0']
        med[c] = statistics.median(ok) if ok else float('nan')
        print(f"{scene:<18} {c:<10} {med[c]:>13.2f} {rs[-1]['steps']:>6} {float(rs[-1]['density_iterations_per_step']):>12.2f}  "
              + " ".join(f"{r['wall_s']}({r['exit']})" for r in rs))
    print(f"{scene:<18} strong / staggered: {med['strong'] / med['staggered']:.2f}x")
PY
echo "csv: $csv"

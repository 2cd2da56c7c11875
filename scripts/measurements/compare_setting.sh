#!/usr/bin/env bash
# What one DFSPH scene key costs: each scene runs with fluid.solver dfsph and KEY=A, then KEY=B (runs
# alternating, one sitting), RUNS times each; the script prints per scene and value the median wall time
# of the runs that exited 0, the steps and the density iterations per step of the last run, and the A/B
# ratio of the medians, and writes OUT/compare.csv (one row per run).
#   scripts/measurements/compare_setting.sh KEY A B [OUT_DIR] -- SCENE...
# e.g. scripts/measurements/compare_setting.sh fluid.dfsph.body_coupling strong staggered /tmp/o -- scenes/haptic_balls.yaml
# Environment: SPHAPTICS (the binary; default build/cli/sphaptics), RUNS (default 3), DURATION (simulated
# seconds per run; default 0.5).
set -uo pipefail
top=$(cd "$(dirname "$0")/../.." && pwd)
sph=${SPHAPTICS:-$top/build/cli/sphaptics}
key=$1 a=$2 b=$3
shift 3
if [ "${1:-}" != "--" ]; then out=$1; shift; else out=$(mktemp -d); fi
[ "${1:-}" = "--" ] && shift
scenes=("$@")
runs=${RUNS:-3}
duration=${DURATION:-0.5}
mkdir -p "$out"
csv="$out/compare.csv"
echo "scene,value,run,wall_s,steps,density_iterations_per_step,exit" > "$csv"
for scene in "${scenes[@]}"; do
  name=$(basename "$scene" .yaml)
  for ((r = 1; r <= runs; ++r)); do
    for value in "$a" "$b"; do
      log="$out/$name-$value-$r.log"
      "$sph" run "$top/$scene" --set fluid.solver=dfsph --set "$key=$value" \
        --set output.particles=false --duration "$duration" -o "$out/$name-$value" > "$log" 2>&1
      rc=$?
      wall=$(grep -o 'simulated in [0-9.]* s wall' "$log" | grep -o '[0-9.]* s wall' | grep -o '^[0-9.]*')
      steps=$(grep -o 'wall ([0-9.]* frames/s), [0-9]* steps' "$log" | grep -o '[0-9]* steps' | grep -o '^[0-9]*')
      its=$(grep -o 'DFSPH: [0-9.]* density' "$log" | grep -o '[0-9.]*' | head -1)
      echo "$name,$value,$r,${wall:-nan},${steps:-0},${its:-0},$rc" >> "$csv"
    done
  done
done
python3 - "$csv" "$key" "$a" "$b" <<'PY'
import csv, statistics, sys
path, key, a, b = sys.argv[1:5]
rows = list(csv.DictReader(open(path)))
print(f"{key}: {a} against {b}")
print(f"{'scene':<22} {'value':<10} {'median wall s':>13} {'steps':>6} {'dens it/step':>12}  runs (exit)")
for scene in dict.fromkeys(r['scene'] for r in rows):
    med = {}
    for v in (a, b):
        rs = [r for r in rows if r['scene'] == scene and r['value'] == v]
        ok = [float(r['wall_s']) for r in rs if r['exit'] == '0']
        med[v] = statistics.median(ok) if ok else float('nan')
        print(f"{scene:<22} {v:<10} {med[v]:>13.2f} {rs[-1]['steps']:>6} {float(rs[-1]['density_iterations_per_step']):>12.2f}  "
              + " ".join(f"{r['wall_s']}({r['exit']})" for r in rs))
    ratio = f"{med[a] / med[b]:.2f}x" if med[b] > 0 else "n/a (no timed run of " + b + ")"
    print(f"{scene:<22} {a} / {b}: {ratio}")
PY
echo "csv: $csv"

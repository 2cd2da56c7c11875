#!/usr/bin/env bash
# Stability sweep (session 16): every example scene in scenes/ with DFSPH, at its own frame rate and at
# 300 frames/s (one step of at most 3.3 ms per frame), for DURATION simulated seconds, outputs off.
# Prints one line per run: scene, frame rate, exit code (4 = numerical failure), wall seconds, and the
# error line if any, and the run's density iterations per step. Skips the three ~50k-particle scenes
# unless ALL=1. SETS adds scene overrides to every run, e.g.
# SETS="fluid.dfsph.warm_smoothing=0.5 fluid.dfsph.warm_average=0.5" (session 29).
#   scripts/measurements/dfsph_scene_sweep.sh [DURATION] [OUT_DIR]
set -uo pipefail
top=$(cd "$(dirname "$0")/../.." && pwd)
sph=${SPHAPTICS:-$top/build/cli/sphaptics}
duration=${1:-0.6}
out=${2:-$(mktemp -d)}
mkdir -p "$out"
for f in "$top"/scenes/*.yaml; do
  n=$(basename "$f" .yaml)
  if [ -z "${ALL:-}" ]; then case $n in balls_in_bowl|balls_on_cloth|demo_balls_cloth) continue ;; esac; fi
  for fr in default 300; do
    extra=(); [ "$fr" = 300 ] && extra=(--set simulation.frame_rate=300)
    for kv in ${SETS:-}; do extra+=(--set "$kv"); done
    s=$(date +%s.%N)
    "$sph" run "$f" --set fluid.solver=dfsph --set simulation.duration="$duration" --set output.particles=false \
      --set output.isosurface.enabled=false "${extra[@]}" -o "$out/${n}_$fr" --quiet > "$out/${n}_$fr.log" 2>&1
    rc=$?
    e=$(date +%s.%N)
    its=$(grep -o '"density_iterations_per_step": [0-9.e+-]*' "$out/${n}_$fr/run.json" 2>/dev/null | grep -o '[0-9.e+-]*$')
    printf '%s %s rc=%d %.1fs it/step %s %s\n' "$n" "$fr" "$rc" "$(echo "$e - $s" | bc)" "${its:--}" "$(grep -o 'error: .*' "$out/${n}_$fr.log" | head -1 | cut -c1-150)"
  done
done

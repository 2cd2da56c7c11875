#!/bin/bash
# The sinking ball's speed 0.2 s after its release into a tank at rest (scenes/tests/sink_ball_rest.yaml),
# at 8 cm and 28 cm depth, with each fluid.body_ambient_pressure rule, and the R/dx 4 tank with and without
# the gap at two walls that session 12 had (docs/forces.md, session 32). Usage: run.sh [SPHAPTICS] [OUT]
set -euo pipefail
bin=${1:-build/cli/sphaptics}
out=${2:-/tmp/ambient_pressure}
src=scenes/tests/sink_ball_rest.yaml
mkdir -p "$out"
cp "$src" "$out/base.yaml"
# 20 cm more water above the ball (the ball where it was: 28 cm deep instead of 8)
sed -e 's/max: \[0.2, 0.2, 0.3\]/max: [0.2, 0.2, 0.5]/' -e 's/max: \[0.2, 0.2, 0.28\]/max: [0.2, 0.2, 0.48]/' "$src" > "$out/deep.yaml"
# R/dx 4 (the walls move out to 0.2025 m), and the same with the block one spacing short of them
sed -e 's/particle_spacing: 0.01 /particle_spacing: 0.0075/' "$src" > "$out/r4.yaml"
sed -e 's/particle_spacing: 0.01 /particle_spacing: 0.0075/' -e 's/max: \[0.2, 0.2, 0.28\]/max: [0.195, 0.195, 0.28]/' "$src" > "$out/r4_gap.yaml"
speed() {  # v_z of bodies.csv at 0.8 s (0.2 s after the release at 0.6 s)
  awk -F, '$1 == "0.8" && $2 == "ball" { printf "%.3f", -$12 }' "$1/bodies.csv"
}
for rule in keep subtract; do
  for scene in base deep; do
    "$bin" run "$out/$scene.yaml" --set fluid.body_ambient_pressure=$rule -q -o "$out/${scene}_$rule" > /dev/null 2>&1
    echo "$scene $rule: v(0.2 s) $(speed "$out/${scene}_$rule") m/s"
  done
done
for scene in r4 r4_gap; do
  "$bin" run "$out/$scene.yaml" -q -o "$out/$scene" > /dev/null 2>&1
  echo "$scene keep: v(0.2 s) $(speed "$out/$scene") m/s"
done

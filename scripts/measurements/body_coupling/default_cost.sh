#!/usr/bin/env bash
# Session 26 (docs/forces.md): what DFSPH's strong body coupling (the default since session 26) costs
# against the staggered one on scenes with free bodies (scripts/measurements/compare_setting.sh says what
# it prints and writes).
#   scripts/measurements/body_coupling/default_cost.sh [OUT_DIR]
# Environment: SPHAPTICS, RUNS (default 3), DURATION (default 0.5), as compare_setting.sh.
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
exec "$here/../compare_setting.sh" fluid.dfsph.body_coupling strong staggered ${1:+"$1"} -- \
  scenes/tests/floating_block.yaml scenes/floating_bodies.yaml scenes/balls_in_bowl.yaml \
  scenes/haptic_balls.yaml scenes/haptic_stir_live.yaml

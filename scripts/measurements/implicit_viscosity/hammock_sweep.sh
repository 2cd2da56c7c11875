#!/bin/bash
# Usage: OUT=/tmp/hammock_sweep scripts/measurements/implicit_viscosity/hammock_sweep.sh  (from a built tree;
# then cd $OUT and run hammock_sweep_summary.py there). Since session 37 the loader refuses implicit with
# cloth, so the implicit rows need the refusal (io/scene_loader.cpp) taken out to be rerun. Session 38 reran
# the implicit rows with the nodes as unknowns of the solve: hammock_sweep_session38.txt.
# areal density x viscosity sweep of the hammock in syrup, implicit at 5 ms (and explicit at its bound for reference)
cd "$(dirname "$0")/../../.."
for ad in 0.5 1 2 5; do for nu in 0.001 0.01 0.1; do for mode in implicit explicit; do
  out=${OUT:-/tmp/hammock_sweep}/${mode}_${ad}_${nu}
  s=$(date +%s.%N)
  timeout 300 build/cli/sphaptics run scenes/tests/dfsph_hammock_syrup.yaml -q --set fluid.dfsph.viscosity_solve=$mode \
    --set cloth[0].areal_density=$ad --set fluid.phases[0].viscosity=$nu -o $out > $out.log 2>&1
  rc=$?; e=$(date +%s.%N)
  echo "$mode $ad $nu rc=$rc wall=$(echo "$e - $s" | bc)"
done; done; done

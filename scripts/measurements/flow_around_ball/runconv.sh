#!/bin/bash
# converged DFSPH (session 13's 'density_error=1e-6 divergence_error=1e-6') at R/dx 3: tow U=0.1, held, shaken
C="--set fluid.dfsph.density_error=1e-6 --set fluid.dfsph.divergence_error=1e-6"
for u in 0 0.1; do d=out_ke/dfsphconv_r3_u$u
 /usr/bin/time -f "%U user %e wall" nice -n 10 build/cli/sphaptics run scripts/measurements/flow_around_ball/scenes/tow_ke_u$u.yaml --device cpu --set fluid.solver=dfsph $C -o $d -q 2> $d.time; echo "$d $(tail -1 $d.time)"; done
scripts/measurements/flow_around_ball/runshake.sh dfsph 0.01 r3conv $C

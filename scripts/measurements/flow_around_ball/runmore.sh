#!/bin/bash
for s in dfsph wcsph; do d=out_ke/shake100_${s}_r3
 /usr/bin/time -f "%U user %e wall" nice -n 10 build/cli/sphaptics run scenes/tests/accel_ball.yaml --device cpu --set fluid.solver=$s -o $d -q 2> $d.time; echo "$d $(tail -1 $d.time)"; done
scripts/measurements/flow_around_ball/runshake.sh dfsph 0.006 r5
scripts/measurements/flow_around_ball/runset.sh wcsph 0.006 r5 0 0.1
scripts/measurements/flow_around_ball/runshake.sh wcsph 0.006 r5

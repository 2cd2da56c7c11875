#!/bin/bash
# usage: runshake.sh SOLVER DX TAG [extra --set args...]: accel_ball.yaml with particles at 200 fps into out_ke/shake_$SOLVER_$TAG
solver=$1; dx=$2; tag=$3; shift 3
d=out_ke/shake_${solver}_$tag
/usr/bin/time -f "%U user %e wall" nice -n 10 build/cli/sphaptics run scenes/tests/accel_ball.yaml --device cpu \
   --set fluid.solver=$solver --set fluid.particle_spacing=$dx --set output.particles=true --set simulation.frame_rate=200 "$@" -o $d -q 2> $d.time || echo FAIL $d
echo "$d $(tail -1 $d.time)"

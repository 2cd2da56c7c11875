#!/bin/bash
# usage: runset.sh SOLVER DX TAG U... : runs tow_ke_u$U.yaml for each U into out_ke/$SOLVER_$TAG_u$U
solver=$1; dx=$2; tag=$3; shift 3
for u in "$@"; do
  d=out_ke/${solver}_${tag}_u$u
  /usr/bin/time -f "%U user %e wall" nice -n 10 build/cli/sphaptics run scripts/measurements/flow_around_ball/scenes/tow_ke_u$u.yaml --device cpu \
     --set fluid.solver=$solver --set fluid.particle_spacing=$dx -o $d -q 2> $d.time || echo FAIL $d
  echo "$d $(tail -1 $d.time)"
done

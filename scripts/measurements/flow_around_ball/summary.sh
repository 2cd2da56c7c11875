#!/bin/bash
# one line per tow run: early dipole k and KE (diff vs held run), coherent KE over the tow, force fits
for d in "$@"; do
  base=${d%_u*}; u=${d##*_u}; dx=$(/usr/bin/python3 -c "import json;print(json.load(open('out_ke/$d/run.json'))['scene']['fluid']['particle_spacing'])")
  e=$(/usr/bin/python3 scripts/measurements/flow_around_ball/early.py out_ke/$d out_ke/${base}_u0 2>/dev/null | awk '$1=="0.340"||$1=="0.350"||$1=="0.360"{printf "t%s k %s KEnear %s [%s] KEtank %s | ", $1,$3,$4,$5,$6}')
  c=$(/usr/bin/python3 scripts/measurements/flow_around_ball/ke2.py out_ke/$d $dx 2>/dev/null | sed -n -e "s/.*halves) \([-0-9.]*\);.*same way \([0-9.]*\),.*/coh(<3R) \1 pf \2 /p" -e "s/.*r < 2R, all sectors: k \([-0-9.]*\).*/k_tow \1/p" | tr "\n" " ")
  f0=$(/usr/bin/python3 scripts/measurements/flow_around_ball/ramp_force.py out_ke/$d --rest out_ke/${base}_u0 | awk 'NR==1{print $12}')
  f5=$(/usr/bin/python3 scripts/measurements/flow_around_ball/ramp_force.py out_ke/$d --rest out_ke/${base}_u0 --lag 0.005 | awk 'NR==1{print $12}')
  echo "$d: $e"; echo "    $c | force C_m lag0 $f0 lag5ms $f5"
done

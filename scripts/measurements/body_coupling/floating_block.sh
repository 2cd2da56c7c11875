#!/usr/bin/env bash
# Session 23 (docs/forces.md): DFSPH's body coupling on the free floating block
# (scenes/tests/floating_block.yaml: a 12 x 12 x 6 cm block of 500 kg/m^3 placed at its draft, dx = 1 cm).
# For each variant: the fluid's vertical force on the block over the steps of a window (mean, standard
# deviation, range; the weight is 4.24 N), the block's largest |v_z| there, the steps, the density
# iterations per step and the wall time of the run. Prints a table and writes OUT/floating_block.csv.
#   scripts/measurements/body_coupling/floating_block.sh [OUT_DIR] ["NAME:--set a=b --set c=d" ...]
# Default variants: the table of docs/forces.md, session 23 (0.6 s runs, window 0.22-0.6 s).
set -uo pipefail
top=$(cd "$(dirname "$0")/../../.." && pwd)
sph=${SPHAPTICS:-$top/build/cli/sphaptics}
out=${1:-$(mktemp -d)}
shift || true
variants=("$@")
[ ${#variants[@]} -gt 0 ] || variants=(
  "wcsph:--set fluid.solver=wcsph"
  "dfsph-staggered:--set fluid.solver=dfsph"
  "dfsph-staggered-held:--set fluid.solver=dfsph --set rigid_bodies[0].hold_until=1"
  "dfsph-strong:--set fluid.solver=dfsph --set fluid.dfsph.body_coupling=strong"
  "dfsph-strong-0.03:--set fluid.solver=dfsph --set fluid.dfsph.body_coupling=strong --set fluid.dfsph.body_error=0.03"
  "dfsph-strong-0.3:--set fluid.solver=dfsph --set fluid.dfsph.body_coupling=strong --set fluid.dfsph.body_error=0.3")
t0=${T0:-0.22}
t1=${T1:-0.6}
mkdir -p "$out"
csv="$out/floating_block.csv"
echo "variant,window_s,steps,force_mean_N,force_sd_N,force_min_N,force_max_N,max_abs_vz_mps,density_iterations_per_step,wall_s" > "$csv"
for v in "${variants[@]}"; do
  name=${v%%:*}
  sets=${v#*:}
  dir="$out/$name"
  # shellcheck disable=SC2086
  "$sph" run "$top/scenes/tests/floating_block.yaml" $sets --set output.step_forces=true --set output.particles=false \
    --duration "$t1" -o "$dir" > "$dir.log" 2>&1
  rc=$?
  if [ $rc -ne 0 ]; then echo "$name: exit $rc (see $dir.log)"; continue; fi
  wall=$(grep -o 'simulated in [0-9.]* s wall' "$dir.log" | grep -o '[0-9.]* s wall' | grep -o '^[0-9.]*')
  its=$(grep -o 'DFSPH: [0-9.]* density' "$dir.log" | grep -o '[0-9.]*' | head -1)
  awk -F, -v pre="$name,$t0-$t1" -v t0="$t0" -v t1="$t1" -v its="${its:-0}" -v wall="$wall" '
    /^#/ { next }
    $1 == "time" { for (c = 1; c <= NF; ++c) { if ($c == "fluid_fz") f = c; if ($c == "vz") z = c } next }
    $1 >= t0 - 1e-9 && $1 <= t1 { n++; s += $f; q += $f * $f; if (n == 1 || $f < lo) lo = $f; if (n == 1 || $f > hi) hi = $f
                                  a = $z < 0 ? -$z : $z; if (a > vz) vz = a }
    END { m = s / n; sd = sqrt(q / n - m * m); printf "%s,%d,%.3f,%.3f,%.2f,%.2f,%.4f,%s,%s\n", pre, n, m, sd, lo, hi, vz, its, wall }' \
    "$dir/forces.csv" >> "$csv"
done
column -s, -t "$csv"
echo "written: $csv"

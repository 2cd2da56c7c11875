#!/bin/bash
# What the implicit viscosity buys a live haptic scene in a viscous liquid (session 39).
# scenes/haptic_stir_live.yaml (the hand stirs a wooden spoon through a 6 cm tub, 1,520 particles at dx = 1 cm,
# 30 frames/s) with its water replaced by a laminar liquid of viscosity NU, run with WCSPH, DFSPH with the
# explicit viscosity, and DFSPH with its default (auto: implicit where the explicit bound 0.125 h^2 / nu is
# below the 5 ms max_time_step). Prints and writes CSV: steps, wall time per simulated second (whole process,
# median of ROUNDS interleaved runs) and the felt force over the stirring (1-3 s): mean |F| and its RMS
# difference from DFSPH explicit's, tick by tick (the servo's virtual clock makes the ticks line up).
# Usage: scripts/measurements/implicit_viscosity/live_syrup.sh [NU=0.01] [ROUNDS=3] [OUT=live_syrup.csv]
set -euo pipefail
NU=${1:-0.01}
ROUNDS=${2:-3}
OUT=${3:-live_syrup.csv}
ROOT=$(cd "$(dirname "$0")/../../.." && pwd)
BIN=${SPHAPTICS:-$ROOT/build/cli/sphaptics}
SCENE=$ROOT/scenes/haptic_stir_live.yaml
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
COMMON=(--set fluid.viscosity_model=laminar --set "fluid.phases=[{name: syrup, rest_density: 1000, viscosity: $NU}]" -q)
declare -A SETS=(
  [wcsph]="--set fluid.solver=wcsph"
  [dfsph_explicit]="--set fluid.solver=dfsph --set fluid.dfsph.viscosity_solve=explicit"
  [dfsph_auto]="--set fluid.solver=dfsph"
)
CASES=(wcsph dfsph_explicit dfsph_auto)
for r in $(seq 1 "$ROUNDS"); do
  for c in "${CASES[@]}"; do
    # shellcheck disable=SC2086
    /usr/bin/time -f "%e" -o "$TMP/$c.$r.time" "$BIN" run "$SCENE" ${SETS[$c]} "${COMMON[@]}" -o "$TMP/$c" >/dev/null
  done
done
/usr/bin/python3 - "$TMP" "$NU" "$ROUNDS" "$OUT" "${CASES[@]}" <<'PY'
import json, sys, statistics
import numpy as np
tmp, nu, rounds, out, cases = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5:]
def felt(c):
    rows = [l for l in open(f"{tmp}/{c}/haptics.csv") if not l.startswith("#")]
    h = rows[0].strip().split(",")
    d = np.array([[float(x) for x in r.strip().split(",")] for r in rows[1:]])
    t = d[:, h.index("time")]
    m = (t >= 1.0) & (t < 3.0)
    return d[m][:, [h.index("fx"), h.index("fy"), h.index("fz")]]
ref = felt("dfsph_explicit")
lines = ["case,nu_m2_s,steps,viscosity_solve,wall_s_median,wall_s_per_simulated_s,felt_mean_N,felt_rms_diff_from_dfsph_explicit_N"]
for c in cases:
    j = json.load(open(f"{tmp}/{c}/run.json"))
    walls = [float(open(f"{tmp}/{c}.{r}.time").read()) for r in range(1, rounds + 1)]
    w = statistics.median(walls)
    f = felt(c)
    n = min(len(f), len(ref))
    rms = float(np.sqrt(np.mean(np.sum((f[:n] - ref[:n]) ** 2, axis=1))))
    vs = j["scene"]["fluid"].get("dfsph", {}).get("viscosity_solve", "") if j["scene"]["fluid"].get("solver") == "dfsph" else "explicit"
    lines.append(f"{c},{nu:g},{j['steps']},{vs},{w:.2f},{w / j['simulated_seconds']:.2f},"
                 f"{np.mean(np.linalg.norm(f, axis=1)):.4f},{rms:.4f}")
    print(f"{c}: wall {', '.join(f'{x:.2f}' for x in walls)} s", file=sys.stderr)
open(out, "w").write("\n".join(lines) + "\n")
print("\n".join(lines))
PY

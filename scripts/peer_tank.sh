#!/usr/bin/env bash
# The hydrostatic tank (scenes/tests/hydrostatic.yaml) in the reference library: SPlisHSPlasH's
# DFSPH at its default bounds (density 0.05 %, divergence 0.1 %), steps of 5 ms (CFL 0.4 capped
# at 5 ms, as sphaptics' DFSPH), walls as volume maps (Bender et al. 2019, its default) or Akinci
# boundary particles. The same geometry in its axes (y up): water 0.2 x 0.2 x 0.06 m (x, y, z) of
# 20 x 20 x 6 particles, spacing 0.01 m, in a closed box 0.2 x 0.3 x 0.06 m; gravity from the
# start (sphaptics ramps it in over 0.4 s); laminar viscosity 0.002 m^2/s (sphaptics' artificial
# alpha 0.1 is about alpha h c0 / 10 = 0.1 x 0.01 x 19.8 / 10 m^2/s). Exports every step (200/s)
# and prints the layer pressures against rho0 g d (scripts/peer_tank.py says how p is read).
#   PEER_BIN=/work/peer/run/SPlisHSPlasH/bin/SPHSimulator scripts/peer_tank.sh [volume|akinci] [T_END]
set -euo pipefail
walls=${1:-volume}
t_end=${2:-2.75}
: "${PEER_BIN:?set PEER_BIN to the SPHSimulator binary of SPlisHSPlasH (../shared/peer-bench/README.md)}"
top=$(cd "$(dirname "$0")/.." && pwd)
box=${PEER_BOX:-$(dirname "$(dirname "$PEER_BIN")")/data/models/UnitBox.obj}
work=${WORK:-$(mktemp -d)}
method=2; [ "$walls" = akinci ] && method=0
cat > "$work/tank.json" <<JSON
{
  "Configuration": {
    "particleRadius": 0.005, "numberOfStepsPerRenderUpdate": 1, "simulationMethod": 4,
    "kernel": 0, "gradKernel": 0, "gravitation": [0, -9.81, 0],
    "timeStepSize": 0.005, "cflMethod": ${CFL_METHOD:-1}, "cflFactor": 1, "cflMaxTimeStepSize": 0.005,
    "enablePartioExport": false, "enableVTKExport": true, "dataExportFPS": 200,
    "particleAttributes": "density;p / rho^2;p_v / rho^2",
    "boundaryHandlingMethod": $method,
    "DFSPH": {"minIterations": 2, "maxIterations": 100, "maxError": 0.05,
              "maxIterationsV": 100, "maxErrorV": 0.1, "enableDivergenceSolver": true}
  },
  "Materials": [{"id": "Fluid", "density0": 1000, "viscosityMethod": 1, "Standard viscosity": {"viscosity": 0.002}}],
  "RigidBodies": [{
    "geometryFile": "$box", "translation": [0.1, 0.15, 0.03], "rotationAxis": [1, 0, 0], "rotationAngle": 0,
    "scale": [0.2, 0.3, 0.06], "isDynamic": false, "isWall": true, "mapInvert": true, "mapThickness": 0.0,
    "mapResolution": [40, 60, 12]
  }],
  "FluidBlocks": [{"denseMode": 0, "start": [-0.005, -0.005, -0.005], "end": [0.205, 0.205, 0.065]}]
}
JSON
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-2}
"$PEER_BIN" --no-gui --stopAt "$t_end" --output-dir "$work/out" "$work/tank.json" > "$work/peer.log" 2>&1
grep -E "Average number: DFSPH - iterations|Average number: DFSPH - iterationsV" "$work/peer.log" | tail -2 || true
echo "# walls: $walls; 1.0-1.5 s"
python3 "$top/scripts/peer_tank.py" "$work/out/vtk" 0.005 1.0 1.5
echo "# walls: $walls; 1.0-$t_end s"
python3 "$top/scripts/peer_tank.py" "$work/out/vtk" 0.005 1.0 "$t_end"

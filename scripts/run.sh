#!/usr/bin/env bash
# Install the dependencies, build, and run the default scene (dam break) into out/dam_break.
# Extra arguments go to `sphaptics run`, e.g. ./scripts/run.sh --duration 0.5 --device gpu
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

./scripts/install_deps.sh
./scripts/build.sh
exec build/cli/sphaptics run scenes/dam_break.yaml --out out/dam_break "$@"

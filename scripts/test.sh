#!/usr/bin/env bash
# Install the dependencies, build, and run the whole test suite (Catch2 tests through CTest).
# Extra arguments go to ctest, e.g. ./scripts/test.sh -R cli
# Tests run one at a time: the OpenCL tests already use every core (pocl), and running them side
# by side only makes each slower and the suite no faster.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

./scripts/install_deps.sh
./scripts/build.sh
ctest --test-dir build --output-on-failure -j1 "$@"

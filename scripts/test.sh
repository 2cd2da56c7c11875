#!/usr/bin/env bash
# Install the dependencies, build, and run the whole test suite (Catch2 tests through CTest).
# Extra arguments go to ctest, e.g. ./scripts/test.sh -R cli
# Two tests at a time (SPHAPTICS_TEST_JOBS overrides): one OpenCL test alone leaves the 2-core
# machine idle about a third of the time (host work, kernel builds, waits), and two side by side
# finish ~1.5x sooner (measured, session 24: 45 tests in 181 s one at a time, 119 s two at a time,
# the same CPU seconds). Tests that measure the wall clock, start Xvfb or use UDP run alone
# (RUN_SERIAL, tests/CMakeLists.txt).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

./scripts/install_deps.sh
./scripts/build.sh
ctest --test-dir build --output-on-failure -j"${SPHAPTICS_TEST_JOBS:-2}" "$@"

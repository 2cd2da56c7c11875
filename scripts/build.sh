#!/usr/bin/env bash
# Configure and build sphaptics into build/ (RelWithDebInfo: optimised, with debug info and
# SPH_ASSERT alive). Idempotent: a second call only rebuilds what changed.
# Warnings are errors when CI is set (or SPHAPTICS_WERROR=ON); a user build only prints them.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

werror="${SPHAPTICS_WERROR:-}"
if [ -z "$werror" ]; then
  if [ -n "${CI:-}" ]; then werror=ON; else werror=OFF; fi
fi

cmake -S . -B build -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSPHAPTICS_WERROR="$werror"
cmake --build build -j"$(nproc)"

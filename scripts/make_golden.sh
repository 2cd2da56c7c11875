#!/usr/bin/env bash
# Regenerate the golden OBJ sequence of the surface regression test (tests/test_regression.cpp,
# tag [regression]): runs scenes/tests/regression_surface.yaml with the built `sphaptics` into a
# temporary folder and copies only its fluid_*.obj files to tests/data/golden/regression_surface/
# (the old files there are removed first). This script is the only way the goldens are made.
#
#   scripts/make_golden.sh [BUILD_DIR]      (default: build-dev, then build)
#
# When to run it: only for an intended, reviewed change of the physics or of the meshing (a new
# kernel, wall model, time stepping, iso value, marching-cubes change, a change to the scene file)
# that moves the surface beyond the test's tolerances. Then commit the new goldens together with
# that change and say in the commit why the surface moved; look at the old-vs-new `compare` table
# this script prints first. Never run it to make a failing test pass without knowing why it fails:
# a failure means the simulation or the mesher changed its output.
# The goldens were made on the 2-core development machine (pocl, CPU). Another device or driver
# may differ in the last bits; the test's tolerances allow that (see the comment in tests/test_regression.cpp).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
scene="$root/scenes/tests/regression_surface.yaml"
golden="$root/tests/data/golden/regression_surface"

if [ $# -ge 1 ]; then
  build="$1"
elif [ -x "$root/build-dev/cli/sphaptics" ]; then
  build="$root/build-dev"
else
  build="$root/build"
fi
bin="$build/cli/sphaptics"
if [ ! -x "$bin" ]; then
  echo "make_golden.sh: no sphaptics executable at $bin (build first, or pass BUILD_DIR)" >&2
  exit 2
fi

tmp="$(mktemp -d "${TMPDIR:-/tmp}/sphaptics_golden.XXXXXX")"
trap 'rm -rf "$tmp"' EXIT

echo "make_golden.sh: running $bin run $scene --out $tmp/run"
"$bin" run "$scene" --out "$tmp/run" --quiet
shopt -s nullglob
files=("$tmp"/run/fluid_*.obj)
if [ ${#files[@]} -eq 0 ]; then
  echo "make_golden.sh: the run wrote no fluid_*.obj files (does the scene have output.isosurface?)" >&2
  exit 1
fi

if [ -d "$golden" ] && compgen -G "$golden/fluid_*.obj" >/dev/null; then
  echo "make_golden.sh: old goldens against the new run (tolerances: the test's defaults):"
  "$bin" compare "$golden" "$tmp/run" || true
  rm -f "$golden"/fluid_*.obj
fi
mkdir -p "$golden"
cp "${files[@]}" "$golden/"
echo "make_golden.sh: wrote ${#files[@]} files to $golden ($(du -sh "$golden" | cut -f1)):"
(cd "$golden" && ls -l fluid_*.obj | awk '{print "  " $NF " " $5 " bytes"}')
echo "make_golden.sh: review the change (git diff --stat tests/data/golden) and commit it with the reason."

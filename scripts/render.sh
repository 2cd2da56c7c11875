#!/usr/bin/env bash
# Render a run folder's OBJ (or, with --volume, VDB) sequence to PNG frames with Blender's Cycles
# on the CPU: scripts/render.sh RUN_DIR [--frames A:B] [--every N] [--resolution WxH] [--samples N]
# [--out DIR] [--volume] [--blend FILE]. PNGs go to RUN_DIR/render/frame_%04d.png by default.
# Needs Debian's blender (apt-get install --no-install-recommends blender, about 570 MB).
set -euo pipefail
if [ $# -lt 1 ]; then
  sed -n '2,5p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
if ! command -v blender >/dev/null 2>&1; then
  echo "render.sh: blender is not installed (apt-get install --no-install-recommends blender)" >&2
  exit 3
fi
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
exec blender -b --factory-startup --python-exit-code 1 -P "$here/render_blender.py" -- "$@"

#!/usr/bin/env bash
# Render a run folder's OBJ (or, with --volume, VDB) sequence to PNG frames with Blender's Cycles
# on the CPU: scripts/render.sh RUN_DIR [--frames A:B] [--every N] [--resolution WxH] [--samples N]
# [--out DIR] [--volume] [--blend FILE] [--video FILE.mp4 [--fps N]]. PNGs go to RUN_DIR/render/
# frame_%04d.png by default; --video also joins them into an H.264 animation (needs ffmpeg).
# Needs Debian's blender (apt-get install --no-install-recommends blender, about 570 MB).
set -euo pipefail
if [ $# -lt 1 ]; then
  sed -n '2,6p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
# Our own options (--video, --fps) are taken out; the rest goes to render_blender.py.
run_dir="$1"
out_dir=""
video=""
fps=""
args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --video) [ $# -ge 2 ] || { echo "render.sh: --video needs a file name" >&2; exit 2; }; video="$2"; shift 2 ;;
    --fps) [ $# -ge 2 ] || { echo "render.sh: --fps needs a number" >&2; exit 2; }; fps="$2"; shift 2 ;;
    --out) [ $# -ge 2 ] || { echo "render.sh: --out needs a folder" >&2; exit 2; }; out_dir="$2"; args+=("$1" "$2"); shift 2 ;;
    *) args+=("$1"); shift ;;
  esac
done
if [ ! -d "$run_dir" ]; then
  echo "render.sh: $run_dir: no such run folder" >&2
  exit 2
fi
if ! command -v blender >/dev/null 2>&1; then
  echo "render.sh: blender is not installed (apt-get install --no-install-recommends blender)" >&2
  exit 3
fi
if [ -n "$video" ] && ! command -v ffmpeg >/dev/null 2>&1; then
  echo "render.sh: --video needs ffmpeg, which is not installed (apt-get install --no-install-recommends ffmpeg)" >&2
  exit 3
fi
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
blender -b --factory-startup --python-exit-code 1 -P "$here/render_blender.py" -- "${args[@]}"
if [ -n "$video" ]; then
  frames_dir="${out_dir:-$run_dir/render}"
  # The run's frame rate from run.json unless --fps is given (30 if neither).
  if [ -z "$fps" ]; then
    fps="$(sed -n 's/.*"frame_rate": *\([0-9.]*\).*/\1/p' "$run_dir/run.json" 2>/dev/null | head -n 1)"
    fps="${fps:-30}"
  fi
  if ! ls "$frames_dir"/frame_*.png >/dev/null 2>&1; then
    echo "render.sh: no frame_*.png in $frames_dir to make a video of" >&2
    exit 1
  fi
  # A glob, not a numbered pattern: --every N leaves gaps in the numbers.
  ffmpeg -y -loglevel error -framerate "$fps" -pattern_type glob -i "$frames_dir/frame_*.png" \
    -c:v libx264 -pix_fmt yuv420p -vf "pad=ceil(iw/2)*2:ceil(ih/2)*2" "$video"
  echo "render.sh: wrote $video ($fps frames/s)"
fi

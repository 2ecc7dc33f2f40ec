#!/usr/bin/env bash
# Exports a log's boards with the OSL field data and renders them in Cycles with
# shaders/osl/sawyer_wood.osl (docs/export.md, "OSL"). Needs a Blender with OSL in its Cycles
# (BLENDER=/path/to/blender; Debian's package has none and the script says so).
#
#   scripts/blender_osl_render.sh LOG SAWING.json OUT_DIR
set -euo pipefail
if [ $# -ne 3 ]; then
  echo "usage: $0 LOG sawing.json OUT_DIR" >&2
  exit 2
fi
log=$1 sawing=$2 out=$3
here=$(cd "$(dirname "$0")" && pwd)
sawyer=${SAWYER:-$here/../build/apps/sawyer/sawyer}
blender=${BLENDER:-blender}
if ! "$blender" -b --factory-startup --python-expr \
    "import _cycles, sys; sys.exit(0 if _cycles.with_osl else 3)" >/dev/null 2>&1; then
  echo "blender_osl_render: $blender has no OSL in its Cycles (Debian's build has none);" \
       "set BLENDER to a Blender with OSL" >&2
  exit 3
fi
mkdir -p "$out"
"$sawyer" export "$log" --sawing "$sawing" --px-per-mm 0.25 -o "$out/boards.glb" \
  --osl-data "$out/osl"
"$blender" -b --factory-startup --python-exit-code 1 --python "$here/blender_osl_render.py" -- \
  "$out/boards.glb" "$out/osl" "$out/osl_render.png"

#!/usr/bin/env bash
# Renders the gallery of docs/render.md with `sawyer render` (headless) into docs/images/.
#   bench/render_gallery.sh [build folder (default build)] [output folder (default docs/images)]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
OUT=${2:-docs/images}
S="$BUILD/apps/sawyer/sawyer"
G=sample_logs/gran1_spruce/log.json
P=sample_logs/pine_8/log.json
mkdir -p "$OUT"
# The pith at a stem sample, "x,y" in the scanner frame (for boards through the pith there).
pith() { python3 -c "import json,sys; p=json.load(open('$1'))['stem']['pith'][$2]; print('%.2f,%.2f' % tuple(p))"; }

# Spruce (gran1, the real CT-derived log): a board's four long faces.
"$S" render "$G" -o "$OUT/gran1_board_faces.png" --board "0,45,150,40,0,1000,2200" --size 700 -q
# A dead knot cut across (face perpendicular to the knot, 100 mm from the pith): outline,
# darker dead wood, rings bent above and below it more than at its sides (the butterfly).
"$S" render "$G" -o "$OUT/gran1_dead_knot.png" --scanner-frame \
  --board "95.5,150.4,120,20,101,900,1040" --face top --size 440 -q
# The largest knot cut along its axis through the pith: rings flowing around it.
"$S" render "$G" -o "$OUT/gran1_knot_along_axis.png" --scanner-frame \
  --board "$(pith $G 214),280,2,173,2040,2260" --face top --size 400 -q
"$S" render "$G" -o "$OUT/gran1_cross_section.png" --section 1788 --size 340 -q

# Pine (generated, with heartwood): a whorl in a cross-section and cut along a knot.
"$S" render "$P" -o "$OUT/pine_whorl_section.png" --section 965 --size 340 -q
"$S" render "$P" -o "$OUT/pine_whorl_along_knot.png" --scanner-frame \
  --board "$(pith $P 95),270,1,5,800,1150" --face top --size 400 -q
"$S" render "$P" -o "$OUT/pine_board_faces.png" --board "0,30,160,40,0,700,1600" \
  --face top,bottom --size 700 -q
# 3D: three boards sawn out of the top end of the log, seen from that end.
"$S" render "$P" -o "$OUT/pine_view.png" --view --size 800x450 --distance 1500 --look-at 2300 \
  --yaw -40 --pitch 25 --board "0,-48,140,40,0,2000,3000" --board "0,-4,140,44,0,2000,3000" \
  --board "0,40,140,40,0,2000,3000" -q
ls -l "$OUT"

#!/usr/bin/env bash
# Renders the gallery of docs/render.md with `sawyer render` (headless) into docs/images/.
#   bench/render_gallery.sh [build folder (default build)] [output folder (default docs/images)]
#                           [published setup/ folder]
# With the third argument (the setup/ folder of a checkout of github.com/marialarsson/procedural_knots,
# not part of Sawyer) it also draws the knot comparison: the same board face by the published
# shader (bench/published_shader), by Sawyer before issue 23 (commit 0e39101's shaders, read
# through SAWYER_SHADER_DIR, 2 x 2 samples in every pixel as then) and by Sawyer now, cropped 1:1
# around four knots (knot_crops_gran1.png: one row each).
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
# Bark on a section, and the same pine board with the spruce look (species looks).
"$S" render "$P" -o "$OUT/pine_section_bark.png" --section 965 --size 340 --bark -q

PUBLISHED=${3:-}
if [ -n "$PUBLISHED" ]; then
  T=$(mktemp -d)
  trap 'rm -rf "$T"' EXIT
  "$S" convert sample_logs/gran1_spruce/published_maps -o "$T/pub_log.json" >/dev/null
  mkdir -p "$T/before"
  for f in wood.frag wood.vert wood_field.glsl wood_log_data.glsl mesh.frag mesh.vert; do
    git show "0e39101:shaders/$f" >"$T/before/$f"
  done
  # The whorl board of tests/published_render_test.cpp: 150 x 40 mm, 35 mm from the pith,
  # turned 165 degrees, z 2.4-3.0 m; its top face at 4 px/mm.
  BOARD="-12.94,-26.87,150,40,165,2400,3000"
  "$BUILD/bench/published_shader" "$PUBLISHED" sample_logs/gran1_spruce/published_maps \
    sample_logs/wood_color_maps "$BOARD" 2400x600 "$T/published.png" >/dev/null
  SAWYER_SHADER_DIR="$T/before" "$S" render "$T/pub_log.json" --scanner-frame --board "$BOARD" \
    --face top --size 2400x600 --stretch --supersample-all -o "$T/before.png" -q
  "$S" render "$T/pub_log.json" --scanner-frame --board "$BOARD" --face top --size 2400x600 \
    --stretch -o "$T/after.png" -q
  tiles=()
  for row in published before after; do
    for cut in 240x240+1124+0 240x240+928+232 240x240+1572+150 240x240+200+360; do
      oiiotool "$T/$row.png" --cut "$cut" --ch R,G,B -o "$T/$row-$cut.png"
      tiles+=("$T/$row-$cut.png")
    done
  done
  oiiotool "${tiles[@]}" --mosaic:pad=4 4x3 -o "$OUT/knot_crops_gran1.png"
  oiiotool "$T/after.png" --resize 1200x300 --ch R,G,B -o "$OUT/gran1_whorl_board.png"
fi
ls -l "$OUT"

#!/usr/bin/env bash
# The README's first command: installs what is missing, builds sawyer, and runs the main job on
# the bundled real spruce log. Safe to run again: set-up and build are incremental.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DSAWYER_BUILD_TESTS=OFF >/dev/null
cmake --build build --target sawyer
echo
build/apps/sawyer/sawyer info sample_logs/gran1_spruce/log.json
echo
# CT in and out: half a metre of the same log as a scanner would see it, then read back.
build/apps/sawyer/sawyer phantom sample_logs/gran1_spruce/log.json -o out/demo_ct \
  --from-mm 1000 --to-mm 1500 --seed 1
echo
build/apps/sawyer/sawyer info out/demo_ct
echo
# Analysis of that scan: pith, outer shape, heartwood and knots, with QA images.
rm -rf out/demo_scan
build/apps/sawyer/sawyer scan out/demo_ct -o out/demo_scan
echo
# The scanned model rendered headless with the knotted-wood shader: the four long faces of a
# 150 x 40 mm board 40 mm above the pith, over the scanned half metre (the scan's own frame:
# z from 0 at its first slice).
build/apps/sawyer/sawyer render out/demo_scan/log.json -o out/demo_board.png \
  --board "0,40,150,40,0,0,500" --size 1200
echo "board faces of the scanned log: out/demo_board.png"

#!/usr/bin/env bash
# The README's first command: installs what is missing, builds sawyer, and runs the main job on
# the bundled real spruce log: CT folder in, cutting report out. Safe to run again: set-up and
# build are incremental, and the CT scan is generated once.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DSAWYER_BUILD_TESTS=OFF >/dev/null
cmake --build build --target sawyer
SAWYER=build/apps/sawyer/sawyer
echo
$SAWYER info sample_logs/gran1_spruce/log.json
echo
# The bundled log as a CT scanner would see it: a DICOM series of the whole 4 m log at 5 mm
# slices, synthesised from its real measured geometry (pith, outer shape, 108 knots; see
# sample_logs/README.md). Generated on the first run only (a few minutes), with its ground truth
# in out/gran1_ct/truth/.
if [ ! -f out/gran1_ct/truth/phantom.json ]; then
  echo "first run: synthesising the CT scan of the bundled log into out/gran1_ct (a few minutes)"
  $SAWYER phantom sample_logs/gran1_spruce/log.json -o out/gran1_ct --seed 1
  echo
fi
# The main job: scan (pith, outer shape, knots), the best sawing position, the cutting report
# (PDF, HTML, CSV, JSON with images) and the log register.
$SAWYER run out/gran1_ct -o out/gran1 --id gran1_spruce --species spruce
echo
$SAWYER logs --id gran1_spruce
echo
echo "cutting report: $PWD/out/gran1/report/report.pdf"
echo "                $PWD/out/gran1/report/report.html"

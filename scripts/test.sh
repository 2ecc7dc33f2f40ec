#!/usr/bin/env bash
# The README's second command (and what CI runs): installs what is missing, builds everything
# with the tests, and runs the whole suite. Build folder: build-test/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
cmake -S . -B build-test -G Ninja -DCMAKE_BUILD_TYPE=Release -DSAWYER_BUILD_TESTS=ON >/dev/null
cmake --build build-test
# With no display, the suite runs inside a virtual X server (Xvfb, installed above) so that the
# window tests run too; the headless renderer uses EGL either way.
run=()
if [ -z "${DISPLAY:-}" ] && command -v xvfb-run >/dev/null; then
  run=(xvfb-run -a -s "-screen 0 1280x1024x24")
fi
"${run[@]}" ctest --test-dir build-test --output-on-failure -j "$(nproc)"

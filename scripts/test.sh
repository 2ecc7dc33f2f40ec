#!/usr/bin/env bash
# The README's second command (and what CI runs): installs what is missing, builds everything
# with the tests, and runs the whole suite. Build folder: build-test/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
cmake -S . -B build-test -G Ninja -DCMAKE_BUILD_TYPE=Release -DSAWYER_BUILD_TESTS=ON >/dev/null
cmake --build build-test
ctest --test-dir build-test --output-on-failure -j "$(nproc)"

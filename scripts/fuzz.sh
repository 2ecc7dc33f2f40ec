#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan + UBSan) in build-fuzz/ and runs each for the
# given number of seconds (default 180), starting from the seed corpora under tests/corpus/.
# New crashes land in build-fuzz/crashes/<target>/.
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_PER_TARGET="${1:-180}"
scripts/install_deps.sh
for p in clang libclang-rt-14-dev; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get install -y -qq --no-install-recommends clang libclang-rt-14-dev
    break
  fi
done
CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DSAWYER_BUILD_TESTS=OFF -DSAWYER_BUILD_FUZZERS=ON >/dev/null
cmake --build build-fuzz --target fuzz_dicom fuzz_image_stack fuzz_vtk_volume fuzz_sawing_files fuzz_sawing_record fuzz_log_json fuzz_sidecar
for t in fuzz_dicom fuzz_image_stack fuzz_vtk_volume fuzz_sawing_files fuzz_sawing_record fuzz_log_json fuzz_sidecar; do
  mkdir -p "build-fuzz/corpus/$t" "build-fuzz/crashes/$t"
  dirs=("build-fuzz/corpus/$t")
  [ -d "tests/fuzz/corpus/$t" ] && dirs+=("tests/fuzz/corpus/$t")
  echo "== $t: ${SECONDS_PER_TARGET}s"
  LSAN_OPTIONS=suppressions=$PWD/tests/fuzz/lsan.supp \
  "build-fuzz/tests/fuzz/$t" -max_total_time="$SECONDS_PER_TARGET" -rss_limit_mb=2048 \
    -artifact_prefix="build-fuzz/crashes/$t/" "${dirs[@]}" \
    2>&1 | grep -E "^#[0-9]+[[:space:]]+(DONE|INITED)|ERROR|SUMMARY|Test unit written|Done [0-9]+ runs" || true
done

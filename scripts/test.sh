#!/usr/bin/env bash
# The README's second command (and what CI runs): installs what is missing, builds everything
# with the tests, and runs the whole suite. Build folder: build-test/.
#
#   scripts/test.sh              Release build, the whole suite
#   scripts/test.sh --sanitize   the same suite built with AddressSanitizer + UndefinedBehavior-
#                                Sanitizer in build-asan/ (-O1, asserts on); any report fails the
#                                test that caused it. Slow: about 3x the build and the run.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=release
case "${1:-}" in
  "") ;;
  --sanitize) mode=sanitize ;;
  *) echo "usage: scripts/test.sh [--sanitize]" >&2; exit 1 ;;
esac
scripts/install_deps.sh
if [ "$mode" = sanitize ]; then
  dir=build-asan
  cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1" "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O1 -g1" \
    -DSAWYER_BUILD_TESTS=ON -DSAWYER_SANITIZE=ON >/dev/null
  # Every ASan or UBSan report fails the test that caused it. Leak checking is a second pass
  # below: a process that makes a GL context loses 112 bytes inside Mesa's driver, which is
  # unloaded before the leak check and so cannot be named in a suppression.
  export ASAN_OPTIONS="detect_leaks=0:abort_on_error=0:allocator_may_return_null=1"
  export LSAN_OPTIONS="suppressions=$PWD/scripts/sanitize.supp:print_suppressions=0"
  export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
else
  dir=build-test
  cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DSAWYER_BUILD_TESTS=ON >/dev/null
fi
cmake --build "$dir"
# With no display, the suite runs inside a virtual X server (Xvfb, installed above) so that the
# window tests run too; the headless renderer uses EGL either way.
run=()
if [ -z "${DISPLAY:-}" ] && command -v xvfb-run >/dev/null; then
  run=(xvfb-run -a -s "-screen 0 1280x1024x24")
fi
# Tests labelled root (SlurmJobArray: installs Slurm, starts its daemons) run only as root.
not_root=()
if [ "$(id -u)" -ne 0 ]; then not_root=(-LE root); fi
"${run[@]}" ctest --test-dir "$dir" --output-on-failure -j "$(nproc)" "${not_root[@]}"
if [ "$mode" = sanitize ]; then
  # The leak pass: every test whose processes never open a GL context (no renderer, report,
  # viewer, window, `sawyer run`, which writes the report, or `sawyer export`).
  gl='Render|Viewer|Report|RunCli|Batch|PublishedRender|DataLoss|Interrupt|Concurrency|InventedSlices|Register.AFailed|RenderLimits|LogJsonLimits.EveryCommand|Export|BoardBake|OslField|SlurmJobArray'
  ASAN_OPTIONS="detect_leaks=1:allocator_may_return_null=1" \
    "${run[@]}" ctest --test-dir "$dir" --output-on-failure -j "$(nproc)" -E "$gl" "${not_root[@]}"
fi

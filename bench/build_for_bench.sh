# Sourced by the bench drivers: bench_build BUILD TARGET... configures BUILD (an existing build
# folder keeps its options, so build-test keeps its tests; a new one skips them) and builds the
# targets, quietly.
bench_build() {
  local build=$1
  shift
  local tests_flag=()
  [ -f "$build/CMakeCache.txt" ] || tests_flag=(-DSAWYER_BUILD_TESTS=OFF)
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release "${tests_flag[@]}" >/dev/null
  cmake --build "$build" --target "$@" >/dev/null
}

// Stage marks for the performance gate (bench/perf_gate): under valgrind's callgrind, each mark
// closes a stage, so that the instructions executed since the previous mark (on every thread)
// are written as one dump named after the stage. Outside valgrind a mark costs a handful of
// instructions and does nothing; a build without valgrind's callgrind.h has no marks at all.
#pragma once

namespace sawyer {

// Ends the stage `name` (the work since the last mark, or since the process started). `name`
// is what bench/perf_baseline.json calls it: keep the names stable.
void mark_stage_end(const char* name);

}  // namespace sawyer

#include "sawyer/core/instruction_count.h"

#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#define SAWYER_HAVE_CALLGRIND 1
#else
#define SAWYER_HAVE_CALLGRIND 0
#endif

namespace sawyer {

void mark_stage_end(const char* name) {
#if SAWYER_HAVE_CALLGRIND
  CALLGRIND_DUMP_STATS_AT(name);
#else
  (void)name;
#endif
}

}  // namespace sawyer

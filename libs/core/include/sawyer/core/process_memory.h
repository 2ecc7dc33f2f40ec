// The process's own memory: giving freed heap back to the system between stages.
#pragma once

namespace sawyer {

// Gives the heap's free pages back to the system (glibc's malloc_trim; nothing elsewhere). For
// after a stage freed much memory that later allocations would not reuse: what other threads'
// heaps held (the stem pass's workers), or freed GL objects and models that sat between later
// allocations (the report).
void release_free_memory();

}  // namespace sawyer

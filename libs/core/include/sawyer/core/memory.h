// The process's memory, as the system sees it.
#pragma once

namespace sawyer {

// Gives the pages of freed memory back to the system. glibc keeps them in its heap otherwise,
// where a finished stage's arrays sat between later allocations, and the process's resident
// size (what a memory budget counts) stays as if they were still held. A no-op elsewhere.
void release_free_memory();

}  // namespace sawyer

// A content hash of a CT scan, so the register can tell a re-scan of the same data from new data
// under the same path.
#pragma once

#include <filesystem>
#include <string>

#include "sawyer/core/result.h"

namespace sawyer::reg {

// "xxh3-64:<16 hex digits>" over the scan's bytes. For a folder: the files the CT readers read,
// i.e. every regular file directly in it whose name does not start with '.' (a link to a file
// counts as that file; sub-folders, links to folders, FIFOs and devices are not read), sorted
// by name, each contributing its name, its size and its contents, so renaming, adding, removing
// or changing one byte of any such file changes the hash. For a single regular file (.mha,
// .vti, .nrrd...): its contents only; anything else is refused.
// Streams the files in 1 MiB blocks: memory does not grow with the scan; the speed is the
// disk's (docs/batch.md has the figures). Errors name the path that could not be read.
Result<std::string> ct_checksum(const std::filesystem::path& ct);

}  // namespace sawyer::reg

// Small file helpers shared by every writer: whole-file reads and atomic writes.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

#include "sawyer/core/result.h"

namespace sawyer {

// Reads a whole file. Errors name the file.
Result<std::string> read_text_file(const std::filesystem::path& path);

// Writes `text` to `path` atomically: a temporary file beside it, then a rename, so a failure
// never leaves a half-written file under the final name.
Status write_text_file_atomic(const std::filesystem::path& path, const std::string& text);

// Runs `write_to(tmp)` for a temporary path beside `path`, then renames tmp to path. If the
// callback fails, the temporary file is removed and the error is returned unchanged.
Status write_file_atomic(const std::filesystem::path& path,
                         const std::function<Status(const std::filesystem::path&)>& write_to);

// Creates `dir` with the files written by `fill(tmp_dir)` atomically: `fill` writes into a
// temporary sibling folder, which then replaces `dir` (an existing `dir` is replaced whole).
Status write_dir_atomic(const std::filesystem::path& dir,
                        const std::function<Status(const std::filesystem::path&)>& fill);

}  // namespace sawyer

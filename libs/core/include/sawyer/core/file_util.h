// Small file helpers shared by every writer: whole-file reads and atomic writes.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "sawyer/core/result.h"

namespace sawyer {

// The most read_text_file reads unless told otherwise: far above any log.json, manifest or
// settings file Sawyer reads, far below what would strain memory.
inline constexpr std::uintmax_t kMaxTextFileBytes = 256u << 20;  // 256 MiB

// Reads a whole file the user named, its type and size checked before a byte is read: a FIFO
// would block the reader, a device such as /dev/zero never ends, a huge file would be read whole
// into memory. One error naming the path: no such file, a folder, not a regular file (FIFO,
// device, socket), more than `max_bytes` bytes, or a failed read. Symbolic links are followed.
//
//   Result<std::string> text = read_text_file(path, 1 << 20);  // at most 1 MiB
Result<std::string> read_text_file(const std::filesystem::path& path,
                                   std::uintmax_t max_bytes = kMaxTextFileBytes);

// "line N" for the 1-based byte offset `byte` of `text` (as JSON parsers report positions), for
// messages about a file's contents.
std::string line_of(const std::string& text, size_t byte);

// "1 MiB", "512 MiB", "1.5 KiB": a byte count for messages.
std::string byte_size_text(std::uintmax_t bytes);

// The longest file name most Linux file systems take (NAME_MAX of ext4, XFS, Btrfs, tmpfs).
inline constexpr size_t kMaxFileNameBytes = 255;

// ".<name>" for the hidden siblings an output at `path` gets while it is written: its
// temporaries ".<name>.tmp<16 hex>" (and ".old" after them), its lock ".<name>.lock". A name too
// long for those to fit in kMaxFileNameBytes (over 230 bytes) is shortened to its first bytes
// (whole UTF-8 characters), '~' and 16 hex digits of a hash of the whole name, so an output
// name up to the file system's limit can be written, and two long names that share their
// first bytes still get siblings of their own.
std::string hidden_sibling_stem(const std::filesystem::path& path);

// A fresh temporary path beside `path`: hidden_sibling_stem(path) + ".tmp" + 16 random hex digits.
std::filesystem::path temp_sibling(const std::filesystem::path& path);

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

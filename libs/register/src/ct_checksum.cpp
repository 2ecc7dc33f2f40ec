#include "sawyer/register/ct_checksum.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <system_error>
#include <utility>
#include <vector>

namespace sawyer::reg {
namespace fs = std::filesystem;

namespace {

struct StateDeleter {
  void operator()(XXH3_state_t* s) const { XXH3_freeState(s); }
};
using State = std::unique_ptr<XXH3_state_t, StateDeleter>;

std::string errno_text(int e) { return std::error_code(e, std::generic_category()).message(); }

// Streams one file into the hash with plain read(2): no stdio buffering on top of the block we
// hand to XXH3, and the kernel told we read front to back (bigger read-ahead).
Status hash_file(XXH3_state_t* state, const fs::path& path, std::vector<char>& buf,
                 std::uint64_t* size_out) {
  // O_NONBLOCK: a file swapped for a FIFO after it was listed must not block the open; fstat
  // then refuses anything that is not a regular file.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) return Error(path.string(), "cannot open: " + errno_text(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return Error(path.string(), "not a regular file");
  }
  // Back to blocking reads for the regular file (O_NONBLOCK means nothing for it on Linux, but
  // other file systems may honour it).
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  ::posix_fadvise(fd, 0, 0, POSIX_FADV_SEQUENTIAL);
  std::uint64_t total = 0;
  for (;;) {
    const ssize_t n = ::read(fd, buf.data(), buf.size());
    if (n == 0) break;
    if (n < 0) {
      if (errno == EINTR) continue;
      const int e = errno;
      ::close(fd);
      return Error(path.string(), "read failed: " + errno_text(e));
    }
    XXH3_64bits_update(state, buf.data(), static_cast<size_t>(n));
    total += static_cast<std::uint64_t>(n);
  }
  ::close(fd);
  if (size_out) *size_out = total;
  return Status::Ok();
}

std::string format_digest(XXH64_hash_t h) {
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return std::string("xxh3-64:") + hex;
}

}  // namespace

Result<std::string> ct_checksum(const fs::path& ct) {
  std::error_code ec;
  const fs::file_status st = fs::status(ct, ec);
  if (ec || !fs::exists(st)) return Error(ct.string(), "no such file or folder");
  State state(XXH3_createState());
  if (!state) return Error(ct.string(), "out of memory for the checksum state");
  XXH3_64bits_reset(state.get());
  std::vector<char> buf(1 << 20);

  if (fs::is_regular_file(st)) {
    if (Status s = hash_file(state.get(), ct, buf, nullptr); !s) return s.error();
    return format_digest(XXH3_64bits_digest(state.get()));
  }
  if (!fs::is_directory(st)) return Error(ct.string(), "neither a file nor a folder");

  // What a scan folder holds is what the CT readers read (open_ct, the DICOM and stack readers
  // list the folder the same way): the regular files directly in it whose names do not start
  // with '.', a symbolic link counting as the file it points to. Sub-folders (a phantom's truth/,
  // a viewer's cache) and links to folders are not part of the scan and are never entered, so a
  // link loop (`ln -s . a`) cannot make the checksum read forever; FIFOs, sockets and devices
  // are skipped, so nothing here blocks on an open() or reads an endless stream.
  // Sorted names: the hash must not depend on the order the file system lists them in.
  std::vector<std::pair<std::string, fs::path>> files;
  for (fs::directory_iterator it(ct, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.starts_with(".")) continue;
    std::error_code fec;
    if (!it->is_regular_file(fec)) continue;
    files.emplace_back(name, it->path());
  }
  if (ec) return Error(ct.string(), "cannot list the folder: " + ec.message());
  std::sort(files.begin(), files.end());

  for (const auto& [rel, path] : files) {
    // Path, NUL, then contents, then the size: the size after the contents keeps file
    // boundaries unambiguous without a second stat that could race with a writer.
    XXH3_64bits_update(state.get(), rel.data(), rel.size() + 1);  // with the terminating NUL
    std::uint64_t size = 0;
    if (Status s = hash_file(state.get(), path, buf, &size); !s) return s.error();
    unsigned char le[8];
    for (int i = 0; i < 8; ++i) le[i] = static_cast<unsigned char>(size >> (8 * i));
    XXH3_64bits_update(state.get(), le, sizeof le);
  }
  return format_digest(XXH3_64bits_digest(state.get()));
}

}  // namespace sawyer::reg

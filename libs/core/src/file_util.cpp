#include "sawyer/core/file_util.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <random>
#include <sstream>
#include <system_error>

#include "sawyer/core/interrupt.h"

namespace sawyer {
namespace fs = std::filesystem;

namespace {

// The longest tail a sibling adds after the stem: ".tmp", 16 hex digits, ".old".
constexpr size_t kSiblingTailBytes = 4 + 16 + 4;

// Closes the descriptor on every return path.
struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

const char* kind_of(mode_t mode) {
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "a device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

}  // namespace

std::string hidden_sibling_stem(const fs::path& path) {
  const std::string name = path.filename().string();
  if (1 + name.size() + kSiblingTailBytes <= kMaxFileNameBytes) return "." + name;
  // FNV-1a over the whole name: two names that share the kept bytes still differ.
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (unsigned char c : name) {
    h ^= c;
    h *= 0x100000001b3ull;
  }
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  // "." + kept + "~" + 16 hex + the tail fits; the cut falls before a UTF-8 continuation byte.
  size_t keep = kMaxFileNameBytes - kSiblingTailBytes - 1 - 1 - 16;
  while (keep > 0 && (static_cast<unsigned char>(name[keep]) & 0xC0) == 0x80) --keep;
  std::string stem(1, '.');
  stem.append(name, 0, keep);
  stem += '~';
  stem += hex;
  return stem;
}

fs::path temp_sibling(const fs::path& path) {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  std::ostringstream name;
  name << hidden_sibling_stem(path) << ".tmp" << std::hex << std::setw(16) << std::setfill('0')
       << rng();
  return path.parent_path() / name.str();
}

std::string line_of(const std::string& text, size_t byte) {
  size_t line = 1;
  for (size_t i = 0; i + 1 < byte && i < text.size(); ++i)
    if (text[i] == '\n') ++line;
  return "line " + std::to_string(line);
}

std::string byte_size_text(std::uintmax_t bytes) {
  std::ostringstream os;
  if (bytes >= (1u << 20) && bytes % (1u << 20) == 0)
    os << bytes / (1u << 20) << " MiB";
  else if (bytes >= (1u << 20))
    os << static_cast<double>(bytes) / (1u << 20) << " MiB";
  else if (bytes >= 1024)
    os << static_cast<double>(bytes) / 1024 << " KiB";
  else
    os << bytes << " bytes";
  return os.str();
}

Result<std::string> read_text_file(const fs::path& path, std::uintmax_t max_bytes) {
  const std::string name = path.string();
  // stat() first, so that a device or FIFO is never even opened; the same checks on the open
  // descriptor below catch a file swapped in between.
  struct stat st {};
  if (::stat(name.c_str(), &st) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) return Error(name, "no such file");
    return Error(name, std::string("cannot read: ") + std::strerror(errno));
  }
  if (S_ISDIR(st.st_mode)) return Error(name, "is a folder, expected a file");
  auto check = [&](const struct stat& s) -> Status {
    if (!S_ISREG(s.st_mode))
      return Error(name, std::string("is ") + kind_of(s.st_mode) + ", expected a regular file");
    if (static_cast<std::uintmax_t>(s.st_size) > max_bytes)
      return Error(name, "is " + std::to_string(s.st_size) + " bytes, more than the " +
                             byte_size_text(max_bytes) + " allowed for this file");
    return Status::Ok();
  };
  if (Status s = check(st); !s) return s.error();
  // O_NONBLOCK: opening a FIFO that replaced the file would otherwise wait for a writer.
  Fd f{::open(name.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC)};
  if (f.fd < 0) return Error(name, std::string("cannot open for reading: ") + std::strerror(errno));
  if (::fstat(f.fd, &st) != 0)
    return Error(name, "cannot read: " + std::string(std::strerror(errno)));
  if (Status s = check(st); !s) return s.error();
  std::string text;
  text.resize(static_cast<size_t>(st.st_size));
  size_t got = 0;
  // One byte past the stated size tells a file that grows while it is read.
  while (true) {
    if (got == text.size()) {
      if (text.size() > max_bytes)
        return Error(name, "grew past " + byte_size_text(max_bytes) + " while read");
      text.resize(text.size() + 1 + text.size() / 2);
    }
    const ssize_t n = ::read(f.fd, text.data() + got, text.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return Error(name, std::string("read failed: ") + std::strerror(errno));
    if (n == 0) break;
    got += static_cast<size_t>(n);
  }
  if (got > max_bytes) return Error(name, "grew past " + byte_size_text(max_bytes) + " while read");
  text.resize(got);
  return text;
}

Status write_file_atomic(const fs::path& path,
                         const std::function<Status(const fs::path&)>& write_to) {
  std::error_code ec;
  if (!path.parent_path().empty()) {
    fs::create_directories(path.parent_path(), ec);
    if (ec) return Error(path.parent_path().string(), "cannot create folder: " + ec.message());
  }
  const fs::path tmp = temp_sibling(path);
  TrackedTemp tracked(tmp);
  Status st = write_to(tmp);
  if (!st) {
    fs::remove(tmp, ec);
    return st;
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    return Error(path.string(), "cannot move the written file into place");
  }
  return Status::Ok();
}

Status write_text_file_atomic(const fs::path& path, const std::string& text) {
  return write_file_atomic(path, [&](const fs::path& tmp) -> Status {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return Error(path.string(), "cannot open for writing");
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
    out.close();
    if (!out) return Error(path.string(), "write failed (disk full?)");
    return Status::Ok();
  });
}

Status write_dir_atomic(const fs::path& dir, const std::function<Status(const fs::path&)>& fill) {
  std::error_code ec;
  const fs::path parent = dir.parent_path().empty() ? fs::path(".") : dir.parent_path();
  fs::create_directories(parent, ec);
  if (ec) return Error(parent.string(), "cannot create folder: " + ec.message());
  const fs::path tmp = temp_sibling(dir);
  TrackedTemp tracked(tmp);
  fs::create_directories(tmp, ec);
  if (ec) return Error(dir.string(), "cannot create a temporary folder: " + ec.message());
  Status st = fill(tmp);
  if (!st) {
    fs::remove_all(tmp, ec);
    return st;
  }
  if (fs::exists(dir, ec)) {
    const fs::path old = temp_sibling(dir);
    fs::rename(dir, old, ec);
    if (ec) {
      fs::remove_all(tmp, ec);
      return Error(dir.string(), "cannot replace the existing folder");
    }
    fs::rename(tmp, dir, ec);
    if (ec) {
      fs::rename(old, dir, ec);
      fs::remove_all(tmp, ec);
      return Error(dir.string(), "cannot move the written folder into place");
    }
    fs::remove_all(old, ec);
    return Status::Ok();
  }
  fs::rename(tmp, dir, ec);
  if (ec) {
    fs::remove_all(tmp, ec);
    return Error(dir.string(), "cannot move the written folder into place");
  }
  return Status::Ok();
}

}  // namespace sawyer

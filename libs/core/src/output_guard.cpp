#include "sawyer/core/output_guard.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <system_error>

#include "sawyer/core/file_util.h"
#include "sawyer/core/interrupt.h"

namespace sawyer {
namespace fs = std::filesystem;

namespace {

// Absolute, normal, symlinks resolved as far as the path exists, no trailing separator.
fs::path resolved(const fs::path& p) {
  std::error_code ec;
  fs::path a = fs::absolute(p, ec);
  if (ec) a = p;
  a = a.lexically_normal();
  if (a.filename().empty() && a.has_parent_path() && a != a.root_path()) a = a.parent_path();
  fs::path c = fs::weakly_canonical(a, ec);
  return ec ? a : c;
}

// True when `inner` is `outer` or lies below it (both resolved).
bool within(const fs::path& inner, const fs::path& outer) {
  auto i = inner.begin();
  for (auto o = outer.begin(); o != outer.end(); ++o, ++i) {
    if (o->empty()) continue;  // a trailing separator
    if (i == inner.end() || *i != *o) return false;
  }
  return true;
}

// The first bytes of a small regular file, or "" when it is not one.
std::string head_of(const fs::path& file, size_t max_bytes = 64 * 1024) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) return "";
  std::ifstream in(file, std::ios::binary);
  std::string s(max_bytes, '\0');
  in.read(s.data(), static_cast<std::streamsize>(max_bytes));
  s.resize(static_cast<size_t>(std::max<std::streamsize>(0, in.gcount())));
  return s;
}

bool file_mentions(const fs::path& file, const std::string& tag) {
  return head_of(file).find(tag) != std::string::npos;
}

std::string where_of(const OutputRequest& req) {
  return req.option.empty() ? req.path.string() : req.option + " " + req.path.string();
}

// ".<name><suffix>": the hidden siblings (temporaries, lock) of an output, the name shortened
// as hidden_sibling_stem says.
std::string hidden_sibling(const fs::path& p, const char* suffix) {
  return hidden_sibling_stem(p) + suffix;
}

bool is_hex(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s)
    if (!std::isxdigit(static_cast<unsigned char>(c))) return false;
  return true;
}

}  // namespace

const char* output_kind_name(OutputKind kind) {
  switch (kind) {
    case OutputKind::kRunFolder:
      return "a run folder";
    case OutputKind::kScanFolder:
      return "a scan folder";
    case OutputKind::kPhantomFolder:
      return "a phantom folder";
    case OutputKind::kMapsFolder:
      return "a maps folder";
    case OutputKind::kBatchFolder:
      return "a batch folder";
    case OutputKind::kFile:
      return "a file";
  }
  return "an output";
}

bool is_sawyer_output(const fs::path& dir, OutputKind kind) {
  std::error_code ec;
  switch (kind) {
    case OutputKind::kRunFolder:
      return file_mentions(dir / "run.json", "\"sawyer-run/");
    case OutputKind::kScanFolder:
      return file_mentions(dir / "log.json", "\"sawyer-log/");
    case OutputKind::kPhantomFolder:
      return fs::is_regular_file(dir / "truth" / "phantom.json", ec);
    case OutputKind::kMapsFolder:
      return file_mentions(dir / "sawyer_maps.json", "\"format\"") ||
             file_mentions(dir / "float_maps.json", "\"sawyer-float-maps/");
    case OutputKind::kBatchFolder: {
      // A batch_<i>.csv, or a logs/ holding nothing but the runs' .out/.err files: a folder of
      // the user's that merely has a logs/ sub-folder is not a batch folder.
      for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string n = it->path().filename().string();
        if (n.starts_with("batch_") && n.ends_with(".csv")) return true;
      }
      if (!fs::is_directory(dir / "logs", ec)) return false;
      for (fs::directory_iterator it(dir / "logs", ec), end; !ec && it != end; it.increment(ec)) {
        const std::string n = it->path().filename().string();
        if (!it->is_regular_file(ec) || !(n.ends_with(".out") || n.ends_with(".err"))) return false;
      }
      return !ec;
    }
    case OutputKind::kFile:
      return fs::is_regular_file(dir, ec);
  }
  return false;
}

Status check_output(const OutputRequest& req) {
  const std::string where = where_of(req);
  if (req.path.empty()) return Error(req.option, "is empty; give a path to write");
  const fs::path out = resolved(req.path);
  if (out == out.root_path()) return Error(where, "is the root folder; give a path to write");
  const bool folder_kind = req.kind != OutputKind::kFile;

  for (const fs::path& in_raw : req.inputs) {
    if (in_raw.empty()) continue;
    const fs::path in = resolved(in_raw);
    if (in == out)
      return Error(where, "is the input; give another " +
                              std::string(folder_kind ? "folder" : "file") + " to write");
    if (within(in, out))
      return Error(where, "holds the input " + in_raw.string() +
                              "; writing there would replace it (give another folder)");
    std::error_code ec;
    if (within(out, in) && fs::is_directory(in, ec))
      return Error(where, "lies inside the input folder " + in_raw.string() +
                              "; write the output somewhere else");
  }

  std::error_code ec;
  const fs::file_status st = fs::status(out, ec);
  if (!fs::exists(st)) return Status::Ok();
  if (!folder_kind) {
    if (fs::is_directory(st)) return Error(where, "is a folder; give a file name to write");
    if (!fs::is_regular_file(st))
      return Error(where, "is not a regular file (a device, FIFO or socket); will not replace it");
    return Status::Ok();
  }
  if (!fs::is_directory(st))
    return Error(where, std::string("is a file, not a folder; will not replace it (give a folder "
                                    "to write ") +
                            output_kind_name(req.kind) + " into)");
  if (fs::is_empty(out, ec) && !ec) return Status::Ok();
  if (is_sawyer_output(out, req.kind)) return Status::Ok();
  return Error(where, std::string("is not empty and is not ") + output_kind_name(req.kind) +
                          " that Sawyer wrote; Sawyer replaces only its own output (give a new "
                          "or empty folder)");
}

int sweep_stale_temps(const fs::path& path) {
  const fs::path p = resolved(path);
  const fs::path parent = p.parent_path();
  const std::string prefix = hidden_sibling(p, ".tmp");
  int removed = 0;
  std::error_code ec;
  std::vector<fs::path> stale;
  for (fs::directory_iterator it(parent, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string n = it->path().filename().string();
    if (!n.starts_with(prefix)) continue;
    std::string rest = n.substr(prefix.size());
    if (rest.ends_with(".old")) rest.resize(rest.size() - 4);
    if (is_hex(rest)) stale.push_back(it->path());
  }
  for (const fs::path& s : stale) {
    std::error_code rec;
    if (fs::remove_all(s, rec) > 0 && !rec) ++removed;
  }
  return removed;
}

Result<OutputLock> OutputLock::lock_only(const fs::path& path, const std::string& option) {
  const fs::path p = resolved(path);
  const std::string where = option.empty() ? path.string() : option + " " + path.string();
  std::error_code ec;
  fs::create_directories(p.parent_path(), ec);
  if (ec) return Error(p.parent_path().string(), "cannot create folder: " + ec.message());
  const fs::path lock_path = p.parent_path() / hidden_sibling(p, ".lock");
  for (int attempt = 0; attempt < 5; ++attempt) {
    const int fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (fd < 0)
      return Error(lock_path.string(),
                   std::string("cannot create the lock file: ") + std::strerror(errno));
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      char buf[32] = {};
      const ssize_t n = ::pread(fd, buf, sizeof buf - 1, 0);
      ::close(fd);
      if (err == EWOULDBLOCK) {
        std::string pid = n > 0 ? std::string(buf, static_cast<size_t>(n)) : "";
        while (!pid.empty() && !std::isdigit(static_cast<unsigned char>(pid.back())))
          pid.pop_back();
        return Error(where, "is being written by another Sawyer process" +
                                (pid.empty() ? std::string() : " (pid " + pid + ")") +
                                "; wait for it to finish or choose another output");
      }
      return Error(lock_path.string(), std::string("cannot lock: ") + std::strerror(err));
    }
    // The holder before us may have removed the file after we opened it: then our lock is on
    // a file nobody else sees, so start again on the one at the path.
    struct stat a {
    }, b{};
    if (::fstat(fd, &a) != 0 || ::stat(lock_path.c_str(), &b) != 0 || a.st_ino != b.st_ino ||
        a.st_dev != b.st_dev) {
      ::close(fd);
      continue;
    }
    const std::string pid = std::to_string(::getpid()) + "\n";
    if (::ftruncate(fd, 0) == 0) {
      [[maybe_unused]] ssize_t w = ::pwrite(fd, pid.data(), pid.size(), 0);
    }
    track_temp_path(lock_path);
    return OutputLock(fd, lock_path, sweep_stale_temps(p));
  }
  return Error(where, "cannot take the output lock (it keeps changing); try again");
}

Result<OutputLock> OutputLock::acquire(const OutputRequest& req) {
  if (Status st = check_output(req); !st) return st.error();
  return lock_only(req.path, req.option);
}

OutputLock::OutputLock(OutputLock&& other) noexcept
    : fd_(other.fd_), lock_path_(std::move(other.lock_path_)), swept_(other.swept_) {
  other.fd_ = -1;
  other.lock_path_.clear();
}

OutputLock& OutputLock::operator=(OutputLock&& other) noexcept {
  if (this != &other) {
    release();
    fd_ = other.fd_;
    lock_path_ = std::move(other.lock_path_);
    swept_ = other.swept_;
    other.fd_ = -1;
    other.lock_path_.clear();
  }
  return *this;
}

OutputLock::~OutputLock() { release(); }

void OutputLock::release() {
  if (fd_ < 0) return;
  // Unlink while still holding the lock; a process that opened the old file then finds its
  // inode gone and retries on a fresh one (see lock_only).
  ::unlink(lock_path_.c_str());
  untrack_temp_path(lock_path_);
  ::close(fd_);
  fd_ = -1;
}

}  // namespace sawyer

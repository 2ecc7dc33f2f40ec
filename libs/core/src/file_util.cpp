#include "sawyer/core/file_util.h"

#include <fstream>
#include <random>
#include <sstream>
#include <system_error>

namespace sawyer {
namespace fs = std::filesystem;

namespace {

fs::path temp_sibling(const fs::path& path) {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  std::ostringstream name;
  name << "." << path.filename().string() << ".tmp" << std::hex << rng();
  return path.parent_path() / name.str();
}

}  // namespace

Result<std::string> read_text_file(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return Error(path.string(), "no such file");
  if (fs::is_directory(path, ec)) return Error(path.string(), "is a folder, expected a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error(path.string(), "cannot open for reading");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) return Error(path.string(), "read failed");
  return ss.str();
}

Status write_file_atomic(const fs::path& path,
                         const std::function<Status(const fs::path&)>& write_to) {
  std::error_code ec;
  if (!path.parent_path().empty()) {
    fs::create_directories(path.parent_path(), ec);
    if (ec) return Error(path.parent_path().string(), "cannot create folder: " + ec.message());
  }
  const fs::path tmp = temp_sibling(path);
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

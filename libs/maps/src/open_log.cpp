// Opening a log model from any of the sources Sawyer reads (see open_log.h).
#include "sawyer/maps/open_log.h"

#include "sawyer/maps/float_maps.h"

#include "sawyer/maps/float_maps.h"
#include "sawyer/maps/published_maps.h"
#include "sawyer/model/gran1_import.h"
#include "sawyer/model/log_json.h"

namespace sawyer::maps {
namespace fs = std::filesystem;

namespace {

// Stem-bank name prefix of <name>_pith.json in `dir`, or empty.
std::string stem_bank_name(const fs::path& dir) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string f = e.path().filename().string();
    const std::string suffix = "_pith.json";
    if (f.size() > suffix.size() && f.compare(f.size() - suffix.size(), suffix.size(), suffix) == 0)
      return f.substr(0, f.size() - suffix.size());
  }
  return {};
}

}  // namespace

Result<std::string> detect_log_source(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return Error(path.string(), "no such file or folder");
  if (fs::is_regular_file(path, ec)) {
    if (path.extension() == ".json") return std::string("log.json");
    return Error(path.string(), "not a log model (expected log.json or a folder of maps)");
  }
  // A FIFO or a device would block or never end in a reader.
  if (!fs::is_directory(path, ec))
    return Error(path.string(), "is not a regular file or a folder (a FIFO, device or socket?)");
  if (fs::exists(path / "log.json", ec)) return std::string("log folder");
  if (fs::exists(path / "map_params.json", ec)) return std::string("published maps");
  if (fs::exists(path / "float_maps.json", ec)) return std::string("float maps");
  if (!stem_bank_name(path).empty()) return std::string("stem bank");
  return Error(path.string(),
               "folder holds no log.json, published maps (map_params.json), float maps or "
               "<name>_pith.json stem-bank files");
}

Result<LogModel> open_log(const fs::path& path) {
  Result<std::string> kind = detect_log_source(path);
  if (!kind) return kind.error();
  const std::string& k = kind.value();
  if (k == "log.json") return read_log_json(path);
  if (k == "log folder") return read_log_json(path / "log.json");
  if (k == "stem bank") return import_gran1(path, stem_bank_name(path));
  if (k == "published maps") return import_published_maps(path);
  if (k == "float maps") return import_float_maps(path);
  return Error(path.string(), k + " are not supported by this build");
}

}  // namespace sawyer::maps

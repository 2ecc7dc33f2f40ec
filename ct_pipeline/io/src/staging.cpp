// The staging folder that makes the DICOM, stack and volume writers all-or-nothing: a hidden
// sibling of the output that is filled and then renamed into place, or removed.
#include "staging.h"

#include <random>
#include <sstream>
#include <system_error>

#include "sawyer/core/file_util.h"
#include "sawyer/core/interrupt.h"

namespace sawyer::ct::detail {

namespace fs = std::filesystem;

Result<StagingDir> StagingDir::create(const fs::path& out) {
  std::error_code ec;
  if (out.filename().empty()) return Error(out.string(), "not a folder name to write");
  const fs::path parent = out.parent_path().empty() ? fs::path(".") : out.parent_path();
  fs::create_directories(parent, ec);
  if (ec) return Error(parent.string(), "cannot create folder: " + ec.message());
  if (fs::exists(out, ec) && !fs::is_directory(out, ec))
    return Error(out.string(), "exists and is not a folder; will not replace it");
  for (int attempt = 0; attempt < 8; ++attempt) {
    // A hidden sibling named as every writer names its temporaries (file_util.h), so a long
    // output name still fits and a later run sweeps it when this one is killed.
    const fs::path tmp = parent / temp_sibling(out).filename();
    if (fs::create_directory(tmp, ec)) {
      track_temp_path(tmp);  // removed if the process is interrupted (interrupt.h)
      return StagingDir(out, tmp);
    }
    if (ec) return Error(out.string(), "cannot create a temporary folder: " + ec.message());
  }
  return Error(out.string(), "cannot create a temporary folder");
}

StagingDir::StagingDir(StagingDir&& other) noexcept
    : out_(std::move(other.out_)), tmp_(std::move(other.tmp_)) {
  other.tmp_.clear();
}

StagingDir::~StagingDir() {
  if (tmp_.empty()) return;
  std::error_code ec;
  fs::remove_all(tmp_, ec);
  untrack_temp_path(tmp_);
}

Status StagingDir::commit() {
  if (tmp_.empty()) return Error(out_.string(), "already written");
  std::error_code ec;
  if (fs::exists(out_, ec)) {
    // Move the old folder aside first, so a failed rename can put it back.
    const fs::path old = tmp_.parent_path() / (tmp_.filename().string() + ".old");
    fs::rename(out_, old, ec);
    if (ec) return Error(out_.string(), "cannot replace the existing folder: " + ec.message());
    fs::rename(tmp_, out_, ec);
    if (ec) {
      std::error_code ec2;
      fs::rename(old, out_, ec2);
      return Error(out_.string(), "cannot move the written folder into place: " + ec.message());
    }
    fs::remove_all(old, ec);
  } else {
    fs::rename(tmp_, out_, ec);
    if (ec)
      return Error(out_.string(), "cannot move the written folder into place: " + ec.message());
  }
  untrack_temp_path(tmp_);
  tmp_.clear();
  return Status::Ok();
}

}  // namespace sawyer::ct::detail

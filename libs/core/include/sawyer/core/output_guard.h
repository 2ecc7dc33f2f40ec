// The rule every command that writes follows: an output never destroys what is not Sawyer's own.
//
//   OutputRequest req{out_dir, OutputKind::kRunFolder, {ct_folder}, "-o"};
//   Result<OutputLock> lock = OutputLock::acquire(req);   // checks, locks, sweeps stale temps
//   if (!lock) return fail(lock.error());
//   ... write_dir_atomic(out_dir, ...) ...                 // lock released when `lock` goes
//
// A folder output may replace only an empty folder or a folder Sawyer wrote of the same kind (a
// run folder with its sawyer-run run.json, a scan folder with its sawyer-log log.json, a phantom
// folder with truth/phantom.json, a maps folder with its Sawyer sidecar, a batch folder with its
// logs/ or batch_*.csv). A file output may replace a regular file but never a folder, a device
// or a FIFO. Neither may be an input, lie inside an input folder, or hold an input.
//
// OutputLock also takes an advisory lock on ".<name>.lock" beside the output, so a second
// process writing the same output refuses at once, and, holding it, removes the ".<name>.tmp…"
// siblings that a killed process left behind (no live process can own them then).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "sawyer/core/result.h"

namespace sawyer {

enum class OutputKind {
  kRunFolder,      // sawyer run: run.json with format sawyer-run/…
  kScanFolder,     // sawyer scan: log.json with format sawyer-log/…
  kPhantomFolder,  // sawyer phantom: truth/phantom.json
  kMapsFolder,     // sawyer convert: published maps (sawyer_maps.json) or float_maps.json
  kBatchFolder,    // sawyer batch: logs/ and batch_<i>.csv
  kFile,           // one file (log.json, sawing.json, an image)
};

// "a run folder", ... for messages.
const char* output_kind_name(OutputKind kind);

struct OutputRequest {
  std::filesystem::path path;
  OutputKind kind = OutputKind::kFile;
  std::vector<std::filesystem::path> inputs;  // what the command reads (files or folders)
  std::string option = "-o";                  // named in messages
};

// Checks `req` against the rules above. The error names the option, the path and the reason.
Status check_output(const OutputRequest& req);

// True when `dir` holds what Sawyer writes as `kind` (used by check_output).
bool is_sawyer_output(const std::filesystem::path& dir, OutputKind kind);

// Removes the ".<name>.tmp<hex>[.old]" siblings of `path`. Only safe while holding its lock.
// Returns how many were removed.
int sweep_stale_temps(const std::filesystem::path& path);

class OutputLock {
 public:
  // check_output, then the lock, then the sweep. Refuses at once if another process holds it.
  static Result<OutputLock> acquire(const OutputRequest& req);
  // The lock alone (for commands that write inside a folder they were given, e.g. the report).
  static Result<OutputLock> lock_only(const std::filesystem::path& path, const std::string& option);

  OutputLock(OutputLock&& other) noexcept;
  OutputLock& operator=(OutputLock&& other) noexcept;
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;
  ~OutputLock();

  // Stale temporaries removed when the lock was taken.
  int swept() const { return swept_; }

 private:
  OutputLock(int fd, std::filesystem::path lock_path, int swept)
      : fd_(fd), lock_path_(std::move(lock_path)), swept_(swept) {}
  void release();

  int fd_ = -1;
  std::filesystem::path lock_path_;
  int swept_ = 0;
};

}  // namespace sawyer

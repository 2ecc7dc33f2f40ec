// Shared helpers for Sawyer's tests: data paths, temporary folders, running the CLI.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "sawyer/model/log_model.h"

namespace sawyer::test {

// The project's source root: $SAWYER_SOURCE_DIR, else the source tree this was built from.
std::filesystem::path source_dir();
// sample_logs/<name> inside the project.
std::filesystem::path sample_log(const std::string& name);
// sample_logs/<name>/log.json, read once per test process and kept (a failed read is a test
// failure and gives an empty model).
const LogModel& sample_model(const std::string& name);
// The bundled real spruce stem-bank files (sample_logs/gran1_spruce/source).
std::filesystem::path gran1_source_dir();

// A fresh temporary folder, removed when the object goes out of scope.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

// Runs `command` with /bin/sh; returns its exit code (-1 if it did not exit), stdout+stderr in
// *output.
int run_command(const std::string& command, std::string* output);
// Runs the `sawyer` binary ($SAWYER_BIN, else the one built with the tests) with `args`; returns
// the exit code, stdout+stderr in *output.
int run_sawyer(const std::string& args, std::string* output);
// The `sawyer` binary run_sawyer runs, for tests that start it themselves.
std::string sawyer_bin();
// `p` in double quotes, for run_sawyer's command line.
std::string quoted(const std::filesystem::path& p);

// A synthetic CT scan made once per build by `sawyer phantom <phantom_args> -o <folder>` and kept
// in the build tree under test_ct/<name> (a file lock makes concurrent tests wait for the first
// one); empty path on failure (reported as a test failure).
std::filesystem::path cached_phantom(const std::string& name, const std::string& phantom_args);

// 40 cm of the real spruce log (gran1, 1000-1400 mm) at 0.8 mm pixels, 480², 5 mm slices: a
// cached_phantom small enough for `sawyer run` in a second or two (run, reliability tests), and
// fine enough that its rings are resolved and the scan's QA verdict trusts it.
std::filesystem::path gran1_40cm_ct();

// The q-quantile (0..1) of `v`, linear between order statistics; 0 for an empty `v`.
double percentile(std::vector<double> v, double q);

// Writes a text file (test fixtures).
void write_file(const std::filesystem::path& path, const std::string& text);

}  // namespace sawyer::test

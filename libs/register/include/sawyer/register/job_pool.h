// Runs a list of commands as subprocesses, at most `jobs` at a time: the engine of
// `sawyer batch`. Each job is its own process, so a log that crashes, runs out of memory or is
// killed takes only itself down, and memory is bounded by `jobs` times one job's peak.
//
//   std::vector<Job> jobs = {{"a", {"/bin/sh", "-c", "exit 3"}}, {"b", {"/bin/true"}}};
//   std::vector<JobResult> r = run_jobs(jobs, {.jobs = 2, .on_finished = print_progress});
//   // r[0].exit_code == 3, r[1].ok()
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace sawyer::reg {

struct Job {
  std::string id;                     // for progress lines and results
  std::vector<std::string> argv;      // argv[0] is the program (absolute or on PATH)
  std::filesystem::path stdout_path;  // the child's stdout goes here (empty: /dev/null)
  std::filesystem::path stderr_path;  // and its stderr (empty: a temporary file, removed)
};

struct JobResult {
  std::string id;
  int exit_code = -1;  // the exit status, or -1 when killed by a signal or never started
  int signal = 0;      // the signal that killed it, 0 if none
  bool timed_out = false;
  double seconds = 0;  // wall-clock time from start to exit
  std::string error;   // the last non-empty line of its stderr when it failed; or why it
                       // could not start, was killed, or ran out of time
  bool ok() const { return exit_code == 0; }
  // `sawyer run`'s exit 3: every result written, but the scan's QA verdict failed (README).
  bool warned() const { return exit_code == 3; }
  // `sawyer run`'s exit 4: the scan, run.json and a report written, but the pattern cannot be
  // sawn from the log (README): done, not failed.
  bool not_sawn() const { return exit_code == 4; }
  bool completed() const { return ok() || warned() || not_sawn(); }
};

struct JobPoolOptions {
  int jobs = 1;          // at most this many children at once (>= 1)
  double timeout_s = 0;  // > 0: a child running longer gets SIGTERM, then SIGKILL 10 s later
  // Called on the calling thread as each job finishes: the result, how many have finished, of
  // how many.
  std::function<void(const JobResult&, int done, int total)> on_finished;
};

// Runs every job and returns their results in the order of `jobs`. Never fails as a whole: a job
// that cannot start (no such program, an unwritable log file) is a failed result. Waits only for
// its own children (by pid). Not reentrant with other code that reaps children with wait(-1).
std::vector<JobResult> run_jobs(const std::vector<Job>& jobs, const JobPoolOptions& options);

// The last non-empty line of a file (without its line end), "" if none or unreadable. Reads at
// most the last 64 KiB.
std::string last_line_of(const std::filesystem::path& path);

}  // namespace sawyer::reg

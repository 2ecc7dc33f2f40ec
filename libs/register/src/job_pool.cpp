#include "sawyer/register/job_pool.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <system_error>
#include <thread>
#include <vector>

#include "sawyer/core/interrupt.h"

extern char** environ;

namespace sawyer::reg {
namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

// How often the pool looks for finished children. Jobs run for seconds to minutes, so 20 ms of
// latency is nothing, and polling each pid with WNOHANG never reaps a child that is not ours.
constexpr auto kPollInterval = std::chrono::milliseconds(20);
constexpr double kKillGraceS = 10;

struct Running {
  size_t index = 0;
  pid_t pid = 0;
  Clock::time_point start;
  fs::path stderr_path;
  bool stderr_is_temp = false;
  bool term_sent = false, kill_sent = false;
  Clock::time_point term_at;
};

// The children alive now, for the interrupt hook (which runs on another thread): on SIGINT or
// SIGTERM the batch passes SIGTERM on, so that each `sawyer run` removes its temporary output,
// and waits for them before it ends.
struct LiveChildren {
  std::mutex mu;
  std::vector<pid_t> pids;
  void add(pid_t p) {
    std::lock_guard<std::mutex> lock(mu);
    pids.push_back(p);
  }
  void remove(pid_t p) {
    std::lock_guard<std::mutex> lock(mu);
    pids.erase(std::remove(pids.begin(), pids.end(), p), pids.end());
  }
  void stop_all() {
    std::vector<pid_t> now;
    {
      std::lock_guard<std::mutex> lock(mu);
      now = pids;
    }
    for (pid_t p : now) ::kill(p, SIGTERM);
    const auto t0 = Clock::now();
    for (pid_t p : now) {
      // Reaped here or by the pool's loop (then waitpid says ECHILD): either way it is gone.
      while (::waitpid(p, nullptr, WNOHANG) == 0) {
        if (std::chrono::duration<double>(Clock::now() - t0).count() > kKillGraceS) {
          ::kill(p, SIGKILL);
          ::waitpid(p, nullptr, 0);
          break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    }
  }
};

std::string errno_text(int e) { return std::error_code(e, std::generic_category()).message(); }

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

fs::path make_temp_file() {
  std::error_code ec;
  fs::path dir = fs::temp_directory_path(ec);
  if (ec) dir = "/tmp";
  std::string tmpl = (dir / "sawyer-job-XXXXXX").string();
  const int fd = ::mkstemp(tmpl.data());
  if (fd < 0) return {};
  ::close(fd);
  return tmpl;
}

// Starts one job. On failure returns the reason and starts nothing.
std::string spawn(const Job& job, Running& r) {
  if (job.argv.empty()) return "empty command";
  r.stderr_path = job.stderr_path;
  if (r.stderr_path.empty()) {
    r.stderr_path = make_temp_file();
    r.stderr_is_temp = true;
    if (r.stderr_path.empty()) return "cannot create a temporary file for its stderr";
  }
  const std::string out = job.stdout_path.empty() ? "/dev/null" : job.stdout_path.string();
  const std::string err = r.stderr_path.string();

  std::vector<char*> argv;
  for (const std::string& a : job.argv) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);

  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&fa, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  // posix_spawnp reports a failed open or exec in the child as its return value (glibc), so a
  // missing program is an error here, not a mysterious exit code 127.
  const int rc = ::posix_spawnp(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) {
    if (r.stderr_is_temp) ::unlink(err.c_str());
    return "cannot start '" + job.argv[0] + "': " + errno_text(rc);
  }
  r.pid = pid;
  r.start = Clock::now();
  return "";
}

void finish(const Running& r, int status, JobResult& res) {
  res.seconds = seconds_since(r.start);
  if (WIFEXITED(status)) {
    res.exit_code = WEXITSTATUS(status);
  } else if (WIFSIGNALED(status)) {
    res.exit_code = -1;
    res.signal = WTERMSIG(status);
  }
  if (!res.ok()) {
    std::string last = last_line_of(r.stderr_path);
    if (res.timed_out) {
      res.error = "timed out after " + std::to_string(static_cast<long>(res.seconds)) + " s";
      if (!last.empty()) res.error += " (last message: " + last + ")";
    } else if (res.signal) {
      // A crash or an out-of-memory kill: the last line is rarely about it.
      res.error = std::string("killed by signal ") + std::to_string(res.signal) + " (" +
                  strsignal(res.signal) + ")";
      if (res.signal == SIGKILL) res.error += ", e.g. out of memory";
      if (!last.empty()) res.error += "; last message: " + last;
    } else {
      res.error =
          last.empty() ? "exit code " + std::to_string(res.exit_code) + ", no message" : last;
    }
  }
  if (r.stderr_is_temp) ::unlink(r.stderr_path.c_str());
}

}  // namespace

std::string last_line_of(const fs::path& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return "";
  const std::streamoff size = in.tellg();
  const std::streamoff from = std::max<std::streamoff>(0, size - 65536);
  in.seekg(from);
  std::string tail(static_cast<size_t>(size - from), '\0');
  in.read(tail.data(), static_cast<std::streamsize>(tail.size()));
  // Progress lines end in '\r' rather than '\n': treat both as line ends.
  size_t end = tail.find_last_not_of("\r\n \t");
  if (end == std::string::npos) return "";
  size_t begin = tail.find_last_of("\r\n", end);
  begin = begin == std::string::npos ? 0 : begin + 1;
  return tail.substr(begin, end - begin + 1);
}

std::vector<JobResult> run_jobs(const std::vector<Job>& jobs, const JobPoolOptions& options) {
  const int max_running = std::max(1, options.jobs);
  const int total = static_cast<int>(jobs.size());
  std::vector<JobResult> results(jobs.size());
  for (size_t i = 0; i < jobs.size(); ++i) results[i].id = jobs[i].id;
  std::vector<Running> running;
  size_t next = 0;
  int done = 0;
  LiveChildren live;
  const int hook = add_interrupt_hook([&live] { live.stop_all(); });

  auto report = [&](size_t index) {
    ++done;
    if (options.on_finished) options.on_finished(results[index], done, total);
  };

  while (done < total) {
    while (static_cast<int>(running.size()) < max_running && next < jobs.size()) {
      Running r;
      r.index = next++;
      if (std::string why = spawn(jobs[r.index], r); !why.empty()) {
        results[r.index].error = why;
        report(r.index);
        continue;
      }
      live.add(r.pid);
      running.push_back(r);
    }
    if (running.empty()) continue;

    bool any = false;
    for (size_t k = 0; k < running.size();) {
      Running& r = running[k];
      int status = 0;
      const pid_t got = ::waitpid(r.pid, &status, WNOHANG);
      if (got == 0) {
        if (options.timeout_s > 0) {
          if (!r.term_sent && seconds_since(r.start) > options.timeout_s) {
            ::kill(r.pid, SIGTERM);
            r.term_sent = true;
            r.term_at = Clock::now();
            results[r.index].timed_out = true;
          } else if (r.term_sent && !r.kill_sent && seconds_since(r.term_at) > kKillGraceS) {
            ::kill(r.pid, SIGKILL);
            r.kill_sent = true;
          }
        }
        ++k;
        continue;
      }
      if (got < 0 && errno == EINTR) continue;
      if (got < 0) {
        // Someone else reaped it (a wait(-1) elsewhere): the status is lost.
        results[r.index].error = "lost track of the process: " + errno_text(errno);
        results[r.index].seconds = seconds_since(r.start);
        if (r.stderr_is_temp) ::unlink(r.stderr_path.c_str());
      } else {
        finish(r, status, results[r.index]);
      }
      const size_t index = r.index;
      live.remove(r.pid);
      running.erase(running.begin() + static_cast<std::ptrdiff_t>(k));
      report(index);
      any = true;
    }
    if (!any) std::this_thread::sleep_for(kPollInterval);
  }
  remove_interrupt_hook(hook);
  return results;
}

}  // namespace sawyer::reg

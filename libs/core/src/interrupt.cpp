#include "sawyer/core/interrupt.h"

#include <fcntl.h>
#include <pthread.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <map>
#include <mutex>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

namespace sawyer {
namespace fs = std::filesystem;

namespace {

std::atomic<bool> g_interrupted{false};
int g_pipe[2] = {-1, -1};

// Everything the watcher touches, behind one mutex. Leaked on purpose: the watcher may run while
// static destructors do.
struct Registry {
  std::mutex mu;
  std::multimap<std::string, int> temps;  // path -> count (a path may be tracked twice)
  std::map<int, std::function<void()>> hooks;
  int next_hook = 1;
};
Registry& registry() {
  static Registry* r = new Registry;
  return *r;
}

pthread_t g_watcher;

// The layout the getdents64 system call writes (glibc declares no type for it).
struct linux_dirent64_view {
  std::uint64_t d_ino;
  std::int64_t d_off;
  unsigned short d_reclen;
  unsigned char d_type;
  char d_name[1];
};

// While the watcher cleans up, the other threads keep running and may trip over what it removes
// (a write into a vanished folder that throws, a mapped file gone): such a thread is parked here
// instead of aborting the process before the clean-up is done. A fault on the watcher itself
// ends the process at once.
extern "C" void park_thread(int sig) {
  if (pthread_equal(pthread_self(), g_watcher)) ::_exit(kExitInterrupted + sig);
  for (;;) ::pause();
}

int g_signal = 0;

// The clean-up is bounded: were it ever stuck, the process ends anyway after a few seconds.
extern "C" void cleanup_timed_out(int) { ::_exit(kExitInterrupted + g_signal); }

// Calls f(name) for every entry of the open folder `fd` but "." and "..", reading it with
// getdents64 into a buffer on the stack: no allocation (see remove_tree_at).
template <typename F>
void for_each_entry(int fd, F&& f) {
  alignas(8) char buf[4096];
  for (;;) {
    const long n = ::syscall(SYS_getdents64, fd, buf, sizeof buf);
    if (n <= 0) return;
    for (long off = 0; off < n;) {
      const auto* d = reinterpret_cast<const linux_dirent64_view*>(buf + off);
      const char* entry = buf + off + offsetof(linux_dirent64_view, d_name);
      off += d->d_reclen;
      if (std::strcmp(entry, ".") != 0 && std::strcmp(entry, "..") != 0) f(entry);
    }
  }
}

// Removes `name` (relative to `dirfd`) and everything below it without allocating memory: the
// other threads are parked by then, and one may hold the allocator's lock. Links are removed,
// never followed.
void remove_tree_at(int dirfd, const char* name, int depth) {
  if (::unlinkat(dirfd, name, 0) == 0 || errno == ENOENT) return;
  if (depth > 64) return;
  const int fd = ::openat(dirfd, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) return;
  for_each_entry(fd, [&](const char* entry) { remove_tree_at(fd, entry, depth + 1); });
  ::close(fd);
  ::unlinkat(dirfd, name, AT_REMOVEDIR);
}

// Parks every other thread of the process (the signal's handler never returns), so that none
// writes into a temporary folder again after it is removed.
void park_other_threads(int park_signal) {
  const int fd = ::open("/proc/self/task", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  const pid_t self = static_cast<pid_t>(::syscall(SYS_gettid));
  const pid_t pid = ::getpid();
  for_each_entry(fd, [&](const char* entry) {
    const long tid = std::strtol(entry, nullptr, 10);
    if (tid > 0 && tid != self) ::syscall(SYS_tgkill, pid, tid, park_signal);
  });
  ::close(fd);
  // A thread inside a system call (a mkdir, a write) finishes it, then parks.
  struct timespec t {
    0, 30 * 1000 * 1000
  };
  ::nanosleep(&t, nullptr);
}

extern "C" void on_signal(int sig) {
  g_interrupted.store(true);
  const unsigned char b = static_cast<unsigned char>(sig);
  // A full pipe means a signal is already pending: nothing more to say.
  [[maybe_unused]] ssize_t n = ::write(g_pipe[1], &b, 1);
}

void watch() {
  unsigned char sig = 0;
  for (;;) {
    const ssize_t n = ::read(g_pipe[0], &sig, 1);
    if (n == 1) break;
    if (n < 0 && errno == EINTR) continue;
    return;  // the pipe is gone: nothing to watch
  }
  struct sigaction park {};
  park.sa_handler = park_thread;
  sigemptyset(&park.sa_mask);
  for (int s : {SIGABRT, SIGSEGV, SIGBUS, SIGFPE, SIGILL}) ::sigaction(s, &park, nullptr);
  Registry& r = registry();
  std::vector<std::function<void()>> hooks;
  {
    std::lock_guard<std::mutex> lock(r.mu);
    for (auto& [id, h] : r.hooks) hooks.push_back(h);
  }
  for (auto& h : hooks) h();
  g_signal = sig;
  struct sigaction timeout {};
  timeout.sa_handler = cleanup_timed_out;
  sigemptyset(&timeout.sa_mask);
  ::sigaction(SIGALRM, &timeout, nullptr);
  ::alarm(5);
  // Held to the end: no writer tracks or untracks anything from here on.
  r.mu.lock();
  std::vector<std::string> paths;
  for (const auto& [path, unused] : r.temps) paths.push_back(path);
  // Freeze, then clean: with every other thread parked nothing can create a folder again after
  // its removal (a writer's create_directories would otherwise bring back a removed one).
  const int park_signal = SIGRTMIN + 5;
  ::sigaction(park_signal, &park, nullptr);
  park_other_threads(park_signal);
  for (const std::string& p : paths) remove_tree_at(AT_FDCWD, p.c_str(), 0);
  static const char kMsg[] = "sawyer: interrupted; temporary files removed\n";
  [[maybe_unused]] ssize_t n = ::write(2, kMsg, sizeof kMsg - 1);
  ::_exit(kExitInterrupted + sig);
}

}  // namespace

void install_interrupt_cleanup() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (::pipe2(g_pipe, O_CLOEXEC) != 0) return;
    ::fcntl(g_pipe[1], F_SETFL, O_NONBLOCK);
    registry();
    std::thread watcher(watch);
    g_watcher = watcher.native_handle();
    watcher.detach();
    struct sigaction sa {};
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    for (int s : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(s, &sa, nullptr);
  });
}

bool interrupted() { return g_interrupted.load(); }

void track_temp_path(const fs::path& p) {
  Registry& r = registry();
  std::error_code ec;
  const fs::path a = fs::absolute(p, ec);
  std::lock_guard<std::mutex> lock(r.mu);
  r.temps.emplace((ec ? p : a).string(), 0);
}

void untrack_temp_path(const fs::path& p) {
  Registry& r = registry();
  std::error_code ec;
  const fs::path a = fs::absolute(p, ec);
  std::lock_guard<std::mutex> lock(r.mu);
  auto it = r.temps.find((ec ? p : a).string());
  if (it != r.temps.end()) r.temps.erase(it);
}

int add_interrupt_hook(std::function<void()> hook) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mu);
  const int id = r.next_hook++;
  r.hooks.emplace(id, std::move(hook));
  return id;
}

void remove_interrupt_hook(int id) {
  // Once a signal is being handled the hook may be running on the watcher thread with what it
  // refers to; wait here for the watcher to end the process instead of destroying that.
  while (interrupted()) ::pause();
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mu);
  r.hooks.erase(id);
}

}  // namespace sawyer

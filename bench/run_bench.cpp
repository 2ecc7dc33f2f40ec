// End-to-end time of the main job, `sawyer run` (scan + saw + report + register), as a user runs
// it: the bundled real spruce log (4.0 m, 108 knots) and generated 4 m logs, each as a DICOM
// series at 5 mm slices, 512 × 512 × 0.8 mm (generated logs: 4 m, 200 mm at the top, so that
// the default 2ex pattern fits). The scans are synthesised once into a cache folder.
// Prints per log the stage times that run.json records, the time to the decision (scan and saw
// done, the position printed: what the saw line waits for) and the command's wall time, best
// and median of the repeats.
//
// --baseline BINARY runs another build's sawyer (e.g. one of a6ddf54, before the robustness
// work) on the same scans, alternating with this one run by run so that both see the same
// machine, and prints its row and the ratios: this build's whole run and its decision, each
// against the baseline's whole run (issue 42's targets: ≤ 0.76 and ≤ 0.46).
//
//   build/bench/run_bench [--repeat 3] [--cache DIR] [--threads N] [--logs gran1,pine21,spruce24]
//                         [--baseline BINARY]
#include <nlohmann/json.hpp>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

struct Case {
  std::string name, model_cmd;  // model_cmd: "" for a bundled log.json path in `model`
  std::string model;
};

int sh(const std::string& cmd) {
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : 1;
}

// Runs `cmd` through /bin/sh; returns its exit code and, in *peak_mib, the largest resident set
// of the command's process tree's biggest child (getrusage of the waited-for children).
int sh_peak(const std::string& cmd, double* peak_mib) {
  const pid_t pid = fork();
  if (pid == 0) {
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  int status = 0;
  rusage ru{};
  if (pid < 0 || wait4(pid, &status, 0, &ru) < 0) return 1;
  // The shell exec()s a simple command, so this is sawyer's own peak (Linux: KiB).
  *peak_mib = ru.ru_maxrss / 1024.0;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 1;
}

// One sawyer binary's runs of one log.
struct Build {
  std::string label, exe;
  std::map<std::string, std::vector<double>> stage;
  std::vector<double> wall, decision;
  double peak = 0;
  int slices = 0, knots = 0;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const std::string sawyer = SAWYER_EXE, src = SAWYER_SOURCE_DIR;
  int repeat = 3;
  std::string cache = "bench_ct", logs = "gran1,pine21,spruce24", threads, baseline;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--repeat"))
      repeat = std::max(1, std::atoi(argv[i + 1]));
    else if (!std::strcmp(argv[i], "--cache"))
      cache = argv[i + 1];
    else if (!std::strcmp(argv[i], "--logs"))
      logs = argv[i + 1];
    else if (!std::strcmp(argv[i], "--threads"))
      threads = argv[i + 1];
    else if (!std::strcmp(argv[i], "--baseline"))
      baseline = argv[i + 1];
  }
  fs::create_directories(cache);
  std::vector<Case> cases;
  std::stringstream names(logs);
  for (std::string n; std::getline(names, n, ',');) {
    if (n == "gran1")
      cases.push_back({"gran1_spruce", "", src + "/sample_logs/gran1_spruce/log.json"});
    else if (n.rfind("pine", 0) == 0 || n.rfind("spruce", 0) == 0) {
      const bool pine = n[0] == 'p';
      const std::string seed = n.substr(pine ? 4 : 6);
      const std::string model = cache + "/" + n + ".json";
      cases.push_back({n,
                       sawyer + " generate --species " + (pine ? "pine" : "spruce") + " --seed " +
                           seed + " --length-m 4 --top-diameter-mm 200 -o " + model + " >/dev/null",
                       model});
    } else {
      std::fprintf(stderr, "run_bench: unknown log '%s' (gran1, pineN, spruceN)\n", n.c_str());
      return 1;
    }
  }

  std::printf("%-14s %-8s %6s %5s | %6s %6s %6s %8s %6s | %8s %7s %7s %8s | %s\n", "log", "build",
              "slices", "knots", "scan", "saw", "write", "checksum", "report", "decision", "wall",
              "median", "peak MiB", "runs (s)");
  std::vector<std::string> ratio_lines;
  for (const Case& c : cases) {
    if (!c.model_cmd.empty() && !fs::exists(c.model) && sh(c.model_cmd) != 0) return 1;
    const std::string ct = cache + "/" + c.name + "_ct";
    if (!fs::exists(ct + "/truth/phantom.json")) {
      std::fprintf(stderr, "run_bench: synthesising %s (once)\n", ct.c_str());
      if (sh(sawyer + " phantom " + c.model + " -o " + ct + " --seed 1 >/dev/null") != 0) return 1;
    }
    std::vector<Build> builds = {{"this", sawyer}};
    if (!baseline.empty()) builds.push_back({"baseline", baseline});
    for (int r = 0; r < repeat; ++r)
      for (Build& b : builds) {  // alternating: both builds see the machine as it is now
        const std::string out = cache + "/" + c.name + "_run_" + b.label;
        std::string cmd = b.exe + " run " + ct + " -o " + out + " --quiet --db " + cache + "/" +
                          b.label + ".sqlite --id " + c.name;
        if (!threads.empty()) cmd += " --threads " + threads;
        const auto t0 = std::chrono::steady_clock::now();
        double p = 0;
        if (sh_peak(cmd + " >/dev/null", &p) != 0) {
          std::fprintf(stderr, "run_bench: failed: %s\n", cmd.c_str());
          return 1;
        }
        b.peak = std::max(b.peak, p);
        b.wall.push_back(
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        std::ifstream f(out + "/run.json");
        const nlohmann::json j = nlohmann::json::parse(f, nullptr, false);
        if (j.is_discarded()) {
          std::fprintf(stderr, "run_bench: %s/run.json unreadable\n", out.c_str());
          return 1;
        }
        for (const auto& s : j["stages"]) b.stage[s["name"]].push_back(s["seconds"].get<double>());
        // An older run.json has no "time": its decision came after everything (-1: not known).
        double decision = -1;
        if (j.contains("time") && j["time"].contains("to_decision_s"))
          decision = j["time"]["to_decision_s"].get<double>();
        b.decision.push_back(decision);
        b.slices = j.value("slices", 0);
        b.knots = j.value("knots", 0);
      }
    for (const Build& b : builds) {
      auto med = [&](const char* s) {
        auto it = b.stage.find(s);
        return it == b.stage.end() ? 0.0 : median(it->second);
      };
      std::string runs;
      for (double w : b.wall) {
        char t[16];
        std::snprintf(t, sizeof t, "%.2f ", w);
        runs += t;
      }
      const double dec = median(b.decision);
      char dec_text[16] = "-";
      if (dec >= 0) std::snprintf(dec_text, sizeof dec_text, "%.2f", dec);
      std::printf(
          "%-14s %-8s %6d %5d | %6.2f %6.2f %6.2f %8.2f %6.2f | %8s %7.2f %7.2f %8.0f | %s\n",
          c.name.c_str(), b.label.c_str(), b.slices, b.knots, med("scan"), med("saw"), med("write"),
          med("checksum"), med("report"), dec_text, *std::min_element(b.wall.begin(), b.wall.end()),
          median(b.wall), b.peak, runs.c_str());
    }
    if (builds.size() == 2) {
      const double base = median(builds[1].wall);
      const double dec = median(builds[0].decision);
      char line[256];
      std::snprintf(line, sizeof line,
                    "%-14s whole run %.2f× the baseline's (target ≤ 0.76), decision %.2f× the "
                    "baseline's whole run (target ≤ 0.46)",
                    c.name.c_str(), median(builds[0].wall) / base, dec >= 0 ? dec / base : -1.0);
      ratio_lines.push_back(line);
    }
  }
  std::printf(
      "stages: medians of %d runs (run.json); decision: run.json's time to the decision (the "
      "position printed), median; wall: the whole command, best and median\n",
      repeat);
  for (const std::string& l : ratio_lines) std::printf("%s\n", l.c_str());
  return 0;
}

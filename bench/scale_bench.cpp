// scale_bench: time, peak memory, throughput and accuracy of `sawyer run` over log length and
// resolution (issue 24, item 3; driven by bench/scale.sh, docs/bench.md "Scale").
//
//   scale_bench run --scan DIR --out DIR --results FILE --config NAME --length-m L
//                   [--truth DIR] [--sawyer EXE] [-- extra sawyer run options]
//   scale_bench table FILE
//
// `run` runs `sawyer run SCAN -o OUT --no-register --quiet [extra]` in a fresh child process
// (its output in OUT.log), waits for it with wait4 (wall time, CPU time and the child's peak
// resident set), reads OUT/run.json (slices, stage seconds; voxels = slices x W x W with W from
// --size), scores the scanned model OUT/scan/log.json against the phantom's truth/log.json when
// given (pith error, outline error, knots found against true knots as bench/robustness does)
// and appends one JSON line to FILE. A failed run is recorded
// too, with its exit status and its log's last line.
// `table` prints the rows of FILE as a Markdown table, then the fitted cost per voxel, the
// memory's slope over length and issue 24's targets, each met or missed by how much.
#include <nlohmann/json.hpp>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "sawyer/ct/knots/knot_match.h"
#include "sawyer/model/log_json.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr double kTwoPi = 6.28318530717958647692;

// Issue 24's targets.
constexpr double kGranPeakMb = 400;       // the bundled 4 m log's run, report included
constexpr double kBig6mPeakMb = 800;      // the 6 m log at 1024² slices
constexpr double kSlopeMbPerM = 5;        // peak memory over log length
constexpr double kTodayMvoxPerS = 110;    // scan throughput on 2 cores, bundled log
constexpr double kThroughputShare = 0.8;  // within 20 % of it

struct Child {
  int rc = -1;
  double wall_s = 0, cpu_s = 0, peak_mb = 0;
};

// Runs argv with stdout and stderr to `log`; wait4 gives the child's own peak RSS and CPU time.
Child run_child(const std::vector<std::string>& args, const fs::path& log) {
  Child c;
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) dup2(fd, 1), dup2(fd, 2), close(fd);
    execv(argv[0], argv.data());
    std::fprintf(stderr, "scale_bench: cannot run %s: %s\n", argv[0], std::strerror(errno));
    _exit(127);
  }
  int status = 0;
  rusage ru{};
  if (pid < 0 || wait4(pid, &status, 0, &ru) < 0) return c;
  c.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  c.cpu_s =
      ru.ru_utime.tv_sec + ru.ru_stime.tv_sec + 1e-6 * (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
  c.peak_mb = ru.ru_maxrss * 1024.0 / 1e6;  // Linux: KiB; reported in MB (10^6 bytes)
  c.rc = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return c;
}

std::string last_line(const fs::path& file) {
  std::ifstream in(file);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return last;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(std::min<double>(v.size() - 1, std::floor(q * v.size())))];
}

// The scanned model against the phantom's truth, both in the scanner frame with z from the
// first slice (a prefix of the phantom's slices shares its first slice, so its z too).
void score(const sawyer::LogModel& got, const sawyer::LogModel& truth, double z_last, json& row) {
  const sawyer::Stem& s = got.stem;
  std::vector<double> pith;
  double r2 = 0;
  long rn = 0;
  for (int i = 0; i < s.slice_count(); ++i) {
    const double z = s.z_at(i);
    if (z < 10 || z > z_last - 10) continue;  // as the scanner-frame test: not the ends
    pith.push_back((s.pith[static_cast<size_t>(i)] - truth.stem.pith_at(z)).norm());
    for (int k = 0; k < s.n_angles; ++k) {
      const double w = kTwoPi * k / s.n_angles;
      const double d =
          s.radius[static_cast<size_t>(i)][static_cast<size_t>(k)] - truth.stem.radius_at(w, z);
      r2 += d * d, ++rn;
    }
  }
  row["pith_median_mm"] = percentile(pith, 0.5);
  row["pith_p95_mm"] = percentile(pith, 0.95);
  row["outline_rms_mm"] = rn ? std::sqrt(r2 / rn) : NAN;
  // Knots as bench/robustness on a fine scan: true knots whole inside the scanned length 5 mm
  // from its ends, at least 10 mm thick, count for recall; a found knot pairing with any true
  // knot (small, or cut by the scan's end) is right.
  sawyer::ct::KnotMatchOptions mo;
  mo.z_lo = 5.0, mo.z_hi = z_last - 5.0;
  mo.min_diameter_mm = 10.0;
  const sawyer::ct::KnotMatch m = sawyer::ct::match_knots(got.knots, truth.knots, truth.stem, mo);
  row["knots_true"] = m.truth_counted;
  row["knots_true_found"] = m.truth_found;
  row["knots_found"] = m.found;
  row["knots_spurious"] = m.spurious;
}

int usage() {
  std::fprintf(stderr,
               "usage: scale_bench run --scan DIR --out DIR --results FILE --config NAME "
               "--length-m L --size W [--truth DIR] [--sawyer EXE] [-- sawyer run options]\n"
               "       scale_bench table FILE\n");
  return 1;
}

int cmd_run(int argc, char** argv) {
  std::map<std::string, std::string> opt{{"sawyer", SAWYER_EXE}};
  std::vector<std::string> extra;
  for (int i = 2; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--")) {
      for (++i; i < argc; ++i) extra.emplace_back(argv[i]);
      break;
    }
    if (std::strncmp(argv[i], "--", 2) || i + 1 >= argc) {
      std::fprintf(stderr, "scale_bench run: '%s' is not an option with a value\n", argv[i]);
      return usage();
    }
    opt[argv[i] + 2] = argv[i + 1];
    ++i;
  }
  for (const char* k : {"scan", "out", "results", "config", "length-m", "size"})
    if (!opt.count(k)) {
      std::fprintf(stderr, "scale_bench run: --%s is missing\n", k);
      return usage();
    }
  const fs::path out = opt["out"];
  const fs::path log = out.string() + ".log";
  std::vector<std::string> args{opt["sawyer"], "run",           opt["scan"], "-o",
                                out.string(),  "--no-register", "--quiet"};
  args.insert(args.end(), extra.begin(), extra.end());
  std::string command;
  for (const std::string& a : args) command += (command.empty() ? "" : " ") + a;

  const Child c = run_child(args, log);
  json row;
  row["config"] = opt["config"];
  row["length_m"] = std::atof(opt["length-m"].c_str());
  row["command"] = command;
  row["rc"] = c.rc;
  row["wall_s"] = c.wall_s;
  row["cpu_s"] = c.cpu_s;
  row["peak_mb"] = c.peak_mb;
  if (c.rc != 0) {
    row["error"] = last_line(log);
  } else {
    std::ifstream f(out / "run.json");
    const json rj = json::parse(f, nullptr, false);
    if (rj.is_discarded()) {
      row["rc"] = -1;
      row["error"] = (out / "run.json").string() + " unreadable";
    } else {
      const int size = std::atoi(opt["size"].c_str());
      const long slices = rj.value("slices", 0L);
      row["slices"] = slices;
      row["voxels"] = static_cast<double>(slices) * size * size;
      for (const auto& s : rj["stages"]) row["stages"][s["name"].get<std::string>()] = s["seconds"];
      auto got = sawyer::read_log_json(out / "scan/log.json");
      if (opt.count("truth") && got) {
        auto truth = sawyer::read_log_json(fs::path(opt["truth"]) / "log.json");
        if (!truth) {
          std::fprintf(stderr, "scale_bench: %s\n", truth.error().message().c_str());
          return 1;
        }
        const double z_last = got.value().stem.z_at(got.value().stem.slice_count() - 1);
        score(got.value(), truth.value(), z_last, row);
      }
    }
  }
  std::ofstream res(opt["results"], std::ios::app);
  res << row.dump() << "\n";
  if (!res) {
    std::fprintf(stderr, "scale_bench: cannot append to %s\n", opt["results"].c_str());
    return 1;
  }
  std::fprintf(stderr, "  %s %g m: %s, %.1f s, peak %.0f MB\n", opt["config"].c_str(),
               row["length_m"].get<double>(), c.rc == 0 ? "ok" : "FAILED", c.wall_s, c.peak_mb);
  return 0;
}

// Least squares y = a + b x (b alone through the origin when x takes one value).
struct Fit {
  double a = NAN, b = NAN;
  int n = 0;
};
Fit fit(const std::vector<double>& x, const std::vector<double>& y) {
  Fit f;
  f.n = static_cast<int>(x.size());
  if (x.empty()) return f;
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (size_t i = 0; i < x.size(); ++i)
    sx += x[i], sy += y[i], sxx += x[i] * x[i], sxy += x[i] * y[i];
  const double n = static_cast<double>(x.size()), den = n * sxx - sx * sx;
  if (x.size() < 2 || std::abs(den) < 1e-12 * std::max(1.0, n * sxx)) {
    f.a = 0, f.b = sxx > 0 ? sxy / sxx : NAN;
    return f;
  }
  f.b = (n * sxy - sx * sy) / den;
  f.a = (sy - f.b * sx) / n;
  return f;
}

std::string num(const json& r, const char* k, const char* fmt) {
  if (!r.contains(k) || !r[k].is_number() || std::isnan(r[k].get<double>())) return "-";
  char b[32];
  std::snprintf(b, sizeof b, fmt, r[k].get<double>());
  return b;
}

std::string verdict(double value, double limit, bool at_most, const char* unit) {
  if (std::isnan(value)) return "not measured";
  char b[96];
  const bool met = at_most ? value <= limit : value >= limit;
  if (met)
    std::snprintf(b, sizeof b, "met (%.1f %s)", value, unit);
  else
    std::snprintf(b, sizeof b, "MISSED by %.1f %s (%.1f %s)", std::abs(value - limit), unit, value,
                  unit);
  return b;
}

int cmd_table(const char* file) {
  std::ifstream in(file);
  if (!in) {
    std::fprintf(stderr, "scale_bench: cannot read %s\n", file);
    return 1;
  }
  std::vector<json> rows;
  std::vector<std::string> configs;  // in order of first appearance
  for (std::string line; std::getline(in, line);) {
    if (line.empty()) continue;
    json r = json::parse(line, nullptr, false);
    if (r.is_discarded()) {
      std::fprintf(stderr, "scale_bench: %s: a line is not JSON: %.60s\n", file, line.c_str());
      return 1;
    }
    const std::string c = r.value("config", "");
    if (std::find(configs.begin(), configs.end(), c) == configs.end()) configs.push_back(c);
    rows.push_back(std::move(r));
  }
  // The bundled log's scan rate in this table: the other rows against it are a throughput
  // comparison that holds when other work loads the CPUs (it slows every row alike).
  double gran_rate = NAN;
  for (const json& r : rows)
    if (r.value("config", "").find("gran1") != std::string::npos && r.value("rc", -1) == 0)
      gran_rate = r.value("voxels", 0.0) / r["stages"].value("scan", NAN) / 1e6;
  std::printf(
      "| configuration | log m | slices | voxels M | scan s | total s | CPU s | peak MB | "
      "scan Mvox/s | vs gran1 | pith mm med / p95 | outline RMS mm | knots found / true (spurious) "
      "|\n"
      "|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n");
  for (const json& r : rows) {
    const std::string c = r.value("config", "");
    if (r.value("rc", -1) != 0) {
      std::printf("| %s | %.0f | FAILED (exit %d): %s | | | | | %s | | | | | |\n", c.c_str(),
                  r.value("length_m", 0.0), r.value("rc", -1), r.value("error", "").c_str(),
                  num(r, "peak_mb", "%.0f").c_str());
      continue;
    }
    const double vox = r.value("voxels", 0.0);
    const double scan = r["stages"].value("scan", NAN);
    std::string knots = "-";
    if (r.contains("knots_true")) {
      char b[64];
      std::snprintf(b, sizeof b, "%d / %d (%d)", r.value("knots_true_found", 0),
                    r.value("knots_true", 0), r.value("knots_spurious", 0));
      knots = b;
    }
    std::printf(
        "| %s | %.1f | %ld | %.0f | %.2f | %.2f | %.1f | %.0f | %.1f | %.0f %% | %s / %s | %s | %s "
        "|\n",
        c.c_str(), r.value("length_m", 0.0), r.value("slices", 0L), vox / 1e6, scan,
        r.value("wall_s", NAN), r.value("cpu_s", NAN), r.value("peak_mb", NAN), vox / scan / 1e6,
        100 * vox / scan / 1e6 / gran_rate, num(r, "pith_median_mm", "%.2f").c_str(),
        num(r, "pith_p95_mm", "%.2f").c_str(), num(r, "outline_rms_mm", "%.2f").c_str(),
        knots.c_str());
  }
  std::printf(
      "\nscan s: run.json's scan stage (reading the slices, stem and knot passes); total s: the "
      "whole `sawyer run` (report included), wall; peak MB: the child's peak resident set "
      "(getrusage, 10^6 bytes); knots: true knots >= 10 mm found / counted, (found knots "
      "matching no true knot).\n");

  // Fits per configuration and over every configuration.
  std::printf(
      "\n| configuration | cost per voxel (scan) | fixed cost | memory slope over length |\n"
      "|---|--:|--:|--:|\n");
  std::vector<double> all_v, all_t;
  double worst_slope = NAN;
  std::string worst_slope_cfg;
  double min_tp = NAN;
  std::string min_tp_row;
  for (const std::string& c : configs) {
    std::vector<double> v, t, m, mb;
    for (const json& r : rows) {
      if (r.value("config", "") != c || r.value("rc", -1) != 0) continue;
      const double vox = r.value("voxels", 0.0), scan = r["stages"].value("scan", NAN);
      v.push_back(vox), t.push_back(scan);
      all_v.push_back(vox), all_t.push_back(scan);
      m.push_back(r.value("length_m", 0.0)), mb.push_back(r.value("peak_mb", NAN));
      const double tp = vox / scan / 1e6;
      if (std::isnan(min_tp) || tp < min_tp) {
        char b[96];
        std::snprintf(b, sizeof b, "%s, %.1f m", c.c_str(), r.value("length_m", 0.0));
        min_tp = tp, min_tp_row = b;
      }
    }
    if (v.empty()) continue;  // every run of it failed
    const Fit ft = fit(v, t), fm = fit(m, mb);
    const bool lengths = fm.n >= 2 && !std::isnan(fm.a);
    char fixed[32] = "- (one row: through 0)", slope[32] = "- (one length)";
    if (ft.n >= 2) std::snprintf(fixed, sizeof fixed, "%.2f s", ft.a);
    if (lengths) std::snprintf(slope, sizeof slope, "%.1f MB/m", fm.b);
    std::printf("| %s | %.2f ns/voxel | %s | %s |\n", c.c_str(), ft.b * 1e9, fixed, slope);
    if (lengths && (std::isnan(worst_slope) || fm.b > worst_slope))
      worst_slope = fm.b, worst_slope_cfg = c;
  }
  const Fit fa = fit(all_v, all_t);
  std::printf("| all | %.2f ns/voxel | %.2f s | |\n", fa.b * 1e9, fa.a);
  std::printf(
      "\ncost per voxel: least squares of the scan stage's seconds on voxels (slope, and the "
      "intercept as fixed cost); memory slope: least squares of peak MB on the log's length.\n");

  // Targets (issue 24).
  auto peak_of = [&](auto pred) {
    double p = NAN;
    for (const json& r : rows)
      if (pred(r)) p = r.value("peak_mb", NAN);
    return p;
  };
  const double gran = peak_of([](const json& r) {
    return r.value("config", "").find("gran1") != std::string::npos && r.value("rc", -1) == 0;
  });
  const double big = peak_of([](const json& r) {
    return r.value("config", "").find("1024") != std::string::npos &&
           std::abs(r.value("length_m", 0.0) - 6.0) < 0.01 && r.value("rc", -1) == 0;
  });
  std::printf("\n| target (issue 24) | result |\n|---|---|\n");
  std::printf("| peak <= %.0f MB, bundled 4 m log (gran1), report included | %s |\n", kGranPeakMb,
              verdict(gran, kGranPeakMb, true, "MB").c_str());
  std::printf("| peak <= %.0f MB, 6 m log at 1024² | %s |\n", kBig6mPeakMb,
              verdict(big, kBig6mPeakMb, true, "MB").c_str());
  std::printf("| memory slope over length < %.0f MB/m (steepest configuration%s%s) | %s |\n",
              kSlopeMbPerM, worst_slope_cfg.empty() ? "" : ": ", worst_slope_cfg.c_str(),
              verdict(worst_slope, kSlopeMbPerM, true, "MB/m").c_str());
  std::printf(
      "| scan throughput >= %.0f M voxels/s, within 20 %% of %.0f (slowest row%s%s) | %s |\n",
      kThroughputShare * kTodayMvoxPerS, kTodayMvoxPerS, min_tp_row.empty() ? "" : ": ",
      min_tp_row.c_str(),
      verdict(min_tp, kThroughputShare * kTodayMvoxPerS, false, "M voxels/s").c_str());
  std::printf(
      "| the same, against the gran1 row of this table: >= %.0f %% of its rate (slowest "
      "row%s%s) | %s |\n",
      100 * kThroughputShare, min_tp_row.empty() ? "" : ": ", min_tp_row.c_str(),
      verdict(100 * min_tp / gran_rate, 100 * kThroughputShare, false, "%").c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 2 && !std::strcmp(argv[1], "run")) return cmd_run(argc, argv);
  if (argc == 3 && !std::strcmp(argv[1], "table")) return cmd_table(argv[2]);
  return usage();
}

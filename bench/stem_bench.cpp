// stem_bench: accuracy and speed of the stem pass (issue 4) on phantoms with ground truth.
//
//   stem_bench [--slices N] [--spacing MM] [--random K]
//
// For each log (the three bundled ones and K freshly generated ones) and each condition
// ("clean": 512 x 512, 0.8 mm, the default 20 HU noise and bed; "hard": twice the noise, the
// bed touching the log, 5 % missing slices) it renders N slices in memory, runs scan_stem on
// them and compares with the phantom's truth: pith error (median, 95th percentile, worst slice),
// outer radius RMS over every angle and slice, heartwood radius RMS. A second table times the
// per-slice detectors alone on one core. Rendering is not timed.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "sawyer/ct/phantom.h"
#include "sawyer/ct/slice_source.h"
#include "sawyer/ct/stem_detect.h"
#include "sawyer/ct/stem_scan.h"
#include "sawyer/model/log_generator.h"
#include "sawyer/model/log_json.h"

using namespace sawyer;
using namespace sawyer::ct;

namespace {

// The phantom's kept slices, rendered up front, behind the SliceSource interface.
class PhantomSource final : public SliceSource {
 public:
  explicit PhantomSource(const Phantom& ph) : g_(ph.geometry()) {
    for (int k : ph.kept()) slices_.push_back(ph.render_slice(k));
  }
  Format format() const override { return Format::kDicom; }
  const VolumeGeometry& geometry() const override { return g_; }
  std::string description() const override { return "phantom"; }
  const std::vector<std::string>& notes() const override { return notes_; }
  Status read(int i, Slice& out) override {
    out = slices_[i];
    out.index = i;
    return Status::Ok();
  }

 private:
  VolumeGeometry g_;
  std::vector<Slice> slices_;
  std::vector<std::string> notes_;
};

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
}

struct Row {
  std::string log, condition;
  int slices = 0;
  double pith_median = 0, pith_p95 = 0, pith_worst = 0;
  int worst_slice = -1;
  double radius_rms = 0, heart_rms = 0;
  bool heart = false;
  double slices_per_s = 0;
};

Result<Row> run(const LogModel& log, const std::string& condition, int n, double spacing,
                std::uint64_t seed) {
  PhantomOptions o;
  o.slice_spacing_mm = spacing;
  const double mid = log.stem.z_begin() + 0.5 * log.stem.length_mm();
  o.from_mm = mid - 0.5 * spacing * (n - 1);
  o.to_mm = mid + 0.5 * spacing * (n - 1);
  o.seed = seed;
  if (condition == "hard") {
    o.noise_hu *= 2;
    o.drop_slices = std::max(1, n / 20);
  }
  auto ph = Phantom::create(log, o);
  if (!ph) return ph.error();
  const Phantom& p = *ph.value();
  auto raw = std::make_unique<PhantomSource>(p);
  OpenOptions oo;
  auto src = make_uniform_z(std::move(raw), oo);
  if (!src) return src.error();
  StemScanOptions so;
  auto scan = scan_stem(*src.value(), so);
  if (!scan) return scan.error();
  const StemScan& s = scan.value();
  const LogModel truth = p.truth_log();
  Row row;
  row.log = log.id;
  row.condition = condition;
  row.slices = static_cast<int>(s.slices.size());
  row.slices_per_s = s.slices_per_second();
  std::vector<double> err;
  double r2 = 0, h2 = 0;
  long rn = 0, hn = 0;
  for (size_t j = 0; j < s.slices.size(); ++j) {
    const StemSliceRecord& rec = s.slices[j];
    const double z = rec.z;
    const Vec2 want = truth.stem.pith_at(z);
    const double e = (rec.pith - want).norm();
    err.push_back(e);
    if (e > row.pith_worst) {
      row.pith_worst = e;
      row.worst_slice = static_cast<int>(j);
    }
    // Radii are compared on the truth's own pith, so a pith error does not count twice: the
    // measured contour point at azimuth w is re-expressed around the true pith.
    std::vector<double> rad = rec.contour.radius;
    std::vector<bool> ok = rec.contour.valid;
    recentre_contour(rec.pith, want, rad, ok);
    for (size_t k = 0; k < rad.size(); ++k) {
      if (!ok[k]) continue;
      const double w = kTwoPi * k / rad.size();
      const double d = rad[k] - truth.stem.radius_at(w, z);
      r2 += d * d;
      ++rn;
    }
    if (rec.heartwood.present && !truth.stem.heartwood.empty()) {
      std::vector<double> hr = rec.heartwood.radius;
      std::vector<bool> hok = rec.heartwood.valid;
      recentre_contour(rec.pith, want, hr, hok);
      for (size_t k = 0; k < hr.size(); ++k) {
        if (!hok[k]) continue;
        const double w = kTwoPi * k / hr.size();
        const double d = hr[k] - truth.stem.heartwood_at(w, z);
        h2 += d * d;
        ++hn;
      }
    }
  }
  row.pith_median = percentile(err, 0.5);
  row.pith_p95 = percentile(err, 0.95);
  row.radius_rms = rn ? std::sqrt(r2 / rn) : NAN;
  row.heart = hn > 0;
  row.heart_rms = hn ? std::sqrt(h2 / hn) : NAN;
  return row;
}

// Median milliseconds per slice of the three detectors on one core, with a pith prior.
double time_detectors(const LogModel& log) {
  PhantomOptions o;
  const double mid = log.stem.z_begin() + 0.5 * log.stem.length_mm();
  o.from_mm = mid;
  o.to_mm = mid + 45;
  auto ph = Phantom::create(log, o);
  if (!ph) return NAN;
  std::vector<double> ms;
  for (int i = 0; i < ph.value()->nominal_count(); ++i) {
    const Slice s = ph.value()->render_slice(i);
    const Vec2 prior = ph.value()->pith(i);
    for (int rep = 0; rep < 5; ++rep) {
      const auto t0 = std::chrono::steady_clock::now();
      const PithResult p = detect_pith(s, ph.value()->geometry(), {}, &prior);
      const ContourResult c = detect_contour(s, ph.value()->geometry(), p.pith_mm, {});
      const HeartwoodResult h = detect_heartwood(s, ph.value()->geometry(), p.pith_mm, c, {});
      ms.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      if (!p.found && h.present) ms.back() = NAN;  // keep the results alive
    }
  }
  return percentile(ms, 0.5);
}

}  // namespace

int main(int argc, char** argv) {
  int n = 40, random_logs = 2;
  double spacing = 5.0;
  for (int a = 1; a + 1 < argc; a += 2) {
    if (!std::strcmp(argv[a], "--slices")) n = std::atoi(argv[a + 1]);
    else if (!std::strcmp(argv[a], "--spacing")) spacing = std::atof(argv[a + 1]);
    else if (!std::strcmp(argv[a], "--random")) random_logs = std::atoi(argv[a + 1]);
  }
  std::vector<LogModel> logs;
  for (const char* name : {"gran1_spruce", "pine_8", "spruce_77"}) {
    auto r = read_log_json(std::string(SAWYER_SOURCE_DIR) + "/sample_logs/" + name + "/log.json");
    if (!r) {
      std::fprintf(stderr, "stem_bench: %s\n", r.error().message().c_str());
      return 1;
    }
    logs.push_back(std::move(r).value());
  }
  for (int k = 0; k < random_logs; ++k) {
    GeneratorOptions g;
    g.species = k % 2 ? Species::kSpruce : Species::kPine;
    g.seed = 1000 + k;
    auto r = generate_log(g);
    if (r) logs.push_back(std::move(r).value());
  }
  std::printf("Stem accuracy on phantoms (512 x 512, 0.8 mm, %d slices at %.1f mm)\n\n", n, spacing);
  std::printf("| log | condition | slices | pith median mm | pith p95 mm | worst mm (slice) | "
              "radius RMS mm | heartwood RMS mm | slices/s |\n");
  std::printf("|---|---|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const LogModel& log : logs) {
    for (const char* cond : {"clean", "hard"}) {
      auto row = run(log, cond, n, spacing, 7);
      if (!row) {
        std::printf("| %s | %s | error: %s |\n", log.id.c_str(), cond,
                    row.error().message().c_str());
        continue;
      }
      const Row& r = row.value();
      std::printf("| %s | %s | %d | %.2f | %.2f | %.2f (%d) | %.2f | %s | %.0f |\n", r.log.c_str(),
                  r.condition.c_str(), r.slices, r.pith_median, r.pith_p95, r.pith_worst,
                  r.worst_slice, r.radius_rms,
                  r.heart ? std::to_string(r.heart_rms).substr(0, 5).c_str() : "-",
                  r.slices_per_s);
      std::fflush(stdout);
    }
  }
  std::printf("\nDetectors alone, one core, median ms per 512 x 512 slice (pith with a prior + "
              "contour + heartwood)\n\n| log | ms/slice |\n|---|---:|\n");
  for (const LogModel& log : logs) std::printf("| %s | %.2f |\n", log.id.c_str(), time_detectors(log));
  return 0;
}

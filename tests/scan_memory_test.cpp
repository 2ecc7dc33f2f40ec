// The scan in bounded memory (issue 24): a log four times as long, with slices of the same size,
// takes about the same peak memory, as the process itself measures it (run.json's peak_mb per
// stage, getrusage); a budget too small is refused before anything is read or written.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "sawyer/model/log_json.h"
#include "sawyer/test/test_util.h"

namespace sawyer {
namespace {

namespace fs = std::filesystem;

// The scan stage's peak memory (MB) of `sawyer run` on `ct`, from its run.json.
double scan_peak_mb(const fs::path& ct, const fs::path& out) {
  std::string text;
  const int rc = test::run_sawyer(
      "run " + test::quoted(ct) + " -o " + test::quoted(out) + " --no-report --no-register -q",
      &text);
  EXPECT_TRUE(rc == 0 || rc == 3) << text;  // 3: written, QA verdict failed (coarse pixels)
  std::ifstream in(out / "run.json");
  EXPECT_TRUE(in.good()) << text;
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (!j.is_object() || !j.contains("stages")) return -1;
  for (const auto& s : j["stages"])
    if (s.value("name", "") == "scan") return s.value("peak_mb", -1.0);
  return -1;
}

TEST(ScanMemory, PeakDoesNotGrowWithTheLogsLength) {
  test::TempDir dir;
  const fs::path log = test::sample_log("gran1_spruce") / "log.json";
  // 1 m and the whole 4 m of the bundled spruce, the same 128 x 128 slices (3.2 mm pixels, the
  // knot pass's grid does not depend on them) 5 mm apart: 200 and 800 slices. Without windows
  // the knot pass's grid alone would grow by ~19 MB a metre here.
  const fs::path short_ct = dir.path() / "short", long_ct = dir.path() / "long";
  std::string text;
  const std::string common = " --size 128 --pixel-mm 3.2 --spacing-mm 5 --seed 2";
  ASSERT_EQ(test::run_sawyer("phantom " + test::quoted(log) + " -o " + test::quoted(short_ct) +
                                 common + " --from-mm 1000 --to-mm 1995",
                             &text),
            0)
      << text;
  ASSERT_EQ(test::run_sawyer(
                "phantom " + test::quoted(log) + " -o " + test::quoted(long_ct) + common, &text),
            0)
      << text;
  const double p1 = scan_peak_mb(short_ct, dir.path() / "run1");
  const double p4 = scan_peak_mb(long_ct, dir.path() / "run4");
  std::printf("scan peak: 1 m %.1f MB, 4 m %.1f MB (%.1f MB per metre)\n", p1, p4, (p4 - p1) / 3.0);
  ASSERT_GT(p1, 0);
  ASSERT_GT(p4, 0);
  EXPECT_LT(p4 / p1, 1.25);
  EXPECT_LT((p4 - p1) / 3.0, 12.0) << "MB per metre of log";
}

// Slices 1 mm apart: the stem comes at the 4 mm step (--stem-step, default), a quarter of the
// samples over the same length, and says what the stem of every slice says: the same pith and
// outline within a fraction of a millimetre, the same knots.
TEST(ScanMemory, FineSlicesGiveAStemAtTheStepThatAgreesWithOnePerSlice) {
  test::TempDir dir;
  const fs::path ct = dir.path() / "ct";
  std::string text;
  ASSERT_EQ(
      test::run_sawyer("phantom " + test::quoted(test::sample_log("gran1_spruce") / "log.json") +
                           " -o " + test::quoted(ct) +
                           " --size 160 --pixel-mm 2.4 --spacing-mm 1 --from-mm 1000 --to-mm 1399",
                       &text),
      0)
      << text;
  const auto scan = [&](const std::string& name, const std::string& options) {
    const fs::path out = dir.path() / name;
    const int rc = test::run_sawyer(
        "scan " + test::quoted(ct) + " -o " + test::quoted(out) + " " + options, &text);
    EXPECT_TRUE(rc == 0 || rc == 3) << text;  // 3: written, QA verdict failed
    Result<LogModel> log = read_log_json(out / "log.json");
    EXPECT_TRUE(log.ok()) << text;
    return log ? log.value() : LogModel{};
  };
  const LogModel coarse = scan("coarse", ""), fine = scan("fine", "--stem-step 0");
  ASSERT_EQ(fine.stem.slice_count(), 400);
  EXPECT_NEAR(fine.stem.dz_mm, 1.0, 1e-6);
  ASSERT_EQ(coarse.stem.slice_count(), 100);
  EXPECT_NEAR(coarse.stem.dz_mm, 4.0, 1e-6);
  EXPECT_NEAR(coarse.stem.z_begin(), fine.stem.z_begin(), 1e-6);
  EXPECT_NEAR(coarse.stem.z_end(), fine.stem.z_end(), 1e-6);
  double worst_pith = 0, radius_err2 = 0;
  int n = 0;
  for (int i = 0; i < coarse.stem.slice_count(); ++i) {
    const double z = coarse.stem.z_at(i);
    worst_pith = std::max(worst_pith, (coarse.stem.pith[i] - fine.stem.pith_at(z)).norm());
    for (int k = 0; k < 360; k += 10) {
      const double w = kTwoPi * k / 360;
      const double d = coarse.stem.radius_at(w, z) - fine.stem.radius_at(w, z);
      radius_err2 += d * d;
      ++n;
    }
  }
  std::printf("stem at 4 mm against one per slice: pith within %.3f mm, outline RMS %.3f mm\n",
              worst_pith, std::sqrt(radius_err2 / n));
  EXPECT_LT(worst_pith, 0.2);
  EXPECT_LT(std::sqrt(radius_err2 / n), 0.5);
  // The knot pass unrolled around either stem: the same knots, where they were. A knot near the
  // detection threshold may be found around one stem and not the other (or split in two), so
  // each knot of the shorter list is paired with the nearest unpaired one of the longer (by its
  // axis point, 40 mm out or at its end: its formula's z0, omega0 and twist trade against each
  // other within the fit's noise); all of the shorter list pair, and they are most of the
  // longer.
  ASSERT_GT(coarse.knots.size(), 0u);
  const bool coarse_shorter = coarse.knots.size() <= fine.knots.size();
  const std::vector<Knot>& few = coarse_shorter ? coarse.knots : fine.knots;
  const std::vector<Knot>& many = coarse_shorter ? fine.knots : coarse.knots;
  EXPECT_GE(static_cast<double>(few.size()), 0.85 * static_cast<double>(many.size()))
      << coarse.knots.size() << " knots around the coarse stem, " << fine.knots.size()
      << " around the fine one";
  const auto apart = [](const Knot& a, const Knot& b) {
    const double r = std::min({40.0, a.r_end, b.r_end});
    const double dh = a.height_at(r) - b.height_at(r);
    const double arc = r * std::remainder(a.azimuth_at(r) - b.azimuth_at(r), kTwoPi);
    return std::hypot(dh, arc);
  };
  std::vector<bool> taken(many.size(), false);
  for (size_t i = 0; i < few.size(); ++i) {
    size_t best = many.size();
    for (size_t j = 0; j < many.size(); ++j)
      if (!taken[j] && (best == many.size() || apart(few[i], many[j]) < apart(few[i], many[best])))
        best = j;
    ASSERT_LT(best, many.size()) << "knot " << i << " has no partner";
    taken[best] = true;
    const Knot &a = few[i], &b = many[best];
    const double r = std::min({40.0, a.r_end, b.r_end});
    std::printf("knot %zu at r %.0f mm: height %.2f / %.2f mm, azimuth %.3f / %.3f rad\n", i, r,
                a.height_at(r), b.height_at(r), a.azimuth_at(r), b.azimuth_at(r));
    EXPECT_LT(apart(a, b), 3.0) << "knot " << i;
    EXPECT_NEAR(a.r_end, b.r_end, 10.0) << "knot " << i;
  }
}

TEST(ScanMemory, ANegativeStemStepIsRefusedNamingTheOption) {
  test::TempDir dir;
  const fs::path out = dir.path() / "out";
  std::string text;
  for (const std::string cmd : {"scan", "run --no-register"}) {
    EXPECT_NE(test::run_sawyer(cmd + " " + test::quoted(dir.path()) + " -o " + test::quoted(out) +
                                   " --stem-step -1",
                               &text),
              0);
    EXPECT_NE(text.find("-1 is outside 0-1000 mm"), std::string::npos) << text;
    EXPECT_NE(text.find("--stem-step"), std::string::npos) << text;
    EXPECT_FALSE(fs::exists(out)) << "nothing written";
  }
  // NaN passed CLI11's range; the option's own check refuses it (the scan would too, before
  // reading a slice).
  const fs::path ct = dir.path() / "ct";
  ASSERT_EQ(test::run_sawyer(
                "phantom " + test::quoted(test::sample_log("gran1_spruce") / "log.json") + " -o " +
                    test::quoted(ct) + " --size 128 --pixel-mm 3.2 --from-mm 1000 --to-mm 1100",
                &text),
            0)
      << text;
  EXPECT_NE(
      test::run_sawyer("scan " + test::quoted(ct) + " -o " + test::quoted(out) + " --stem-step nan",
                       &text),
      0);
  EXPECT_NE(text.find("--stem-step: nan is outside 0-1000 mm"), std::string::npos) << text;
  EXPECT_FALSE(fs::exists(out)) << "nothing written";
}

TEST(ScanMemory, ABudgetTooSmallIsRefusedUpFrontNamingTheFigure) {
  test::TempDir dir;
  const fs::path ct = dir.path() / "ct", out = dir.path() / "run";
  std::string text;
  ASSERT_EQ(test::run_sawyer(
                "phantom " + test::quoted(test::sample_log("gran1_spruce") / "log.json") + " -o " +
                    test::quoted(ct) + " --size 128 --pixel-mm 3.2 --from-mm 1000 --to-mm 1200",
                &text),
            0)
      << text;
  EXPECT_NE(test::run_sawyer("run " + test::quoted(ct) + " -o " + test::quoted(out) +
                                 " --no-register --memory 40",
                             &text),
            0);
  EXPECT_NE(text.find("memory budget"), std::string::npos) << text;
  EXPECT_NE(text.find("over the budget of 40 MB (--memory)"), std::string::npos) << text;
  EXPECT_NE(text.find("this scan needs at least"), std::string::npos) << text;
  EXPECT_FALSE(fs::exists(out)) << "nothing written";
  EXPECT_EQ(text.find("scan:"), std::string::npos) << "refused before a slice was read: " << text;
}

}  // namespace
}  // namespace sawyer

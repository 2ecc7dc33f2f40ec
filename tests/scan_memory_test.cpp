// The scan in bounded memory (issue 24): a log four times as long, with slices of the same size,
// takes about the same peak memory, as the process itself measures it (run.json's peak_mb per
// stage, getrusage); a budget too small is refused before anything is read or written.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>

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

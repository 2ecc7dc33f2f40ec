// log.json: exact round trips, and malformed files rejected with the key that is wrong.
#include "sawyer/model/log_json.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>

#include "sawyer/core/file_util.h"
#include "sawyer/core/stats.h"
#include "sawyer/test/test_util.h"

namespace sawyer {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

// A small log with awkward numbers (not representable in few digits) in every field.
LogModel awkward_log() {
  LogModel log;
  log.id = "t\"est\\log";
  log.species = "pine";
  log.source = "unit test, ünïcode";
  Stem& s = log.stem;
  s.z0_mm = 1.0 / 3.0;
  s.dz_mm = 2.0 * kPi;
  s.n_angles = 7;
  for (int i = 0; i < 5; ++i) {
    s.pith.push_back({std::sqrt(2.0) * i, -std::exp(0.1 * i)});
    std::vector<double> r(7), h(7);
    for (int k = 0; k < 7; ++k) {
      r[k] = 100.0 + std::sin(i * 7 + k) / 3.0 + 1e-13 * k;
      h[k] = 0.5 * r[k] - 1e-9;
    }
    s.radius.push_back(r);
    s.heartwood.push_back(h);
    s.bark_mm.push_back(4.0 + i / 7.0);
  }
  for (int j = 0; j < 3; ++j) {
    Knot k;
    k.id = 10 + j;
    k.z0 = 1.23456789012345678 * (j + 1);
    k.a = -0.1 / 3.0;
    k.b = 0.31415926535897931;
    k.omega0 = 6.2831 - 1e-15;
    k.twist = -1e-7 / 3.0;
    k.r_dead = 12.0 / 7.0;
    k.r_end = 99.99999999999999;
    k.diameter = {17.0 / 3.0, 0.7777777777777};
    k.fit_rms_mm = 0.125 + j;
    k.support = 1000 + j;
    log.knots.push_back(k);
  }
  return log;
}

void expect_identical(const LogModel& a, const LogModel& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.species, b.species);
  EXPECT_EQ(a.source, b.source);
  EXPECT_EQ(a.stem.z0_mm, b.stem.z0_mm);
  EXPECT_EQ(a.stem.dz_mm, b.stem.dz_mm);
  EXPECT_EQ(a.stem.n_angles, b.stem.n_angles);
  EXPECT_EQ(a.stem.pith, b.stem.pith);
  EXPECT_EQ(a.stem.radius, b.stem.radius);
  EXPECT_EQ(a.stem.heartwood, b.stem.heartwood);
  EXPECT_EQ(a.stem.bark_mm, b.stem.bark_mm);
  ASSERT_EQ(a.knots.size(), b.knots.size());
  for (size_t i = 0; i < a.knots.size(); ++i) {
    const Knot &x = a.knots[i], &y = b.knots[i];
    EXPECT_EQ(x.id, y.id);
    EXPECT_EQ(x.z0, y.z0);
    EXPECT_EQ(x.a, y.a);
    EXPECT_EQ(x.b, y.b);
    EXPECT_EQ(x.omega0, y.omega0);
    EXPECT_EQ(x.twist, y.twist);
    EXPECT_EQ(x.r_dead, y.r_dead);
    EXPECT_EQ(x.r_end, y.r_end);
    EXPECT_EQ(x.diameter.d_dead, y.diameter.d_dead);
    EXPECT_EQ(x.diameter.exponent, y.diameter.exponent);
    EXPECT_EQ(x.fit_rms_mm, y.fit_rms_mm);
    EXPECT_EQ(x.support, y.support);
  }
}

TEST(LogJson, RoundTripIsBitExact) {
  const LogModel log = awkward_log();
  const std::string text = log_to_json(log);
  Result<LogModel> back = log_from_json(text);
  ASSERT_TRUE(back) << back.error().message();
  expect_identical(log, back.value());
  EXPECT_EQ(log_to_json(back.value()), text);
}

// The bark at every angle (Stem::bark, what a scan measures): written as a row per sample under
// "bark_mm", read back bit-exact, each row's median its bark_mm; the one-figure form still reads.
TEST(LogJson, BarkAtEveryAngleRoundTripsAndTheOneFigureFormStillReads) {
  LogModel log = awkward_log();
  for (int i = 0; i < log.stem.slice_count(); ++i) {
    std::vector<double> row(7);
    for (int k = 0; k < 7; ++k) row[k] = 2.0 + (i * 7 + k) % 9 / 3.0;
    log.stem.bark.push_back(row);
    log.stem.bark_mm[static_cast<size_t>(i)] = median(row);
  }
  const std::string text = log_to_json(log);
  const Json j = Json::parse(text);
  ASSERT_TRUE(j["stem"]["bark_mm"].is_array());
  ASSERT_TRUE(j["stem"]["bark_mm"][0].is_array());
  EXPECT_EQ(j["stem"]["bark_mm"][0].size(), 7u);
  Result<LogModel> back = log_from_json(text);
  ASSERT_TRUE(back) << back.error().message();
  expect_identical(log, back.value());
  EXPECT_EQ(back.value().stem.bark, log.stem.bark);
  EXPECT_EQ(log_to_json(back.value()), text);
  // A negative or absurd bark at one angle is refused, naming the sample and the angle.
  Json bad = j;
  bad["stem"]["bark_mm"][3][5] = -0.5;
  Result<LogModel> refused = log_from_json(bad.dump());
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message().find("stem.bark_mm[3][5]"), std::string::npos)
      << refused.error().message();
  bad["stem"]["bark_mm"][3].erase(5);
  refused = log_from_json(bad.dump());
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message().find("stem.bark_mm[3]"), std::string::npos)
      << refused.error().message();
  // Without rows: one figure per sample, as before.
  log.stem.bark.clear();
  Result<LogModel> scalars = log_from_json(log_to_json(log));
  ASSERT_TRUE(scalars) << scalars.error().message();
  EXPECT_TRUE(scalars.value().stem.bark.empty());
  EXPECT_EQ(scalars.value().stem.bark_mm, log.stem.bark_mm);
}

TEST(LogJson, FileRoundTripIsBitExactAndLeavesNoTemporaryFiles) {
  test::TempDir dir;
  const LogModel log = awkward_log();
  ASSERT_TRUE(write_log_json(log, dir / "sub/log.json"));
  Result<LogModel> back = read_log_json(dir / "sub/log.json");
  ASSERT_TRUE(back) << back.error().message();
  expect_identical(log, back.value());
  int files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir / "sub")) ++files;
  EXPECT_EQ(files, 1);
}

TEST(LogJson, UsesTheFixedKeyNames) {
  const Json j = Json::parse(log_to_json(awkward_log()));
  EXPECT_EQ(j["format"], "sawyer-log/1");
  for (const char* key : {"z0_mm", "dz_mm", "pith", "radius"})
    EXPECT_TRUE(j["stem"].contains(key)) << key;
  for (const char* key : {"z0", "a", "b", "omega0", "twist", "r_dead", "r_end", "d_dead", "d_exp"})
    EXPECT_TRUE(j["knots"][0].contains(key)) << key;
  EXPECT_EQ(j["stem"]["pith"][1].size(), 2u);
  EXPECT_EQ(j["stem"]["radius"][0].size(), 7u);
}

// Parses `log_to_json(awkward_log())` after `edit` and returns the error message.
std::string error_after(const std::function<void(Json&)>& edit) {
  Json j = Json::parse(log_to_json(awkward_log()));
  edit(j);
  Result<LogModel> r = log_from_json(j.dump());
  if (r) return "(accepted)";
  return r.error().message();
}

// The scanner frame (docs/formats.md): optional; written and read back bit-exact; a file
// without it loads with no frame (identity at 0); a bad frame is refused naming the key.
TEST(LogJson, ScannerFrameRoundTripsAndIsOptional) {
  LogModel log = awkward_log();
  EXPECT_FALSE(Json::parse(log_to_json(log)).contains("scanner_frame"));
  Result<LogModel> old = log_from_json(log_to_json(log));
  ASSERT_TRUE(old) << old.error().message();
  EXPECT_FALSE(old.value().scanner_frame.has_value());

  ScannerFrame f;
  f.origin_mm = {-204.8, -204.8 + 1.0 / 3, 1234.5};
  f.row_dir = {-1, 0, 0};
  f.col_dir = {0, 1, 0};
  f.z0_mm = 1234.5 + 0.1;
  f.z_dir = -1;
  place_in_scanner_frame(log, {-204.8, 0.25}, f);
  const std::string text = log_to_json(log);
  Result<LogModel> back = log_from_json(text);
  ASSERT_TRUE(back) << back.error().message();
  ASSERT_TRUE(back.value().scanner_frame.has_value());
  const ScannerFrame& g = *back.value().scanner_frame;
  EXPECT_EQ(g.origin_mm, f.origin_mm);
  EXPECT_EQ(g.row_dir, f.row_dir);
  EXPECT_EQ(g.col_dir, f.col_dir);
  EXPECT_EQ(g.z0_mm, f.z0_mm);
  EXPECT_EQ(g.z_dir, f.z_dir);
  EXPECT_EQ(g.scanner_z(10), 1234.6 - 10);
  EXPECT_EQ(back.value().stem.pith[0], log.stem.pith[0]);
  EXPECT_EQ(log_to_json(back.value()), text);

  using ::testing::HasSubstr;
  const auto bad = [&](const std::function<void(Json&)>& edit) {
    Json j = Json::parse(text);
    edit(j);
    Result<LogModel> r = log_from_json(j.dump());
    return r ? std::string("(accepted)") : r.error().message();
  };
  EXPECT_THAT(bad([](Json& j) { j["scanner_frame"]["z_dir"] = 0.5; }),
              HasSubstr("scanner_frame.z_dir: 0.5 must be 1 or -1"));
  EXPECT_THAT(bad([](Json& j) {
                j["scanner_frame"]["row_dir"] = {2, 0, 0};
              }),
              HasSubstr("scanner_frame.row_dir: (2, 0, 0) is not a unit vector"));
  EXPECT_THAT(bad([](Json& j) {
                j["scanner_frame"]["col_dir"] = {1, 0, 0};
              }),
              HasSubstr("scanner_frame.col_dir: is not perpendicular to row_dir"));
  EXPECT_THAT(bad([](Json& j) {
                j["scanner_frame"]["origin_mm"] = {0, 0};
              }),
              HasSubstr("scanner_frame.origin_mm: has 2 values, expected 3"));
  EXPECT_THAT(bad([](Json& j) { j["scanner_frame"]["z0_mm"] = 1e9; }),
              HasSubstr("scanner_frame.z0_mm: 1e+09 mm is outside -100000 to 100000 mm"));
  EXPECT_THAT(bad([](Json& j) { j["scanner_frame"].erase("z0_mm"); }),
              HasSubstr("scanner_frame.z0_mm: missing key"));
  EXPECT_THAT(bad([](Json& j) { j["scanner_frame"] = 3; }),
              HasSubstr("scanner_frame: expected an object"));
}

TEST(LogJson, MalformedFilesNameTheKeyAndTheProblem) {
  using ::testing::HasSubstr;
  EXPECT_THAT(error_after([](Json& j) { j.erase("format"); }), HasSubstr("format: missing key"));
  EXPECT_THAT(error_after([](Json& j) { j["format"] = "sawyer-log/9"; }),
              HasSubstr("expected \"sawyer-log/1\""));
  EXPECT_THAT(error_after([](Json& j) { j["stem"].erase("dz_mm"); }),
              HasSubstr("stem.dz_mm: missing key"));
  EXPECT_THAT(error_after([](Json& j) { j["stem"]["dz_mm"] = "ten"; }),
              HasSubstr("stem.dz_mm: expected a number, got string"));
  EXPECT_THAT(error_after([](Json& j) { j["stem"]["dz_mm"] = -1; }),
              HasSubstr("stem.dz_mm: must be positive"));
  EXPECT_THAT(error_after([](Json& j) { j["stem"]["radius"].erase(1); }),
              HasSubstr("stem.radius: has 4 rows, expected 5"));
  EXPECT_THAT(error_after([](Json& j) { j["stem"]["radius"][2].erase(3); }),
              HasSubstr("stem.radius[2]: has 6 values, expected 7"));
  EXPECT_THAT(error_after([](Json& j) { j["stem"]["radius"][2][3] = -4; }),
              HasSubstr("stem.radius[2][3]: radius must be a positive"));
  EXPECT_THAT(error_after([](Json& j) { j["stem"]["radius"][2][3] = nullptr; }),
              HasSubstr("stem.radius[2][3]: expected a number, got null"));
  EXPECT_THAT(error_after([](Json& j) {
                j["stem"]["pith"][4] = {1, 2, 3};
              }),
              HasSubstr("stem.pith[4]: expected [x, y]"));
  EXPECT_THAT(error_after([](Json& j) { j["knots"][2].erase("r_end"); }),
              HasSubstr("knots[2].r_end: missing key"));
  EXPECT_THAT(error_after([](Json& j) { j["knots"][1]["twist"] = true; }),
              HasSubstr("knots[1].twist: expected a number, got boolean"));
  EXPECT_THAT(error_after([](Json& j) { j["knots"][0]["r_end"] = 0; }),
              HasSubstr("knots[0].r_end: must be positive"));
  EXPECT_THAT(error_after([](Json& j) { j["knots"][0]["d_exp"] = 0; }),
              HasSubstr("knots[0].d_exp: must be positive"));
  EXPECT_THAT(error_after([](Json& j) { j["knots"] = Json::object(); }),
              HasSubstr("knots: expected an array"));
  EXPECT_THAT(error_after([](Json& j) { j["stem"]["bark_mm"].erase(0); }),
              HasSubstr("stem.bark_mm: has 4 values"));
  EXPECT_THAT(error_after([](Json& j) { j["stem"]["heartwood"][0][0] = -1; }),
              HasSubstr("stem.heartwood[0][0]: must not be negative"));
  EXPECT_THAT(error_after([](Json& j) { j = Json::array(); }), HasSubstr("expected a JSON object"));
}

TEST(LogJson, TruncatedFileNamesTheFileAndLine) {
  test::TempDir dir;
  const std::string text = log_to_json(awkward_log());
  const fs::path path = dir / "cut.json";
  test::write_file(path, text.substr(0, text.size() / 2));
  Result<LogModel> r = read_log_json(path);
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(), ::testing::HasSubstr(path.string() + ": line "));
  EXPECT_THAT(r.error().message(), ::testing::HasSubstr("malformed JSON"));
}

TEST(LogJson, MissingFileAndFolderAreNamed) {
  test::TempDir dir;
  Result<LogModel> r = read_log_json(dir / "nope.json");
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().message(), (dir / "nope.json").string() + ": no such file");
  r = read_log_json(dir.path());
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(), ::testing::HasSubstr("is a folder"));
}

TEST(LogJson, InvalidModelIsNotWrittenAndLeavesNothingBehind) {
  test::TempDir dir;
  LogModel log = awkward_log();
  log.stem.radius[1][1] = std::nan("");
  Status st = write_log_json(log, dir / "bad.json");
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message(), ::testing::HasSubstr("stem.radius[1][1]"));
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(LogJson, UnwritableDestinationFailsCleanly) {
  test::TempDir dir;
  test::write_file(dir / "file", "x");  // a file where a folder is needed
  Status st = write_log_json(awkward_log(), dir / "file" / "log.json");
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message(), ::testing::HasSubstr("file"));
}

}  // namespace
}  // namespace sawyer

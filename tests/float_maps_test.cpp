// Float maps (docs/maps.md): the model at float32 precision in OpenEXR images plus a JSON
// header. Round trips exact to float32 rounding, the documented layout, and bad inputs.
#include "sawyer/maps/float_maps.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "sawyer/core/file_util.h"
#include "sawyer/model/gran1_import.h"
#include "sawyer/test/test_util.h"

namespace sawyer {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using Json = nlohmann::json;

// The value a double becomes after a trip through float32.
double f32(double v) { return static_cast<double>(static_cast<float>(v)); }

// A small log with awkward numbers (none exactly representable in float32) in every field.
LogModel awkward_log() {
  LogModel log;
  log.id = "awkward \"log\"";
  log.species = "pine";
  log.source = "float_maps_test, ünïcode";
  Stem& s = log.stem;
  s.z0_mm = 1.0 / 3.0 - 50.0;
  s.dz_mm = 2.0 * kPi;
  s.n_angles = 7;
  for (int i = 0; i < 5; ++i) {
    s.pith.push_back({1234.5678901 + std::sqrt(2.0) * i, -std::exp(0.1 * i) * 100.0});
    std::vector<double> r(7), h(7);
    for (int k = 0; k < 7; ++k) {
      r[k] = 100.0 + std::sin(i * 7 + k) / 3.0;
      h[k] = 0.5 * r[k] - 1e-9;
    }
    s.radius.push_back(r);
    s.heartwood.push_back(h);
    s.bark_mm.push_back(4.0 + i / 7.0);
  }
  for (int j = 0; j < 4; ++j) {
    Knot k;
    k.id = 1000003 + 17 * j;
    k.z0 = 1.23456789012345678 * (j + 1) * 10.0;
    k.a = -0.1 / 3.0 * (j + 1);
    k.b = 0.31415926535897931 / (j + 1);
    k.omega0 = 6.2831 - 1e-7 * j;
    k.twist = -1e-7 / 3.0 + 0.01 * j;
    k.r_dead = 12.0 / 7.0 * (j + 1);
    k.r_end = 99.99999999999999 - j;
    k.diameter = {17.0 / 3.0, 0.7777777777777};
    k.fit_rms_mm = 0.125 / 3.0 + j;
    k.support = 16777216 - j;  // 2^24: the largest float32 integer range
    log.knots.push_back(k);
  }
  return log;
}

void expect_equal_to_float32(const LogModel& want, const LogModel& got) {
  EXPECT_EQ(got.id, want.id);
  EXPECT_EQ(got.species, want.species);
  EXPECT_EQ(got.source, want.source);
  const Stem& a = want.stem;
  const Stem& b = got.stem;
  // The header keeps full double precision.
  EXPECT_EQ(b.z0_mm, a.z0_mm);
  EXPECT_EQ(b.dz_mm, a.dz_mm);
  EXPECT_EQ(b.n_angles, a.n_angles);
  EXPECT_EQ(b.bark_mm, a.bark_mm);
  ASSERT_EQ(b.slice_count(), a.slice_count());
  ASSERT_EQ(b.has_heartwood(), a.has_heartwood());
  for (int i = 0; i < a.slice_count(); ++i) {
    EXPECT_EQ(b.pith[i].x, f32(a.pith[i].x)) << "slice " << i;
    EXPECT_EQ(b.pith[i].y, f32(a.pith[i].y)) << "slice " << i;
    for (int k = 0; k < a.n_angles; ++k) {
      EXPECT_EQ(b.radius[i][k], f32(a.radius[i][k])) << "slice " << i << " angle " << k;
      if (a.has_heartwood()) {
        EXPECT_EQ(b.heartwood[i][k], f32(a.heartwood[i][k]));
      }
    }
  }
  ASSERT_EQ(got.knots.size(), want.knots.size());
  for (size_t i = 0; i < want.knots.size(); ++i) {
    const Knot& x = want.knots[i];
    const Knot& y = got.knots[i];
    SCOPED_TRACE("knot " + std::to_string(i));
    EXPECT_EQ(y.id, x.id);
    EXPECT_EQ(y.support, x.support);
    EXPECT_EQ(y.z0, f32(x.z0));
    EXPECT_EQ(y.a, f32(x.a));
    EXPECT_EQ(y.b, f32(x.b));
    EXPECT_EQ(y.omega0, f32(x.omega0));
    EXPECT_EQ(y.twist, f32(x.twist));
    EXPECT_EQ(y.r_dead, f32(x.r_dead));
    EXPECT_EQ(y.r_end, f32(x.r_end));
    EXPECT_EQ(y.diameter.d_dead, f32(x.diameter.d_dead));
    EXPECT_EQ(y.diameter.exponent, f32(x.diameter.exponent));
    EXPECT_EQ(y.fit_rms_mm, f32(x.fit_rms_mm));
  }
}

Json read_json(const fs::path& p) {
  Result<std::string> text = read_text_file(p);
  EXPECT_TRUE(text) << p;
  return text ? Json::parse(text.value()) : Json();
}

TEST(FloatMaps, RoundTripIsExactToFloat32) {
  const LogModel want = awkward_log();
  test::TempDir tmp;
  Status st = export_float_maps(want, tmp / "f");
  ASSERT_TRUE(st) << st.error().message();
  Result<LogModel> got = import_float_maps(tmp / "f");
  ASSERT_TRUE(got) << got.error().message();
  expect_equal_to_float32(want, got.value());
  // And a second trip changes nothing at all.
  ASSERT_TRUE(export_float_maps(got.value(), tmp / "g"));
  Result<LogModel> again = import_float_maps(tmp / "g");
  ASSERT_TRUE(again);
  expect_equal_to_float32(got.value(), again.value());
}

TEST(FloatMaps, RealLogRoundTripIsExactToFloat32) {
  Result<LogModel> gran1 = import_gran1(test::gran1_source_dir());
  ASSERT_TRUE(gran1) << gran1.error().message();
  test::TempDir tmp;
  ASSERT_TRUE(export_float_maps(gran1.value(), tmp / "f"));
  Result<LogModel> got = import_float_maps(tmp / "f");
  ASSERT_TRUE(got) << got.error().message();
  EXPECT_FALSE(got.value().stem.has_heartwood());
  EXPECT_EQ(got.value().knots.size(), 108u);
  expect_equal_to_float32(gran1.value(), got.value());
}

TEST(FloatMaps, HeaderDescribesTheLayout) {
  LogModel log = awkward_log();
  test::TempDir tmp;
  ASSERT_TRUE(export_float_maps(log, tmp / "f"));
  const Json j = read_json(tmp / "f" / "float_maps.json");
  EXPECT_EQ(j["format"], "sawyer-float-maps/1");
  EXPECT_EQ(j["n_angles"], 7);
  EXPECT_EQ(j["n_slices"], 5);
  EXPECT_EQ(j["n_knots"], 4);
  EXPECT_EQ(j["has_heartwood"], true);
  EXPECT_EQ(j["bark_mm"].size(), 5u);
  EXPECT_EQ(j["layout"]["stem.exr"]["channels"],
            Json::array({"pith_x", "pith_y", "radius", "heartwood"}));
  EXPECT_EQ(j["layout"]["knots.exr"]["texels"],
            Json::parse(R"([["z0", "a", "b", "omega0"], ["twist", "r_dead", "r_end", "d_dead"],
                            ["d_exp", "id", "fit_rms_mm", "support"]])"));
  EXPECT_TRUE(fs::exists(tmp / "f" / "stem.exr"));
  EXPECT_TRUE(fs::exists(tmp / "f" / "knots.exr"));
}

TEST(FloatMaps, LogWithoutKnotsHeartwoodOrBarkRoundTrips) {
  LogModel log = awkward_log();
  log.knots.clear();
  log.stem.heartwood.clear();
  log.stem.bark_mm.clear();
  test::TempDir tmp;
  ASSERT_TRUE(export_float_maps(log, tmp / "f"));
  EXPECT_FALSE(fs::exists(tmp / "f" / "knots.exr"));
  const Json j = read_json(tmp / "f" / "float_maps.json");
  EXPECT_FALSE(j.contains("bark_mm"));
  EXPECT_EQ(j["has_heartwood"], false);
  Result<LogModel> got = import_float_maps(tmp / "f");
  ASSERT_TRUE(got) << got.error().message();
  EXPECT_TRUE(got.value().knots.empty());
  EXPECT_FALSE(got.value().stem.has_heartwood());
  EXPECT_TRUE(got.value().stem.bark_mm.empty());
  expect_equal_to_float32(log, got.value());
}

// ---- bad input
// ------------------------------------------------------------------------------------

struct BrokenFloatMaps {
  test::TempDir tmp;
  fs::path dir = tmp / "f";
  BrokenFloatMaps() { EXPECT_TRUE(export_float_maps(awkward_log(), dir)); }
  std::string import_error() const {
    Result<LogModel> r = import_float_maps(dir);
    EXPECT_FALSE(r) << "import should fail";
    return r ? std::string() : r.error().message();
  }
  void edit_header(const std::function<void(Json&)>& edit) const {
    Json j = read_json(dir / "float_maps.json");
    edit(j);
    test::write_file(dir / "float_maps.json", j.dump(2));
  }
};

TEST(FloatMapsBadInput, MissingHeader) {
  BrokenFloatMaps m;
  fs::remove(m.dir / "float_maps.json");
  EXPECT_THAT(m.import_error(), HasSubstr((m.dir / "float_maps.json").string() + ": no such file"));
}

TEST(FloatMapsBadInput, WrongFormatTag) {
  BrokenFloatMaps m;
  m.edit_header([](Json& j) { j["format"] = "sawyer-maps/1"; });
  EXPECT_THAT(m.import_error(), HasSubstr("float_maps.json: format: is 'sawyer-maps/1', expected "
                                          "'sawyer-float-maps/1'"));
}

TEST(FloatMapsBadInput, MalformedHeader) {
  BrokenFloatMaps m;
  test::write_file(m.dir / "float_maps.json", "{\"format\": ");
  EXPECT_THAT(m.import_error(), HasSubstr("float_maps.json: malformed JSON"));
}

TEST(FloatMapsBadInput, MissingOrMistypedKey) {
  BrokenFloatMaps m;
  m.edit_header([](Json& j) { j.erase("dz_mm"); });
  EXPECT_THAT(m.import_error(), HasSubstr("float_maps.json: dz_mm: missing key"));
  ASSERT_TRUE(export_float_maps(awkward_log(), m.dir));
  m.edit_header([](Json& j) { j["n_slices"] = "five"; });
  EXPECT_THAT(m.import_error(),
              HasSubstr("float_maps.json: n_slices: expected a number, got string"));
  ASSERT_TRUE(export_float_maps(awkward_log(), m.dir));
  m.edit_header([](Json& j) { j["bark_mm"].erase(0); });
  EXPECT_THAT(m.import_error(),
              HasSubstr("float_maps.json: bark_mm: has 4 values, expected n_slices = 5"));
}

TEST(FloatMapsBadInput, MissingStemExr) {
  BrokenFloatMaps m;
  fs::remove(m.dir / "stem.exr");
  EXPECT_THAT(m.import_error(), HasSubstr((m.dir / "stem.exr").string() + ": no such file"));
}

TEST(FloatMapsBadInput, MissingKnotsExr) {
  BrokenFloatMaps m;
  fs::remove(m.dir / "knots.exr");
  EXPECT_THAT(m.import_error(), HasSubstr((m.dir / "knots.exr").string() + ": no such file"));
}

TEST(FloatMapsBadInput, CorruptExr) {
  BrokenFloatMaps m;
  test::write_file(m.dir / "stem.exr", "not an OpenEXR file, just words");
  const std::string e = m.import_error();
  EXPECT_THAT(e, HasSubstr((m.dir / "stem.exr").string() + ": cannot read as an OpenEXR image"));
  EXPECT_EQ(e.find('\n'), std::string::npos);
}

TEST(FloatMapsBadInput, TruncatedExr) {
  BrokenFloatMaps m;
  const fs::path p = m.dir / "knots.exr";
  fs::resize_file(p, fs::file_size(p) - 40);
  EXPECT_THAT(m.import_error(), HasSubstr(p.string() + ": corrupt or truncated image data"));
  fs::resize_file(p, 30);
  EXPECT_THAT(m.import_error(), HasSubstr(p.string() + ": cannot read as an OpenEXR image"));
}

TEST(FloatMapsBadInput, StemSizeDisagreesWithHeader) {
  BrokenFloatMaps m;
  m.edit_header([](Json& j) { j["n_angles"] = 6; });
  EXPECT_THAT(m.import_error(), HasSubstr("stem.exr: expected 6 columns, found 7"));
  ASSERT_TRUE(export_float_maps(awkward_log(), m.dir));
  m.edit_header([](Json& j) {
    j["n_slices"] = 4;
    j["bark_mm"].erase(0);
  });
  EXPECT_THAT(m.import_error(), HasSubstr("stem.exr: expected 4 rows, found 5"));
}

TEST(FloatMapsBadInput, KnotCountDisagreesWithHeader) {
  BrokenFloatMaps m;
  m.edit_header([](Json& j) { j["n_knots"] = 3; });
  EXPECT_THAT(m.import_error(), HasSubstr("knots.exr: expected 3 rows, found 4"));
}

TEST(FloatMapsBadInput, WrongImageInPlace) {
  BrokenFloatMaps m;
  fs::copy_file(m.dir / "knots.exr", m.dir / "stem.exr", fs::copy_options::overwrite_existing);
  EXPECT_THAT(m.import_error(), HasSubstr("stem.exr: missing channel 'pith_x'"));
}

// ---- failed exports leave nothing behind -------------------------------------------------------

std::set<std::string> entries(const fs::path& dir) {
  std::set<std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) out.insert(e.path().string());
  return out;
}

TEST(FloatMapsExport, FailureLeavesNoPartialFolder) {
  test::TempDir tmp;
  // Fails while encoding knots.exr, after stem.exr was written to the temporary folder.
  LogModel bad = awkward_log();
  bad.knots[2].id = (1 << 24) + 1;
  Status st = export_float_maps(bad, tmp / "f");
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message(), HasSubstr((tmp / "f" / "knots.exr").string()));
  EXPECT_THAT(st.error().message(), HasSubstr("2^24"));
  EXPECT_TRUE(entries(tmp.path()).empty()) << "no folder, no temporary folder";

  // An existing folder stays as it was.
  ASSERT_TRUE(export_float_maps(awkward_log(), tmp / "f"));
  const auto before = entries(tmp.path());
  const std::string header = read_text_file(tmp / "f" / "float_maps.json").value();
  ASSERT_FALSE(export_float_maps(bad, tmp / "f"));
  bad = awkward_log();
  bad.knots[0].r_end = std::nan("");
  st = export_float_maps(bad, tmp / "f");
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message(), HasSubstr("knots[0]"));
  bad = awkward_log();
  bad.stem.heartwood[2][3] = std::nan("");
  st = export_float_maps(bad, tmp / "f");
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message(), HasSubstr("stem.heartwood[2][3]: not a finite number"));
  EXPECT_EQ(entries(tmp.path()), before);
  EXPECT_EQ(read_text_file(tmp / "f" / "float_maps.json").value(), header);
}

}  // namespace
}  // namespace sawyer

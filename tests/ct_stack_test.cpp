// TIFF and PNG stacks: write -> read round trips for every stack format (values within the
// rescale's quantisation, geometry exact), file order, the sidecar and the command-line options
// that override it, and stacks written by OpenImageIO directly (ImageJ-style tags, 8-bit,
// float, grey stored as RGB), read through open_ct().
#include <OpenImageIO/imageio.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "../ct_pipeline/io/src/readers.h"
#include "../ct_pipeline/io/src/sidecar.h"
#include "sawyer/ct/slice_sink.h"
#include "sawyer/ct/slice_source.h"
#include "sawyer/test/ct_pattern.h"
#include "sawyer/test/test_util.h"

namespace sawyer::ct {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// "s" + std::to_string(i) + ".tif", spelled so that GCC 12 does not warn falsely (-Wrestrict).
std::string numbered(const std::string& prefix, int i, const std::string& ext) {
  std::string s = prefix;
  s += std::to_string(i);
  s += ext;
  return s;
}

// Writes one grey image with OpenImageIO (not through Sawyer's writer).
template <typename T>
void write_image(const fs::path& file, int w, int h, int channels, OIIO::TypeDesc type,
                 const std::vector<T>& pixels,
                 const std::vector<std::pair<std::string, std::string>>& attrs = {},
                 const std::vector<std::pair<std::string, float>>& float_attrs = {}) {
  OIIO::ImageSpec spec(w, h, channels, type);
  for (const auto& [k, v] : attrs) spec.attribute(k, v);
  for (const auto& [k, v] : float_attrs) spec.attribute(k, v);
  auto out = OIIO::ImageOutput::create(file.string());
  ASSERT_TRUE(out);
  ASSERT_TRUE(out->open(file.string(), spec)) << out->geterror();
  ASSERT_TRUE(out->write_image(type, pixels.data())) << out->geterror();
  ASSERT_TRUE(out->close());
}

std::vector<uint16_t> constant_u16(int w, int h, uint16_t v) {
  return std::vector<uint16_t>(static_cast<size_t>(w) * h, v);
}

bool has_note(const SliceSource& src, const std::string& text) {
  for (const std::string& n : src.notes())
    if (n.find(text) != std::string::npos) return true;
  return false;
}

// ---------------------------------------------------------------------------------------------

TEST(CtStack, TiffStackRoundTrip) {
  test::TempDir dir;
  const VolumeGeometry g = test_geometry(41, 29, 7);
  WriteOptions o;
  o.format = Format::kTiffStack;
  write_volume(dir / "scan", g, o);
  EXPECT_TRUE(fs::exists(dir / "scan" / "slice_0001.tif"));
  EXPECT_TRUE(fs::exists(dir / "scan" / "slice_0007.tif"));
  EXPECT_TRUE(fs::exists(dir / "scan" / "sawyer_stack.json"));
  auto src = open_ok(dir / "scan");
  ASSERT_TRUE(src);
  EXPECT_EQ(src->format(), Format::kTiffStack);
  expect_geometry(src->geometry(), g);
  EXPECT_EQ(src->geometry().bits_stored, 16);
  EXPECT_DOUBLE_EQ(src->geometry().rescale_intercept, -1024.0);
  expect_pattern(*src, 0.5);
  // Nothing but the folder itself appears beside it (no temporary leftovers).
  int entries = 0;
  for (const auto& e : fs::directory_iterator(dir.path())) entries += e.path() != dir / "scan";
  EXPECT_EQ(entries, 0);
}

TEST(CtStack, PngStackRoundTripWithRescale) {
  test::TempDir dir;
  const VolumeGeometry g = test_geometry(33, 20, 5);
  WriteOptions o;
  o.format = Format::kPngStack;
  o.rescale_slope = 0.5;
  o.rescale_intercept = -1100;
  write_volume(dir / "png", g, o);
  EXPECT_TRUE(fs::exists(dir / "png" / "slice_0001.png"));
  auto src = open_ok(dir / "png");
  ASSERT_TRUE(src);
  EXPECT_EQ(src->format(), Format::kPngStack);
  expect_geometry(src->geometry(), g);
  EXPECT_DOUBLE_EQ(src->geometry().rescale_slope, 0.5);
  expect_pattern(*src, 0.25 + 1e-4);
}

TEST(CtStack, MultiPageTiffRoundTrip) {
  test::TempDir dir;
  const VolumeGeometry g = test_geometry(24, 18, 6);
  WriteOptions o;
  o.format = Format::kMultiPageTiff;
  write_volume(dir / "mp", g, o);
  ASSERT_TRUE(fs::exists(dir / "mp" / "stack.tif"));
  for (const fs::path& p : {dir / "mp" / "stack.tif", dir / "mp"}) {
    auto src = open_ok(p);
    ASSERT_TRUE(src);
    EXPECT_EQ(src->format(), Format::kMultiPageTiff);
    expect_geometry(src->geometry(), g);
    expect_pattern(*src, 0.5);
  }
}

TEST(CtStack, MultiPageTiffTakesItsOwnJsonBesideIt) {
  test::TempDir dir;
  const VolumeGeometry g = test_geometry(24, 18, 4);
  WriteOptions o;
  o.format = Format::kMultiPageTiff;
  write_volume(dir / "mp", g, o);
  fs::rename(dir / "mp" / "stack.tif", dir / "log7.tif");
  test::write_file(dir / "log7.json",
                   R"({"format": "sawyer-stack/1", "pixel_spacing_mm": 0.3, "slice_spacing_mm": 4,
                       "rescale_slope": 1, "rescale_intercept": -1024})");
  auto src = open_ok(dir / "log7.tif");
  ASSERT_TRUE(src);
  EXPECT_DOUBLE_EQ(src->geometry().spacing_x, 0.3);
  EXPECT_DOUBLE_EQ(src->geometry().slice_spacing(), 4.0);
  expect_pattern(*src, 0.5);
}

TEST(CtStack, EightBitStackWithRescale) {
  test::TempDir dir;
  const VolumeGeometry g = test_geometry(20, 16, 4);
  WriteOptions o;
  o.format = Format::kTiffStack;
  o.bits_stored = 8;
  o.rescale_slope = 12;
  o.rescale_intercept = -1000;
  write_volume(dir / "s8", g, o);
  auto src = open_ok(dir / "s8");
  ASSERT_TRUE(src);
  EXPECT_EQ(src->geometry().bits_stored, 8);
  // The pattern spans -1000..2000 HU; 8 bits at 12 HU per step reach 2060.
  expect_pattern(*src, 6.0 + 1e-3);
}

TEST(CtStack, EightBitStackWithRescaleOnTheCommandLine) {
  test::TempDir dir;
  for (int i = 1; i <= 3; ++i) {
    std::vector<uint8_t> px(10 * 12, static_cast<uint8_t>(10 * i));
    write_image(dir / numbered("s", i, ".png"), 10, 12, 1, OIIO::TypeDesc::UINT8, px);
  }
  OpenOptions o;
  o.pixel_spacing = 0.5;
  o.slice_spacing = 1.0;
  o.rescale_slope = 4;
  o.rescale_intercept = -1000;
  auto src = open_ok(dir.path(), o);
  ASSERT_TRUE(src);
  Slice s;
  ASSERT_TRUE(src->read(2, s).ok());
  EXPECT_FLOAT_EQ(s.at(3, 4), 30 * 4 - 1000);
}

TEST(CtStack, NaturalSortOfNames) {
  test::TempDir dir;
  // Created out of order; slice_N holds the value N everywhere.
  for (int i : {10, 2, 1, 11, 3, 9, 4, 5, 8, 6, 7}) {
    write_image(dir / numbered("slice_", i, ".tif"), 8, 6, 1, OIIO::TypeDesc::INT16,
                std::vector<int16_t>(48, static_cast<int16_t>(i)));
  }
  test::write_file(dir / "sawyer_stack.json", R"({"pixel_spacing_mm": 1, "slice_spacing_mm": 1})");
  auto src = open_ok(dir.path());
  ASSERT_TRUE(src);
  ASSERT_EQ(src->geometry().slice_count(), 11);
  Slice s;
  for (int i = 0; i < 11; ++i) {
    ASSERT_TRUE(src->read(i, s).ok());
    EXPECT_EQ(s.at(0, 0), i + 1) << "slice " << i;
  }
}

TEST(CtStack, SidecarFileListSetsTheOrder) {
  test::TempDir dir;
  for (int i = 1; i <= 4; ++i) {
    write_image(dir / numbered("img", i, ".tif"), 8, 6, 1, OIIO::TypeDesc::INT16,
                std::vector<int16_t>(48, static_cast<int16_t>(100 * i)));
  }
  test::write_file(dir / "sawyer_stack.json",
                   R"({"format": "sawyer-stack/1", "pixel_spacing_mm": [0.5, 0.7],
                       "slice_spacing_mm": 2, "files": ["img4.tif", "img2.tif", "img1.tif"]})");
  // A stray preview image does not matter when the sidecar names the slices.
  std::vector<uint8_t> preview(8 * 6 * 3, 128);
  write_image(dir / "preview.png", 8, 6, 3, OIIO::TypeDesc::UINT8, preview);
  auto src = open_ok(dir.path());
  ASSERT_TRUE(src);
  ASSERT_EQ(src->geometry().slice_count(), 3);
  EXPECT_DOUBLE_EQ(src->geometry().spacing_x, 0.5);
  EXPECT_DOUBLE_EQ(src->geometry().spacing_y, 0.7);
  EXPECT_TRUE(has_note(*src, "2 image files in"));  // img3.tif and preview.png
  Slice s;
  const float want[] = {400, 200, 100};
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(src->read(i, s).ok());
    EXPECT_EQ(s.at(1, 1), want[i]);
  }
}

TEST(CtStack, SidecarZPositionsWithAMissingSlice) {
  test::TempDir dir;
  for (int i = 1; i <= 5; ++i) {
    write_image(dir / numbered("s", i, ".tif"), 8, 6, 1, OIIO::TypeDesc::INT16,
                std::vector<int16_t>(48, static_cast<int16_t>(10 * i)));
  }
  // Positions 100, 102, 104, (106 missing), 108, 110: the raw reader reports them from 0.
  test::write_file(dir / "sawyer_stack.json",
                   R"({"pixel_spacing_mm": 1, "z_mm": [100, 102, 104, 108, 110]})");
  auto raw = detail::open_image_stack(dir.path(), {});
  ASSERT_TRUE(raw.ok()) << raw.error().message();
  EXPECT_EQ(raw.value()->geometry().z, (std::vector<double>{0, 2, 4, 8, 10}));
  // open_ct puts them on an even grid (one more slice), or refuses when told to.
  auto even = open_ok(dir.path());
  ASSERT_TRUE(even);
  EXPECT_EQ(even->geometry().slice_count(), 6);
  OpenOptions strict;
  strict.z_policy = ZPolicy::kReject;
  EXPECT_FALSE(open_ct(dir.path(), strict).ok());
}

TEST(CtStack, CommandLineOverridesTheSidecar) {
  test::TempDir dir;
  const VolumeGeometry g = test_geometry(16, 12, 4);
  WriteOptions w;
  w.format = Format::kTiffStack;
  write_volume(dir / "s", g, w);
  OpenOptions o;
  o.pixel_spacing = 0.9;
  o.slice_spacing = 3.0;
  o.rescale_slope = 2.0;  // the sidecar's intercept (-1024) still applies
  auto src = open_ok(dir / "s", o);
  ASSERT_TRUE(src);
  EXPECT_DOUBLE_EQ(src->geometry().spacing_x, 0.9);
  EXPECT_DOUBLE_EQ(src->geometry().spacing_y, 0.9);
  EXPECT_DOUBLE_EQ(src->geometry().slice_spacing(), 3.0);
  EXPECT_DOUBLE_EQ(src->geometry().rescale_slope, 2.0);
  EXPECT_DOUBLE_EQ(src->geometry().rescale_intercept, -1024.0);
  EXPECT_TRUE(has_note(*src, "--pixel-spacing 0.9 mm overrides"));
  Slice s;
  ASSERT_TRUE(src->read(1, s).ok());
  const double stored = std::round(pattern_hu(5, 3, 1) + 1024);
  EXPECT_FLOAT_EQ(s.at(5, 3), static_cast<float>(stored * 2 - 1024));
}

TEST(CtStack, SidecarRescaleOverridesTheTypeRule) {
  test::TempDir dir;
  for (int i = 0; i < 2; ++i)
    write_image(dir / numbered("a", i, ".tif"), 8, 6, 1, OIIO::TypeDesc::INT16,
                std::vector<int16_t>(48, 300));
  test::write_file(dir / "sawyer_stack.json",
                   R"({"pixel_spacing_mm": 1, "slice_spacing_mm": 1, "rescale_slope": 0.5,
                       "rescale_intercept": -100, "origin_mm": [1, 2, 3],
                       "orientation": [1, 0, 0, 0, 0, -1], "comment": "scanner 2"})");
  auto src = open_ok(dir.path());
  ASSERT_TRUE(src);
  Slice s;
  ASSERT_TRUE(src->read(0, s).ok());
  EXPECT_FLOAT_EQ(s.at(0, 0), 300 * 0.5f - 100);
  EXPECT_EQ(src->geometry().origin, (Vec3{1, 2, 3}));
  EXPECT_EQ(src->geometry().orientation, (std::array<double, 6>{1, 0, 0, 0, 0, -1}));
  EXPECT_TRUE(has_note(*src, "unknown key \"comment\""));
}

TEST(CtStack, ImageJStackWrittenByOpenImageIO) {
  test::TempDir dir;
  // ImageJ's way: pixel size as pixels per unit with ResolutionUnit none, the unit and the
  // slice spacing in the description. Signed 16-bit data are HU. (OpenImageIO writes
  // YResolution as XResolution x PixelAspectRatio.)
  const std::string desc = "ImageJ=1.53t\nimages=4\nslices=4\nunit=mm\nspacing=1.5\nloop=false\n";
  for (int i = 0; i < 4; ++i) {
    std::vector<int16_t> px(30 * 20);
    for (size_t p = 0; p < px.size(); ++p) px[p] = static_cast<int16_t>(-1000 + p + 100 * i);
    write_image(dir / numbered("ij_", i, ".tif"), 30, 20, 1, OIIO::TypeDesc::INT16, px,
                {{"ImageDescription", desc}, {"ResolutionUnit", "none"}},
                {{"XResolution", 2.0f}, {"YResolution", 2.5f}, {"PixelAspectRatio", 1.25f}});
  }
  auto src = open_ok(dir.path());
  ASSERT_TRUE(src);
  EXPECT_NEAR(src->geometry().spacing_x, 0.5, 1e-7);
  EXPECT_NEAR(src->geometry().spacing_y, 0.4, 1e-7);
  EXPECT_DOUBLE_EQ(src->geometry().slice_spacing(), 1.5);
  EXPECT_TRUE(has_note(*src, "ImageJ"));
  Slice s;
  ASSERT_TRUE(src->read(3, s).ok());
  EXPECT_EQ(s.at(7, 2), -1000 + 2 * 30 + 7 + 300);
}

TEST(CtStack, ImageJCalibrationGivesTheRescale) {
  test::TempDir dir;
  // ImageJ keeps signed 16-bit data unsigned with the calibration c0 = -32768, c1 = 1.
  const std::string desc = "ImageJ=1.53t\nunit=mm\nspacing=2\ncf=0\nc0=-32768.0\nc1=1.0\n";
  for (int i = 0; i < 3; ++i) {
    write_image(dir / numbered("c", i, ".tif"), 12, 10, 1, OIIO::TypeDesc::UINT16,
                constant_u16(12, 10, static_cast<uint16_t>(32768 - 500 + i)),
                {{"ImageDescription", desc}, {"ResolutionUnit", "cm"}},
                {{"XResolution", 20.0f}, {"YResolution", 20.0f}});
  }
  auto src = open_ok(dir.path());
  ASSERT_TRUE(src);
  EXPECT_NEAR(src->geometry().spacing_x, 0.5, 1e-7);  // 20 per cm
  Slice s;
  ASSERT_TRUE(src->read(2, s).ok());
  EXPECT_FLOAT_EQ(s.at(0, 0), -498.0f);
  EXPECT_TRUE(has_note(*src, "ImageJ calibration"));
}

TEST(CtStack, OurTiffResolutionTagsGiveThePixelSpacing) {
  test::TempDir dir;
  const VolumeGeometry g = test_geometry(16, 12, 3);
  WriteOptions w;
  w.format = Format::kTiffStack;
  write_volume(dir / "s", g, w);
  fs::remove(dir / "s" / "sawyer_stack.json");
  OpenOptions o;
  o.slice_spacing = 2.5;
  auto src = open_ok(dir / "s", o);
  ASSERT_TRUE(src);
  EXPECT_NEAR(src->geometry().spacing_x, g.spacing_x, 1e-6);
  EXPECT_NEAR(src->geometry().spacing_y, g.spacing_y, 1e-6);
  EXPECT_TRUE(has_note(*src, "resolution tags"));
  // Without the sidecar, unsigned 16-bit data is taken as HU + 1024, as the writer stored it.
  EXPECT_TRUE(has_note(*src, "HU = value - 1024"));
  expect_pattern(*src, 0.5);
}

TEST(CtStack, FloatTiffIsHu) {
  test::TempDir dir;
  for (int i = 0; i < 3; ++i) {
    std::vector<float> px(9 * 7);
    for (size_t p = 0; p < px.size(); ++p) px[p] = -999.75f + p + i;
    write_image(dir / numbered("f", i, ".tif"), 9, 7, 1, OIIO::TypeDesc::FLOAT, px);
  }
  OpenOptions o;
  o.pixel_spacing = 1;
  o.slice_spacing = 1;
  auto src = open_ok(dir.path(), o);
  ASSERT_TRUE(src);
  EXPECT_EQ(src->geometry().bits_stored, 32);
  Slice s;
  ASSERT_TRUE(src->read(2, s).ok());
  EXPECT_FLOAT_EQ(s.at(4, 3), -999.75f + 3 * 9 + 4 + 2);
}

TEST(CtStack, GreyStoredAsRgbIsAccepted) {
  test::TempDir dir;
  for (int i = 0; i < 2; ++i) {
    std::vector<uint16_t> px(6 * 5 * 3);
    for (size_t p = 0; p < px.size(); ++p) px[p] = static_cast<uint16_t>(2000 + p / 3);
    write_image(dir / numbered("g", i, ".png"), 6, 5, 3, OIIO::TypeDesc::UINT16, px);
  }
  OpenOptions o;
  o.pixel_spacing = 1;
  o.slice_spacing = 1;
  auto src = open_ok(dir.path(), o);
  ASSERT_TRUE(src);
  Slice s;
  ASSERT_TRUE(src->read(1, s).ok());
  EXPECT_FLOAT_EQ(s.at(2, 1), 2000 + 8 - 1024);
}

TEST(CtStack, ReadingReusesTheSliceBuffer) {
  test::TempDir dir;
  const VolumeGeometry g = test_geometry(32, 32, 5);
  WriteOptions w;
  w.format = Format::kPngStack;
  write_volume(dir / "s", g, w);
  auto src = open_ok(dir / "s");
  ASSERT_TRUE(src);
  Slice s;
  ASSERT_TRUE(src->read(0, s).ok());
  const float* buffer = s.hu.data();
  for (int i : {1, 4, 2, 3}) {  // any order is allowed
    ASSERT_TRUE(src->read(i, s).ok());
    EXPECT_EQ(s.hu.data(), buffer);
    EXPECT_NEAR(s.at(3, 3), pattern_hu(3, 3, i), 0.5);
  }
}

TEST(CtStack, WriterIsAllOrNothing) {
  test::TempDir dir;
  const VolumeGeometry g = test_geometry(8, 8, 3);
  WriteOptions o;
  o.format = Format::kTiffStack;
  {
    auto sink = create_ct_writer(dir / "out", g, o);
    ASSERT_TRUE(sink.ok());
    ASSERT_TRUE(sink.value()->write(pattern_slice(g, 0)).ok());
    // Destroyed without finish(): nothing is left behind.
  }
  EXPECT_TRUE(fs::is_empty(dir.path()));

  // finish() before every slice arrived is an error and leaves nothing either.
  {
    auto sink = create_ct_writer(dir / "out", g, o);
    ASSERT_TRUE(sink.ok());
    ASSERT_TRUE(sink.value()->write(pattern_slice(g, 0)).ok());
    Status st = sink.value()->finish();
    ASSERT_FALSE(st.ok());
    EXPECT_THAT(st.error().message(), HasSubstr("1 of 3 slices"));
  }
  EXPECT_TRUE(fs::is_empty(dir.path()));

  // An existing folder is replaced whole; before_commit sees the finished slices.
  test::write_file(dir / "out" / "old.txt", "previous run");
  bool saw_slices = false;
  o.before_commit = [&](const fs::path& tmp) -> Status {
    saw_slices = fs::exists(tmp / "slice_0003.tif") && fs::exists(tmp / "sawyer_stack.json");
    test::write_file(tmp / "truth" / "log.json", "{}");
    return Status::Ok();
  };
  write_volume(dir / "out", g, o);
  EXPECT_TRUE(saw_slices);
  EXPECT_FALSE(fs::exists(dir / "out" / "old.txt"));
  EXPECT_TRUE(fs::exists(dir / "out" / "truth" / "log.json"));
  int entries = 0;
  for (const auto& e : fs::directory_iterator(dir.path())) entries += e.path() != dir / "out";
  EXPECT_EQ(entries, 0);

  // A failing before_commit keeps the previous output.
  o.before_commit = [](const fs::path&) -> Status { return Error("truth", "failed"); };
  auto sink = create_ct_writer(dir / "out", g, o);
  ASSERT_TRUE(sink.ok());
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(sink.value()->write(pattern_slice(g, i)).ok());
  EXPECT_FALSE(sink.value()->finish().ok());
  EXPECT_TRUE(fs::exists(dir / "out" / "truth" / "log.json"));
}

TEST(CtStack, StackWriterRecordsUnevenZ) {
  test::TempDir dir;
  VolumeGeometry g = test_geometry(8, 8, 4);
  g.z = {0, 1.5, 3.0, 7.5};
  WriteOptions o;
  o.format = Format::kPngStack;
  write_volume(dir / "s", g, o);
  auto raw = detail::open_image_stack(dir / "s", {});
  ASSERT_TRUE(raw.ok()) << raw.error().message();
  EXPECT_EQ(raw.value()->geometry().z, g.z);
}

TEST(CtStack, SidecarParsesBothSpacingForms) {
  auto one = detail::parse_stack_sidecar(R"({"pixel_spacing_mm": 0.5})", "s.json");
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(one.value().pixel_spacing_x, 0.5);
  EXPECT_EQ(one.value().pixel_spacing_y, 0.5);
  auto two = detail::parse_stack_sidecar(R"({"pixel_spacing_mm": [0.5, 0.8]})", "s.json");
  ASSERT_TRUE(two.ok());
  EXPECT_EQ(two.value().pixel_spacing_y, 0.8);
  auto bad = detail::parse_stack_sidecar(R"({"pixel_spacing_mm": [0.5, 0.8, 1]})", "s.json");
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.error().message(), HasSubstr("s.json: \"pixel_spacing_mm\""));
}

TEST(CtStack, NaturalOrderComparesNumbersByValue) {
  // Through the reader: names that only a numeric comparison orders right.
  test::TempDir dir;
  const std::vector<std::string> names = {"a_0009.tif", "a_10.tif", "a_011.tif", "a_100.tif"};
  for (size_t i = 0; i < names.size(); ++i)
    write_image(dir / names[i], 4, 4, 1, OIIO::TypeDesc::INT16,
                std::vector<int16_t>(16, static_cast<int16_t>(i)));
  OpenOptions o;
  o.pixel_spacing = o.slice_spacing = 1.0;
  auto src = open_ok(dir.path(), o);
  ASSERT_TRUE(src);
  Slice s;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(src->read(i, s).ok());
    EXPECT_EQ(s.at(0, 0), i);
  }
  EXPECT_THAT(src->description(), HasSubstr("a_0009.tif ... a_100.tif"));
}

}  // namespace
}  // namespace sawyer::ct

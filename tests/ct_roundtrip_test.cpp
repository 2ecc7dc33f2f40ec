// Issue 3's acceptance on a short section: a phantom of the sample spruce at 512 x 512, 0.8 mm
// pixels, 5 mm slice spacing, written in every format, reads back through open_ct with the
// geometry it was written with and the HU it was rendered with (within the stored quantisation).
// Also the command line end to end: `sawyer phantom` then `sawyer info` on the result.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "sawyer/ct/io/slice_sink.h"
#include "sawyer/ct/io/slice_source.h"
#include "sawyer/ct/phantom/phantom.h"
#include "sawyer/model/log_json.h"
#include "sawyer/test/test_util.h"

namespace sawyer::ct {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

struct Section {
  std::unique_ptr<Phantom> phantom;
  std::vector<Slice> slices;  // rendered, HU as float
};

// Six slices, 25 mm of the log around a whorl region, rendered once for all formats.
const Section& section() {
  static const Section s = [] {
    Section r;
    auto log = read_log_json(test::sample_log("gran1_spruce") / "log.json");
    EXPECT_TRUE(log.ok());
    PhantomOptions o;
    o.image_size = 512;
    o.pixel_mm = 0.8;
    o.slice_spacing_mm = 5.0;
    o.from_mm = 1500.0;
    o.to_mm = 1525.0;
    o.seed = 42;
    auto ph = Phantom::create(log.value(), o);
    EXPECT_TRUE(ph.ok()) << (ph.ok() ? "" : ph.error().message());
    r.phantom = std::move(ph).value();
    for (int i = 0; i < r.phantom->nominal_count(); ++i)
      r.slices.push_back(r.phantom->render_slice(i));
    return r;
  }();
  return s;
}

struct Case {
  Format format;
  const char* name;
  double intercept;  // stored = HU - intercept
};

class RoundTrip : public ::testing::TestWithParam<Case> {};

TEST_P(RoundTrip, GeometryAndValuesSurvive) {
  const Section& sec = section();
  const VolumeGeometry& want = sec.phantom->geometry();
  ASSERT_EQ(want.slice_count(), 6);
  test::TempDir dir;
  const fs::path out = dir / "scan";
  WriteOptions w;
  w.format = GetParam().format;
  w.rescale_intercept = GetParam().intercept;
  {
    auto sink = create_ct_writer(out, want, w);
    ASSERT_TRUE(sink.ok()) << sink.error().message();
    for (const Slice& s : sec.slices) ASSERT_TRUE(sink.value()->write(s).ok());
    ASSERT_TRUE(sink.value()->finish().ok());
  }
  auto src = open_ct(out);
  ASSERT_TRUE(src.ok()) << src.error().message();
  EXPECT_EQ(src.value()->format(), GetParam().format);
  const VolumeGeometry& got = src.value()->geometry();
  EXPECT_EQ(got.width, 512);
  EXPECT_EQ(got.height, 512);
  EXPECT_NEAR(got.spacing_x, 0.8, 1e-6);
  EXPECT_NEAR(got.spacing_y, 0.8, 1e-6);
  ASSERT_EQ(got.slice_count(), want.slice_count());
  for (int i = 0; i < got.slice_count(); ++i) EXPECT_NEAR(got.z[i], want.z[i], 1e-4) << i;
  EXPECT_NEAR(got.slice_spacing(), 5.0, 1e-4);
  EXPECT_TRUE(src.value()->notes().empty() ||
              src.value()->notes().front().find("resampled") == std::string::npos);

  // Values: exact up to rounding to the stored integer, except where the stored type clips
  // (air noise below the intercept of an unsigned stack).
  // DICOM stores signed 16-bit: nothing clips. The other writers store unsigned from the
  // intercept up.
  const float floor_hu =
      GetParam().format == Format::kDicom ? -1e30f : static_cast<float>(GetParam().intercept);
  Slice s;
  double worst = 0;
  long clipped = 0;
  for (int i = 0; i < got.slice_count(); ++i) {
    ASSERT_TRUE(src.value()->read(i, s).ok());
    ASSERT_EQ(s.hu.size(), sec.slices[i].hu.size());
    for (size_t p = 0; p < s.hu.size(); ++p) {
      const float v = sec.slices[i].hu[p];
      if (v < floor_hu + 0.5f) {
        ++clipped;
        EXPECT_LE(s.hu[p], floor_hu + 0.5f);
        // Only noisy air reaches below the stored range.
        EXPECT_LT(v, -950.0f) << "slice " << i << " pixel " << p;
        continue;
      }
      worst = std::max(worst, static_cast<double>(std::abs(s.hu[p] - v)));
    }
  }
  EXPECT_LE(worst, 0.5 + 1e-3) << GetParam().name;
  if (GetParam().format == Format::kDicom) {
    EXPECT_EQ(clipped, 0);
  }
}

INSTANTIATE_TEST_SUITE_P(EveryFormat, RoundTrip,
                         ::testing::Values(Case{Format::kDicom, "dicom", -1024.0},
                                           Case{Format::kDicom, "dicom0", 0.0},
                                           Case{Format::kTiffStack, "tiff", -1024.0},
                                           Case{Format::kMultiPageTiff, "multitiff", -1024.0},
                                           Case{Format::kPngStack, "png", -1024.0},
                                           Case{Format::kVti, "vti", -1024.0},
                                           Case{Format::kMetaImage, "mha", -1024.0},
                                           Case{Format::kNrrd, "nrrd", -1024.0}),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

TEST(PhantomCli, WritesASeriesThatInfoDescribes) {
  test::TempDir dir;
  const fs::path out = dir / "phantom";
  std::string text;
  const std::string log = (test::sample_log("gran1_spruce") / "log.json").string();
  ASSERT_EQ(test::run_sawyer("phantom \"" + log + "\" -o \"" + out.string() +
                                 "\" --from-mm 800 --to-mm 830 --size 384 --pixel-mm 1.0 "
                                 "--seed 3",
                             &text),
            0)
      << text;
  EXPECT_TRUE(fs::exists(out / "truth" / "log.json"));
  EXPECT_TRUE(fs::exists(out / "truth" / "phantom.json"));
  ASSERT_EQ(test::run_sawyer("info \"" + out.string() + "\"", &text), 0) << text;
  EXPECT_THAT(text, HasSubstr("DICOM series"));
  EXPECT_THAT(text, HasSubstr("7 of 384 x 384 pixels"));
  EXPECT_THAT(text, HasSubstr("1.000 x 1.000 mm"));
  EXPECT_THAT(text, HasSubstr("slice spacing  5.000 mm"));
  EXPECT_THAT(text, HasSubstr("0.0 .. 30.0 mm"));
  EXPECT_THAT(text, HasSubstr("problems       none"));
}

TEST(PhantomCli, InfoNamesMissingSlices) {
  test::TempDir dir;
  const fs::path out = dir / "phantom";
  std::string text;
  const std::string log = (test::sample_log("gran1_spruce") / "log.json").string();
  ASSERT_EQ(test::run_sawyer("phantom \"" + log + "\" -o \"" + out.string() +
                                 "\" --from-mm 800 --to-mm 900 --size 320 --pixel-mm 1.2 "
                                 "--drop-slices 2 --seed 5",
                             &text),
            0)
      << text;
  ASSERT_EQ(test::run_sawyer("info \"" + out.string() + "\"", &text), 0) << text;
  EXPECT_THAT(text, HasSubstr("21 of 320 x 320 pixels"));  // resampled back onto 5 mm steps
  EXPECT_THAT(text, HasSubstr("resampled"));
  // --strict-z refuses instead, naming where the gap is.
  EXPECT_NE(test::run_sawyer("info \"" + out.string() + "\" --strict-z", &text), 0);
  EXPECT_THAT(text, HasSubstr("z="));
}

TEST(PhantomCli, BadLogIsRefusedWithoutOutput) {
  test::TempDir dir;
  test::write_file(dir / "log.json", "{\"format\": \"sawyer-log/1\", \"stem\": 3}");
  std::string text;
  EXPECT_NE(test::run_sawyer("phantom \"" + (dir / "log.json").string() + "\" -o \"" +
                                 (dir / "out").string() + "\"",
                             &text),
            0);
  EXPECT_THAT(text, HasSubstr("log.json"));
  EXPECT_FALSE(fs::exists(dir / "out"));
}

}  // namespace
}  // namespace sawyer::ct

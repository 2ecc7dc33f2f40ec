// TIFF and PNG stacks: write -> read round trips for every stack format (values within the
// rescale's quantisation, geometry exact), file order, the sidecar and the command-line options
// that override it, and stacks written by OpenImageIO directly (ImageJ-style tags, 8-bit,
// float, grey stored as RGB), read through open_ct().
#include <OpenImageIO/imageio.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <libdeflate.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <vector>

#include "../ct_pipeline/io/src/readers.h"
#include "../ct_pipeline/io/src/sidecar.h"
#include "sawyer/ct/io/slice_sink.h"
#include "sawyer/ct/io/slice_source.h"
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
// The grey PNG fast path (png_fast.cpp) against OpenImageIO

// Samples as OpenImageIO decodes them (the reference for the fast path), in the file's own type.
std::vector<float> oiio_samples(const fs::path& file) {
  auto in = OIIO::ImageInput::open(file.string());
  EXPECT_TRUE(in) << OIIO::geterror();
  if (!in) return {};
  const OIIO::ImageSpec spec = in->spec();
  const size_t n = static_cast<size_t>(spec.width) * spec.height;
  std::vector<float> px(n);
  if (spec.format == OIIO::TypeDesc::UINT8) {
    std::vector<uint8_t> raw(n);
    EXPECT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::UINT8, raw.data())) << in->geterror();
    std::copy(raw.begin(), raw.end(), px.begin());
  } else {
    std::vector<uint16_t> raw(n);
    EXPECT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::UINT16, raw.data())) << in->geterror();
    std::copy(raw.begin(), raw.end(), px.begin());
  }
  in->close();
  return px;
}

std::string file_bytes(const fs::path& file) {
  std::ifstream f(file, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// Stored values as the stack reader returns them (slope 1, intercept 0).
OpenOptions raw_values() {
  OpenOptions o;
  o.pixel_spacing = 0.5;
  o.slice_spacing = 1.0;
  o.rescale_slope = 1.0;
  o.rescale_intercept = 0.0;
  return o;
}

void expect_stack_matches_oiio(const fs::path& dir, const std::vector<fs::path>& files) {
  auto src = open_ok(dir, raw_values());
  ASSERT_TRUE(src);
  ASSERT_EQ(src->geometry().slice_count(), static_cast<int>(files.size()));
  Slice s;
  for (size_t i = 0; i < files.size(); ++i) {
    Status st = src->read(static_cast<int>(i), s);
    ASSERT_TRUE(st.ok()) << st.error().message();
    const std::vector<float> want = oiio_samples(files[i]);
    ASSERT_EQ(s.hu.size(), want.size());
    size_t bad = 0;
    for (size_t k = 0; k < want.size(); ++k) bad += s.hu[k] != want[k];
    EXPECT_EQ(bad, 0u) << files[i] << ": " << bad << " samples differ from OpenImageIO";
  }
}

// The filter type byte of every row of a PNG (which libpng chose), found by inflating its IDATs.
std::set<int> filter_types(const fs::path& file, int w, int h, int bytes_per_sample) {
  const std::string b = file_bytes(file);
  std::string z;
  for (size_t pos = 8; pos + 12 <= b.size();) {
    const auto* p = reinterpret_cast<const unsigned char*>(b.data() + pos);
    const size_t len = (size_t{p[0]} << 24) | (size_t{p[1]} << 16) | (size_t{p[2]} << 8) | p[3];
    if (b.compare(pos + 4, 4, "IDAT") == 0) z += b.substr(pos + 8, len);
    pos += 12 + len;
  }
  const size_t stride = 1 + static_cast<size_t>(w) * bytes_per_sample;
  std::vector<unsigned char> rows(stride * h);
  libdeflate_decompressor* d = libdeflate_alloc_decompressor();
  const libdeflate_result r =
      libdeflate_zlib_decompress(d, z.data(), z.size(), rows.data(), rows.size(), nullptr);
  libdeflate_free_decompressor(d);
  EXPECT_EQ(r, LIBDEFLATE_SUCCESS) << file;
  std::set<int> types;
  for (int y = 0; y < h; ++y) types.insert(rows[y * stride]);
  return types;
}

// Images that lead libpng's adaptive filter choice to different filters: noise, gradients
// along x, y and both, flat areas, and rows alternating between them.
std::vector<uint16_t> filter_exercise(int w, int h, int kind, uint16_t max) {
  std::vector<uint16_t> px(static_cast<size_t>(w) * h);
  uint32_t seed = 12345u + kind;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      seed = seed * 1664525u + 1013904223u;
      const uint32_t noise = seed >> 8;
      uint32_t v = 0;
      switch ((kind + y / 7) % 5) {
        case 0:
          v = noise;
          break;
        case 1:
          v = x * 37u;
          break;
        case 2:
          v = y * 53u + (noise & 3);
          break;
        case 3:
          v = (x + y) * 29u + (noise & 1);
          break;
        case 4:
          v = 1000u + ((x / 5) % 2) * 7u;
          break;
      }
      px[static_cast<size_t>(y) * w + x] = static_cast<uint16_t>(v % (max + 1u));
    }
  }
  return px;
}

TEST(CtStack, PngFastPathMatchesOpenImageIOFor16Bit) {
  test::TempDir dir;
  const int w = 97, h = 70;
  std::vector<fs::path> files;
  std::set<int> used;
  for (int kind = 0; kind < 5; ++kind) {
    files.push_back(dir / numbered("s", kind + 1, ".png"));
    write_image(files.back(), w, h, 1, OIIO::TypeDesc::UINT16, filter_exercise(w, h, kind, 65535));
    const std::set<int> t = filter_types(files.back(), w, h, 2);
    used.insert(t.begin(), t.end());
  }
  EXPECT_GE(used.size(), 3u) << "libpng chose too few filter types to be a test";
  expect_stack_matches_oiio(dir.path(), files);
}

TEST(CtStack, PngFastPathMatchesOpenImageIOFor8Bit) {
  test::TempDir dir;
  const int w = 61, h = 75;
  std::vector<fs::path> files;
  std::set<int> used;
  for (int kind = 0; kind < 5; ++kind) {
    const std::vector<uint16_t> v = filter_exercise(w, h, kind, 255);
    files.push_back(dir / numbered("s", kind + 1, ".png"));
    write_image(files.back(), w, h, 1, OIIO::TypeDesc::UINT8,
                std::vector<uint8_t>(v.begin(), v.end()));
    const std::set<int> t = filter_types(files.back(), w, h, 1);
    used.insert(t.begin(), t.end());
  }
  EXPECT_GE(used.size(), 3u) << "libpng chose too few filter types to be a test";
  expect_stack_matches_oiio(dir.path(), files);
}

// A hand-built grey PNG: `rows` are the filtered rows (filter byte first), compressed into a
// zlib stream that is split over two IDAT chunks; zlib_cut/zlib_flip damage that stream.
std::string build_png(int w, int h, int bits, const std::vector<unsigned char>& rows,
                      size_t zlib_cut = 0, long zlib_flip = -1) {
  libdeflate_compressor* c = libdeflate_alloc_compressor(6);
  std::string z(libdeflate_zlib_compress_bound(c, rows.size()), '\0');
  z.resize(libdeflate_zlib_compress(c, rows.data(), rows.size(), z.data(), z.size()));
  libdeflate_free_compressor(c);
  if (zlib_cut) z.resize(z.size() - zlib_cut);
  if (zlib_flip >= 0) z[zlib_flip] = static_cast<char>(z[zlib_flip] ^ 0x5a);
  auto be32 = [](uint32_t v) {
    return std::string{static_cast<char>(v >> 24), static_cast<char>(v >> 16),
                       static_cast<char>(v >> 8), static_cast<char>(v)};
  };
  auto chunk = [&](const char* type, const std::string& data) {
    const std::string td = type + data;
    return be32(static_cast<uint32_t>(data.size())) + td +
           be32(libdeflate_crc32(0, td.data(), td.size()));
  };
  std::string ihdr = be32(w) + be32(h);
  ihdr += {static_cast<char>(bits), 0, 0, 0, 0};
  const size_t half = z.size() / 2;
  return std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) +
         chunk("IDAT", z.substr(0, half)) + chunk("IDAT", z.substr(half)) + chunk("IEND", "");
}

// Filters `px` (big-endian samples, bpp bytes per pixel) row by row with the given filter
// types, the encoder's side of the PNG filters.
std::vector<unsigned char> filter_rows(const std::vector<unsigned char>& px, int w, int h, int bpp,
                                       const std::vector<int>& filters) {
  const size_t row = static_cast<size_t>(w) * bpp;
  std::vector<unsigned char> out;
  for (int y = 0; y < h; ++y) {
    const int f = filters[y];
    out.push_back(static_cast<unsigned char>(f));
    const unsigned char* cur = px.data() + y * row;
    for (size_t i = 0; i < row; ++i) {
      const int a = i >= static_cast<size_t>(bpp) ? cur[i - bpp] : 0;
      const int b = y > 0 ? cur[i - row] : 0;
      const int c = y > 0 && i >= static_cast<size_t>(bpp) ? cur[i - row - bpp] : 0;
      int pred = 0;
      if (f == 1) pred = a;
      if (f == 2) pred = b;
      if (f == 3) pred = (a + b) / 2;
      if (f == 4) {
        const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
        pred = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
      }
      out.push_back(static_cast<unsigned char>(cur[i] - pred));
    }
  }
  return out;
}

struct HandBuilt {
  std::vector<uint16_t> values;     // the samples
  std::vector<unsigned char> rows;  // filtered rows, every filter type used
};

HandBuilt hand_built(int w, int h, int bits) {
  HandBuilt hb;
  const int bpp = bits / 8;
  std::vector<unsigned char> px;
  uint32_t seed = 99;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      seed = seed * 1664525u + 1013904223u;
      // Smooth plus noise, so that every predictor has carries and wrap-arounds to get right.
      const uint32_t v = (x * 411u + y * 977u + (seed >> 20)) % (bits == 8 ? 256u : 65536u);
      hb.values.push_back(static_cast<uint16_t>(v));
      if (bpp == 2) px.push_back(static_cast<unsigned char>(v >> 8));
      px.push_back(static_cast<unsigned char>(v));
    }
  }
  std::vector<int> filters;
  for (int y = 0; y < h; ++y) filters.push_back((y * 3 + y / 5) % 5);  // each type after each
  hb.rows = filter_rows(px, w, h, bpp, filters);
  return hb;
}

TEST(CtStack, PngFastPathUndoesEveryFilterType) {
  for (int bits : {8, 16}) {
    SCOPED_TRACE(bits);
    test::TempDir dir;
    const int w = 23, h = 40;
    const HandBuilt hb = hand_built(w, h, bits);
    const std::vector<fs::path> files = {dir / "a1.png", dir / "a2.png"};
    for (const fs::path& f : files) test::write_file(f, build_png(w, h, bits, hb.rows));
    EXPECT_EQ(filter_types(files[0], w, h, bits / 8), (std::set<int>{0, 1, 2, 3, 4}));
    expect_stack_matches_oiio(dir.path(), files);
    auto src = open_ok(dir.path(), raw_values());
    ASSERT_TRUE(src);
    Slice s;
    ASSERT_TRUE(src->read(1, s).ok());
    for (size_t k = 0; k < hb.values.size(); ++k)
      ASSERT_EQ(s.hu[k], static_cast<float>(hb.values[k])) << "sample " << k;
  }
}

// The message of the first failing read of a two-slice stack whose second slice is `bad`.
std::string read_problem(const fs::path& dir, const std::string& good, const std::string& bad) {
  test::write_file(dir / "b1.png", good);
  test::write_file(dir / "b2.png", bad);
  auto r = open_ct(dir, raw_values());
  if (!r.ok()) return r.error().message();
  Slice s;
  for (int i = 0; i < 2; ++i) {
    Status st = r.value()->read(i, s);
    if (!st) return st.error().message();
  }
  ADD_FAILURE() << "read without complaint";
  return "";
}

TEST(CtStack, PngFastPathRefusesDamagedImageData) {
  for (int bits : {8, 16}) {
    SCOPED_TRACE(bits);
    test::TempDir dir;
    const int w = 30, h = 20;
    const HandBuilt hb = hand_built(w, h, bits);
    const std::string good = build_png(w, h, bits, hb.rows);
    const std::string expected = (dir / "b2.png").string() + ": corrupt or truncated image data";

    // Truncated compressed stream (the chunks themselves are intact).
    EXPECT_THAT(read_problem(dir.path(), good, build_png(w, h, bits, hb.rows, 40)),
                HasSubstr(expected));
    // A damaged byte inside the stream: bad data or a wrong Adler-32.
    EXPECT_THAT(read_problem(dir.path(), good, build_png(w, h, bits, hb.rows, 0, 30)),
                HasSubstr(expected));
    // Too few and too many rows for the header's size.
    std::vector<unsigned char> short_rows(hb.rows.begin(), hb.rows.end() - (1 + w * bits / 8));
    EXPECT_THAT(read_problem(dir.path(), good, build_png(w, h, bits, short_rows)),
                HasSubstr(expected));
    std::vector<unsigned char> long_rows = hb.rows;
    long_rows.insert(long_rows.end(), hb.rows.begin(), hb.rows.begin() + 1 + w * bits / 8);
    EXPECT_THAT(read_problem(dir.path(), good, build_png(w, h, bits, long_rows)),
                HasSubstr(expected));
    // Filter type 5 on row 7.
    std::vector<unsigned char> bad_filter = hb.rows;
    bad_filter[7 * (1 + w * bits / 8)] = 5;
    const std::string msg = read_problem(dir.path(), good, build_png(w, h, bits, bad_filter));
    EXPECT_THAT(msg, HasSubstr(expected));
    EXPECT_THAT(msg, HasSubstr("filter type 5"));
  }
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
  EXPECT_TRUE(has_note(*src, "OpenOptions::pixel_spacing 0.9 mm overrides"));
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

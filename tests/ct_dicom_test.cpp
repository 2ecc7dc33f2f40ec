// The DICOM reader and writer: series this project did not write (built here with GDCM's own
// API in the tag combinations real scanners use), writer -> reader round trips, series choice,
// and streaming (memory does not grow with the slice count; headers are read without pixels).
#include <gdcmAttribute.h>
#include <gdcmDataElement.h>
#include <gdcmDataSet.h>
#include <gdcmFile.h>
#include <gdcmFileMetaInformation.h>
#include <gdcmImage.h>
#include <gdcmImageChangeTransferSyntax.h>
#include <gdcmImageReader.h>
#include <gdcmImageWriter.h>
#include <gdcmReader.h>
#include <gdcmTransferSyntax.h>
#include <gdcmWriter.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <malloc.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <new>
#include <random>
#include <string>
#include <vector>

#include "sawyer/ct/io/slice_sink.h"
#include "sawyer/ct/io/slice_source.h"
#include "sawyer/test/test_util.h"

// ---------------------------------------------------------------------------------------------
// Allocation counting: every operator new in this test binary goes through here, so a test can
// measure the peak of live heap bytes over a stretch of code (the reader's worker thread
// included). Counting, not timing.
namespace {
std::atomic<long long> g_live{0};
std::atomic<long long> g_peak{0};

void* counted_alloc(size_t n, size_t align = 0) {
  void* p = align > alignof(std::max_align_t)
                ? std::aligned_alloc(align, (n + align - 1) / align * align)
                : std::malloc(n ? n : 1);
  if (!p) throw std::bad_alloc();
  const long long live = g_live += static_cast<long long>(malloc_usable_size(p));
  long long peak = g_peak.load();
  while (live > peak && !g_peak.compare_exchange_weak(peak, live)) {
  }
  return p;
}
void counted_free(void* p) {
  if (!p) return;
  g_live -= static_cast<long long>(malloc_usable_size(p));
  std::free(p);
}

// Peak live bytes above the level at construction.
class PeakMeter {
 public:
  PeakMeter() : base_(g_live.load()) { g_peak = base_; }
  long long peak_above_start() const { return g_peak.load() - base_; }

 private:
  long long base_;
};
}  // namespace

void* operator new(size_t n) { return counted_alloc(n); }
void* operator new[](size_t n) { return counted_alloc(n); }
void* operator new(size_t n, std::align_val_t a) {
  return counted_alloc(n, static_cast<size_t>(a));
}
void* operator new[](size_t n, std::align_val_t a) {
  return counted_alloc(n, static_cast<size_t>(a));
}
void* operator new(size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted_alloc(n);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted_alloc(n);
  } catch (...) {
    return nullptr;
  }
}
void operator delete(void* p) noexcept { counted_free(p); }
void operator delete[](void* p) noexcept { counted_free(p); }
void operator delete(void* p, size_t) noexcept { counted_free(p); }
void operator delete[](void* p, size_t) noexcept { counted_free(p); }
void operator delete(void* p, std::align_val_t) noexcept { counted_free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { counted_free(p); }
void operator delete(void* p, size_t, std::align_val_t) noexcept { counted_free(p); }
void operator delete[](void* p, size_t, std::align_val_t) noexcept { counted_free(p); }

namespace sawyer::ct {
namespace {

namespace fs = std::filesystem;
using sawyer::test::TempDir;
using ::testing::HasSubstr;
using ::testing::StartsWith;

// ---------------------------------------------------------------------------------------------
// A foreign series, written with GDCM's own API the way scanners write them.

struct ForeignSpec {
  int rows = 6, cols = 5;
  double row_spacing = 0.5, col_spacing = 0.8;  // DICOM Pixel Spacing order: rows, then columns
  std::vector<double> orientation{1, 0, 0, 0, 1, 0};
  bool write_position = true;
  bool write_location = false;
  unsigned short bits_allocated = 16, bits_stored = 16, high_bit = 15, pixel_rep = 1;
  std::string series_uid = "1.2.826.0.1.3680043.9.7777.1";
  std::string series_description = "foreign test series";
  std::string manufacturer = "ACME";
  std::string model = "LogScan";
  gdcm::TransferSyntax::TSType ts = gdcm::TransferSyntax::ExplicitVRLittleEndian;
};

struct ForeignSlice {
  Vec3 position;
  double slice_location = 0;
  int instance = 1;
  double slope = 1, intercept = 0;
  std::vector<uint16_t> words;  // stored words as the file holds them (before any masking)
};

// Writes Explicit VR Little Endian with gdcm::Writer and a hand-built DataSet (typed values via
// gdcm::Attribute), then, for another transfer syntax, converts it the way gdcmconv does:
// gdcm::ImageReader -> gdcm::ImageChangeTransferSyntax -> gdcm::ImageWriter.
void write_foreign(const fs::path& path, const ForeignSpec& spec, const ForeignSlice& s) {
  {
    gdcm::Writer w;
    gdcm::File& file = w.GetFile();
    gdcm::DataSet& ds = file.GetDataSet();
    const std::string sop_uid = spec.series_uid + ".1." + std::to_string(s.instance);
    ds.Replace(gdcm::Attribute<0x0008, 0x0016>{"1.2.840.10008.5.1.4.1.1.2"}.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0008, 0x0018>{sop_uid.c_str()}.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0008, 0x0060>{"CT"}.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0008, 0x0070>{spec.manufacturer.c_str()}.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0008, 0x1090>{spec.model.c_str()}.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0008, 0x103e>{spec.series_description.c_str()}.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0020, 0x000d>{"1.2.826.0.1.3680043.9.7777"}.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0020, 0x000e>{spec.series_uid.c_str()}.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0020, 0x0013>{s.instance}.GetAsDataElement());
    if (spec.write_position) {
      gdcm::Attribute<0x0020, 0x0032> ipp = {{s.position.x, s.position.y, s.position.z}};
      ds.Replace(ipp.GetAsDataElement());
    }
    gdcm::Attribute<0x0020, 0x0037> iop;
    for (unsigned k = 0; k < 6; ++k) iop.SetValue(spec.orientation[k], k);
    ds.Replace(iop.GetAsDataElement());
    if (spec.write_location)
      ds.Replace(gdcm::Attribute<0x0020, 0x1041>{s.slice_location}.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0028, 0x0002>{1}.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0028, 0x0004>{"MONOCHROME2"}.GetAsDataElement());
    ds.Replace(
        gdcm::Attribute<0x0028, 0x0010>{static_cast<unsigned short>(spec.rows)}.GetAsDataElement());
    ds.Replace(
        gdcm::Attribute<0x0028, 0x0011>{static_cast<unsigned short>(spec.cols)}.GetAsDataElement());
    gdcm::Attribute<0x0028, 0x0030> spacing = {{spec.row_spacing, spec.col_spacing}};
    ds.Replace(spacing.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0028, 0x0100>{spec.bits_allocated}.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0028, 0x0101>{spec.bits_stored}.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0028, 0x0102>{spec.high_bit}.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0028, 0x0103>{spec.pixel_rep}.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0028, 0x1052>{s.intercept}.GetAsDataElement());
    ds.Replace(gdcm::Attribute<0x0028, 0x1053>{s.slope}.GetAsDataElement());
    gdcm::DataElement pixels(gdcm::Tag(0x7fe0, 0x0010));
    pixels.SetVR(spec.bits_allocated == 8 ? gdcm::VR::OB : gdcm::VR::OW);
    std::vector<char> bytes;
    for (uint16_t word : s.words) {
      bytes.push_back(static_cast<char>(word & 0xff));
      if (spec.bits_allocated == 16) bytes.push_back(static_cast<char>(word >> 8));
    }
    if (bytes.size() % 2) bytes.push_back(0);
    pixels.SetByteValue(bytes.data(), static_cast<uint32_t>(bytes.size()));
    ds.Replace(pixels);
    file.GetHeader().SetDataSetTransferSyntax(gdcm::TransferSyntax::ExplicitVRLittleEndian);
    w.SetFileName(path.c_str());
    ASSERT_TRUE(w.Write()) << path;
  }
  if (spec.ts == gdcm::TransferSyntax::ExplicitVRLittleEndian) return;
  gdcm::ImageReader r;
  r.SetFileName(path.c_str());
  ASSERT_TRUE(r.Read()) << path;
  gdcm::ImageChangeTransferSyntax change;
  change.SetTransferSyntax(spec.ts);
  change.SetInput(r.GetImage());
  ASSERT_TRUE(change.Change()) << "GDCM cannot convert to " << gdcm::TransferSyntax(spec.ts);
  gdcm::ImageWriter w;
  w.SetFile(r.GetFile());
  w.SetImage(change.GetOutput());
  w.SetFileName(path.c_str());
  ASSERT_TRUE(w.Write()) << path;
}

std::string transfer_syntax_of(const fs::path& file) {
  gdcm::Reader r;
  r.SetFileName(file.c_str());
  EXPECT_TRUE(r.ReadUpToTag(gdcm::Tag(0x0008, 0x0000)));
  return gdcm::TransferSyntax::GetTSString(r.GetFile().GetHeader().GetDataSetTransferSyntax());
}

// Random file names: their sort order says nothing about z.
std::vector<std::string> random_names(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<std::string> names;
  for (int i = 0; i < n; ++i) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "IM%08X", static_cast<unsigned>(rng()));
    names.push_back(buf);
  }
  return names;
}

Result<std::unique_ptr<SliceSource>> open(const fs::path& p, OpenOptions o = {}) {
  return open_ct(p, o);
}

OpenOptions series_option(const std::string& series) {
  OpenOptions o;
  o.series = series;
  return o;
}

// ---------------------------------------------------------------------------------------------
// Foreign series

// Signed 12-bit stored in 16 allocated, intercept -1024 (the classic CT export). The words have
// junk in the 4 unused high bits and negative values are not sign-extended: the reader must mask
// and sign-extend. Spacing x != y, an off-centre origin, random file names.
TEST(DicomForeign, Signed12BitWithInterceptAndJunkHighBits) {
  TempDir dir;
  ForeignSpec spec;
  spec.bits_stored = 12;
  spec.high_bit = 11;
  spec.pixel_rep = 1;
  const int n = 7;
  const double dz = 2.5;
  const std::vector<std::string> names = random_names(n, 7);
  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) order[i] = (i * 3) % n;  // instance numbers scrambled too
  for (int i = 0; i < n; ++i) {
    ForeignSlice s;
    s.position = {-120.25, -99.5, 40.0 + dz * i};
    s.instance = order[i] + 1;
    s.intercept = -1024;
    for (int k = 0; k < spec.rows * spec.cols; ++k) {
      const int v = -2048 + ((k * 157 + i * 31) % 4096);  // the whole 12-bit range
      const uint16_t junk = static_cast<uint16_t>((k % 16) << 12);
      s.words.push_back(static_cast<uint16_t>((v & 0x0fff) | junk));
    }
    write_foreign(dir / names[i], spec, s);
  }
  auto src = open(dir.path());
  ASSERT_TRUE(src) << src.error().message();
  const VolumeGeometry& g = src.value()->geometry();
  EXPECT_EQ(src.value()->format(), Format::kDicom);
  EXPECT_EQ(g.width, 5);
  EXPECT_EQ(g.height, 6);
  EXPECT_DOUBLE_EQ(g.spacing_x, 0.8);
  EXPECT_DOUBLE_EQ(g.spacing_y, 0.5);
  EXPECT_EQ(g.origin, (Vec3{-120.25, -99.5, 40.0}));
  ASSERT_EQ(g.slice_count(), n);
  for (int i = 0; i < n; ++i) EXPECT_NEAR(g.z[i], dz * i, 1e-9);
  EXPECT_EQ(g.bits_stored, 12);
  EXPECT_TRUE(g.pixel_signed);
  EXPECT_EQ(g.rescale_intercept, -1024);
  Slice s;
  for (int i = 0; i < n; ++i) {
    ASSERT_TRUE(src.value()->read(i, s));
    for (int k = 0; k < spec.rows * spec.cols; ++k) {
      const int v = -2048 + ((k * 157 + i * 31) % 4096);
      ASSERT_EQ(s.hu[k], static_cast<float>(v - 1024)) << "slice " << i << " pixel " << k;
    }
  }
  EXPECT_EQ(src.value()->description(),
            "DICOM series 1.2.826.0.1.3680043.9.7777.1 (CT, \"ACME LogScan\", "
            "\"foreign test series\"), 7 files");
}

// Explicit VR Big Endian with a different slope and intercept on every slice.
TEST(DicomForeign, BigEndianWithPerSliceRescale) {
  TempDir dir;
  ForeignSpec spec;
  spec.ts = gdcm::TransferSyntax::ExplicitVRBigEndian;
  spec.pixel_rep = 1;
  const int n = 4;
  for (int i = 0; i < n; ++i) {
    ForeignSlice s;
    s.position = {0, 0, 10.0 * i};
    s.instance = i + 1;
    s.slope = 0.5 + 0.25 * i;
    s.intercept = -1000 - 10 * i;
    for (int k = 0; k < spec.rows * spec.cols; ++k)
      s.words.push_back(static_cast<uint16_t>(static_cast<int16_t>(k * 300 - 4000)));
    write_foreign(dir / (std::string("slice") + std::to_string(i) + ".dcm"), spec, s);
  }
  ASSERT_EQ(transfer_syntax_of(dir / "slice0.dcm"), "1.2.840.10008.1.2.2");
  auto src = open(dir.path());
  ASSERT_TRUE(src) << src.error().message();
  EXPECT_THAT(src.value()->notes(), ::testing::Contains(HasSubstr("vary per slice")));
  Slice s;
  for (int i = 0; i < n; ++i) {
    ASSERT_TRUE(src.value()->read(i, s));
    for (int k = 0; k < spec.rows * spec.cols; ++k)
      ASSERT_EQ(s.hu[k], static_cast<float>((k * 300 - 4000) * (0.5 + 0.25 * i) - 1000 - 10 * i))
          << "slice " << i << " pixel " << k;
  }
}

// Unsigned 16-bit with intercept -1024, Implicit VR Little Endian, slices listed top to bottom
// (instance 1 is the highest z).
TEST(DicomForeign, Unsigned16BitImplicitVrListedTopToBottom) {
  TempDir dir;
  ForeignSpec spec;
  spec.ts = gdcm::TransferSyntax::ImplicitVRLittleEndian;
  spec.pixel_rep = 0;
  const int n = 5;
  for (int i = 0; i < n; ++i) {
    ForeignSlice s;
    s.position = {5, 6, 100.0 - 4.0 * i};
    s.instance = i + 1;
    s.intercept = -1024;
    for (int k = 0; k < spec.rows * spec.cols; ++k)
      s.words.push_back(static_cast<uint16_t>(60000 - 1000 * k - i));
    write_foreign(dir / (std::string("CT.") + std::to_string(i + 1)), spec, s);  // no extension
  }
  ASSERT_EQ(transfer_syntax_of(dir / "CT.1"), "1.2.840.10008.1.2");
  auto src = open(dir.path());
  ASSERT_TRUE(src) << src.error().message();
  const VolumeGeometry& g = src.value()->geometry();
  EXPECT_EQ(g.origin, (Vec3{5, 6, 84}));  // the lowest slice comes first
  EXPECT_FALSE(g.pixel_signed);
  Slice s;
  for (int zi = 0; zi < n; ++zi) {
    ASSERT_TRUE(src.value()->read(zi, s));
    EXPECT_DOUBLE_EQ(s.z, 4.0 * zi);
    const int file_index = n - 1 - zi;  // instance 5 is at the bottom
    EXPECT_EQ(s.at(0, 0), static_cast<float>(60000 - file_index - 1024));
    EXPECT_EQ(s.at(4, 5), static_cast<float>(60000 - 1000 * 29 - file_index - 1024));
  }
}

// Orientation whose normal points down (row +x, column -y: normal -z): the reader orders by the
// position on the normal, so z grows as the scanner's z falls.
TEST(DicomForeign, NegativeNormalOrdersAlongTheNormal) {
  TempDir dir;
  ForeignSpec spec;
  spec.orientation = {1, 0, 0, 0, -1, 0};
  const std::vector<std::string> names = random_names(4, 11);
  for (int i = 0; i < 4; ++i) {
    ForeignSlice s;
    s.position = {0, 0, -10.0 * i};
    s.instance = 4 - i;
    for (int k = 0; k < spec.rows * spec.cols; ++k) s.words.push_back(static_cast<uint16_t>(i));
    write_foreign(dir / names[i], spec, s);
  }
  auto src = open(dir.path());
  ASSERT_TRUE(src) << src.error().message();
  const VolumeGeometry& g = src.value()->geometry();
  EXPECT_EQ(g.origin, (Vec3{0, 0, 0}));
  EXPECT_EQ(g.orientation, (std::array<double, 6>{1, 0, 0, 0, -1, 0}));
  Slice s;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(src.value()->read(i, s));
    EXPECT_DOUBLE_EQ(s.z, 10.0 * i);
    EXPECT_EQ(s.at(2, 2), static_cast<float>(i));  // file i sits 10*i mm along the normal
  }
}

// Compressed transfer syntaxes the Debian GDCM decodes. 64 x 64 because OpenJPEG's encoder
// crashes on tiny images (a test-side limitation; decoding is what the reader does).
class DicomCompressed : public ::testing::TestWithParam<gdcm::TransferSyntax::TSType> {};

TEST_P(DicomCompressed, DecodesExactly) {
  TempDir dir;
  ForeignSpec spec;
  spec.rows = 64;
  spec.cols = 64;
  spec.bits_stored = 12;
  spec.high_bit = 11;
  spec.pixel_rep = 1;
  spec.ts = GetParam();
  const int n = 3;
  auto value = [](int i, int k) { return -2000 + (k * 37 + i * 101) % 4000; };
  for (int i = 0; i < n; ++i) {
    ForeignSlice s;
    s.position = {0, 0, 1.25 * i};
    s.instance = i + 1;
    s.intercept = -1024;
    s.slope = 1;
    for (int k = 0; k < spec.rows * spec.cols; ++k)
      s.words.push_back(static_cast<uint16_t>(static_cast<int16_t>(value(i, k))));
    write_foreign(dir / (std::string("s") + std::to_string(i) + ".dcm"), spec, s);
  }
  ASSERT_EQ(transfer_syntax_of(dir / "s0.dcm"), gdcm::TransferSyntax::GetTSString(GetParam()));
  auto src = open(dir.path());
  ASSERT_TRUE(src) << src.error().message();
  Slice s;
  for (int i = n - 1; i >= 0; --i) {  // any order works
    ASSERT_TRUE(src.value()->read(i, s)) << i;
    for (int k = 0; k < spec.rows * spec.cols; ++k)
      ASSERT_EQ(s.hu[k], static_cast<float>(value(i, k) - 1024)) << "slice " << i << " px " << k;
  }
}

INSTANTIATE_TEST_SUITE_P(Syntaxes, DicomCompressed,
                         ::testing::Values(gdcm::TransferSyntax::JPEGLosslessProcess14_1,
                                           gdcm::TransferSyntax::RLELossless,
                                           gdcm::TransferSyntax::JPEGLSLossless,
                                           gdcm::TransferSyntax::JPEG2000Lossless),
                         [](const auto& param_info) {
                           switch (param_info.param) {
                             case gdcm::TransferSyntax::JPEGLosslessProcess14_1:
                               return std::string("JpegLossless");
                             case gdcm::TransferSyntax::RLELossless:
                               return std::string("Rle");
                             case gdcm::TransferSyntax::JPEGLSLossless:
                               return std::string("JpegLs");
                             default:
                               return std::string("Jpeg2000");
                           }
                         });

// Deflate is refused with a hint (its inflated stream cannot be checked without inflating
// every file at open; CT scanners do not write it).
TEST(DicomForeign, DeflatedIsRefusedWithAHint) {
  TempDir dir;
  ForeignSpec spec;
  spec.ts = gdcm::TransferSyntax::DeflatedExplicitVRLittleEndian;
  for (int i = 0; i < 2; ++i) {
    ForeignSlice s;
    s.position = {0, 0, 1.0 * i};
    s.words.assign(static_cast<size_t>(spec.rows * spec.cols), 1);
    write_foreign(dir / (std::string("d") + std::to_string(i) + ".dcm"), spec, s);
  }
  auto src = open(dir.path());
  ASSERT_FALSE(src);
  EXPECT_EQ(src.error().message(),
            (dir / "d0.dcm").string() +
                ": Deflated Explicit VR Little Endian is not supported; store the series "
                "uncompressed (e.g. gdcmconv --raw)");
}

// Without Image Position (Patient) the reader orders by Slice Location, never by name.
TEST(DicomForeign, SliceLocationFallback) {
  TempDir dir;
  ForeignSpec spec;
  spec.write_position = false;
  spec.write_location = true;
  const std::vector<double> locations = {30, -5, 12.5, 0};
  for (size_t i = 0; i < locations.size(); ++i) {
    ForeignSlice s;
    s.slice_location = locations[i];
    s.instance = static_cast<int>(i) + 1;
    for (int k = 0; k < spec.rows * spec.cols; ++k)
      s.words.push_back(static_cast<uint16_t>(2 * locations[i] + 100));
    write_foreign(dir / (std::string("a") + std::to_string(i) + ".dcm"), spec, s);
  }
  auto src = open(dir.path());
  ASSERT_TRUE(src) << src.error().message();
  EXPECT_THAT(src.value()->notes(), ::testing::Contains(HasSubstr("ordered by Slice Location")));
  // Positions -5, 0, 12.5, 30: uneven, so open_ct resamples at the median (12.5 mm).
  const VolumeGeometry& g = src.value()->geometry();
  ASSERT_EQ(g.slice_count(), 3);
  EXPECT_EQ(g.origin, (Vec3{0, 0, -5}));
  Slice s;
  ASSERT_TRUE(src.value()->read(1, s));  // z = 12.5 -> location 7.5, between 0 and 12.5
  EXPECT_FLOAT_EQ(s.at(0, 0), 115.0f);   // 100 + 0.6 * (125 - 100)
}

TEST(DicomForeign, NonDicomFilesAreIgnoredWithANote) {
  TempDir dir;
  ForeignSpec spec;
  for (int i = 0; i < 3; ++i) {
    ForeignSlice s;
    s.position = {0, 0, 1.0 * i};
    s.words.assign(static_cast<size_t>(spec.rows * spec.cols), 7);
    write_foreign(dir / (std::string("s") + std::to_string(i) + ".dcm"), spec, s);
  }
  sawyer::test::write_file(dir / "README.txt", "exported by the scanner\n");
  sawyer::test::write_file(dir / "Thumbs.db", std::string(300, '\x01'));
  auto src = open(dir.path());
  ASSERT_TRUE(src) << src.error().message();
  EXPECT_EQ(src.value()->geometry().slice_count(), 3);
  EXPECT_THAT(src.value()->notes(),
              ::testing::Contains("ignored 2 non-DICOM files: README.txt, Thumbs.db"));
}

// ---------------------------------------------------------------------------------------------
// Several series

// Writes three small series with Sawyer's writer into one folder (by way of staging folders).
void write_three_series(const fs::path& dir) {
  for (int k = 0; k < 3; ++k) {
    VolumeGeometry g;
    g.width = 4;
    g.height = 3;
    g.spacing_x = g.spacing_y = 1.0;
    for (int i = 0; i < 2 + k; ++i) g.z.push_back(2.0 * i);
    WriteOptions o;
    o.uid_seed = 100 + k;
    o.series_description = "series " + std::to_string(k);
    const fs::path stage = dir.parent_path() / (dir.filename().string() + "_stage");
    auto sink = create_ct_writer(stage, g, o);
    ASSERT_TRUE(sink) << sink.error().message();
    Slice s;
    s.width = 4;
    s.height = 3;
    s.hu.assign(12, static_cast<float>(100 * k));
    for (int i = 0; i < g.slice_count(); ++i) {
      s.index = i;
      ASSERT_TRUE(sink.value()->write(s));
    }
    ASSERT_TRUE(sink.value()->finish());
    fs::create_directories(dir);
    for (const auto& e : fs::directory_iterator(stage))
      fs::rename(e.path(),
                 dir / (std::string("s") + std::to_string(k) + "_" + e.path().filename().string()));
    fs::remove_all(stage);
  }
}

std::string series_uid_of(const fs::path& file) {
  gdcm::Reader r;
  r.SetFileName(file.c_str());
  EXPECT_TRUE(r.ReadUpToTag(gdcm::Tag(0x7fe0, 0x0010)));
  gdcm::Attribute<0x0020, 0x000e> uid;
  uid.SetFromDataSet(r.GetFile().GetDataSet());
  std::string s = uid.GetValue();
  while (!s.empty() && (s.back() == '\0' || s.back() == ' ')) s.pop_back();
  return s;
}

TEST(DicomSeries, SeveralSeriesAreRefusedWithAList) {
  TempDir tmp;
  const fs::path dir = tmp / "mixed";
  write_three_series(dir);
  auto src = open(dir);
  ASSERT_FALSE(src);
  const std::string& m = src.error().message();
  EXPECT_THAT(
      m, StartsWith(dir.string() + ": holds 3 DICOM series; choose one with OpenOptions::series"));
  for (int k = 0; k < 3; ++k) {
    const std::string uid =
        series_uid_of(dir / (std::string("s") + std::to_string(k) + "_slice_0001.dcm"));
    EXPECT_THAT(m, HasSubstr(uid + " \"series " + std::to_string(k) + "\" CT, " +
                             std::to_string(2 + k) + " files"));
  }
  EXPECT_EQ(m.find('\n'), std::string::npos);  // one line
}

TEST(DicomSeries, PickByUidPrefixAndByNumber) {
  TempDir tmp;
  const fs::path dir = tmp / "mixed";
  write_three_series(dir);
  const std::string uid2 = series_uid_of(dir / "s2_slice_0001.dcm");
  // Shortest prefix that is unique among the three.
  std::vector<std::string> uids;
  for (int k = 0; k < 3; ++k)
    uids.push_back(series_uid_of(dir / (std::string("s") + std::to_string(k) + "_slice_0001.dcm")));
  size_t len = 6;
  while (std::count_if(uids.begin(), uids.end(), [&](const std::string& u) {
           return u.compare(0, len, uid2, 0, len) == 0;
         }) > 1)
    ++len;
  auto by_prefix = open(dir, series_option(uid2.substr(0, len)));
  ASSERT_TRUE(by_prefix) << by_prefix.error().message();
  EXPECT_EQ(by_prefix.value()->geometry().slice_count(), 4);
  EXPECT_THAT(by_prefix.value()->description(), HasSubstr(uid2));
  EXPECT_THAT(by_prefix.value()->notes(), ::testing::Contains(HasSubstr("holds 3 DICOM series")));

  // Series numbers are equal, so the list is in UID order; find which number is uid2.
  std::vector<std::string> sorted = uids;
  std::sort(sorted.begin(), sorted.end());
  const int number =
      static_cast<int>(std::find(sorted.begin(), sorted.end(), uid2) - sorted.begin()) + 1;
  auto by_number = open(dir, series_option(std::to_string(number)));
  ASSERT_TRUE(by_number) << by_number.error().message();
  EXPECT_THAT(by_number.value()->description(), HasSubstr(uid2));
  Slice s;
  ASSERT_TRUE(by_number.value()->read(0, s));
  EXPECT_EQ(s.at(0, 0), 200.0f);

  auto whole = open(dir, series_option(uid2));
  ASSERT_TRUE(whole);
  EXPECT_THAT(whole.value()->description(), HasSubstr(uid2));

  auto none = open(dir, series_option("9.9.9"));
  ASSERT_FALSE(none);
  EXPECT_THAT(none.error().message(),
              HasSubstr("no DICOM series matches OpenOptions::series \"9.9.9\""));
  auto ambiguous = open(dir, series_option("2.25."));
  ASSERT_FALSE(ambiguous);
  EXPECT_THAT(ambiguous.error().message(), HasSubstr("matches 3 series"));
  auto out_of_range = open(dir, series_option("4"));
  ASSERT_FALSE(out_of_range);
  EXPECT_THAT(out_of_range.error().message(), HasSubstr("there are only 3 series"));
}

TEST(DicomSeries, OneFileOpensItsOwnSeries) {
  TempDir tmp;
  const fs::path dir = tmp / "mixed";
  write_three_series(dir);
  auto src = open(dir / "s1_slice_0002.dcm");
  ASSERT_TRUE(src) << src.error().message();
  EXPECT_EQ(src.value()->geometry().slice_count(), 3);
  EXPECT_THAT(src.value()->description(), HasSubstr(series_uid_of(dir / "s1_slice_0001.dcm")));
}

// ---------------------------------------------------------------------------------------------
// Writer

VolumeGeometry oblique_geometry(int n, int w, int h) {
  VolumeGeometry g;
  g.width = w;
  g.height = h;
  g.spacing_x = 0.390625;
  g.spacing_y = 0.7123456789;
  for (int i = 0; i < n; ++i) g.z.push_back(1.6 * i);
  g.origin = {-249.8046875, -180.123456789, 1234.56789012};
  // A rotation of 30 degrees about y: row = (cos, 0, -sin), column = (0, 1, 0).
  const double c = std::cos(kPi / 6), s = std::sin(kPi / 6);
  g.orientation = {c, 0, -s, 0, 1, 0};
  return g;
}

float phantom_hu(int i, int col, int row) {
  return static_cast<float>(-1000.0 + 7.3 * col + 11.1 * row + 53.7 * i);
}

TEST(DicomWriter, RoundTripGeometryExactValuesWithinQuantisation) {
  TempDir tmp;
  const fs::path out = tmp / "series";
  const VolumeGeometry g = oblique_geometry(6, 9, 7);
  WriteOptions o;
  o.rescale_slope = 0.5;
  o.rescale_intercept = -1024;
  auto sink = create_ct_writer(out, g, o);
  ASSERT_TRUE(sink) << sink.error().message();
  Slice s;
  s.width = g.width;
  s.height = g.height;
  for (int i = 0; i < g.slice_count(); ++i) {
    s.index = i;
    s.z = g.z[i];
    s.hu.resize(static_cast<size_t>(g.width * g.height));
    for (int r = 0; r < g.height; ++r)
      for (int c = 0; c < g.width; ++c) s.hu[r * g.width + c] = phantom_hu(i, c, r);
    ASSERT_TRUE(sink.value()->write(s));
  }
  ASSERT_TRUE(sink.value()->finish());

  auto src = open(out);
  ASSERT_TRUE(src) << src.error().message();
  const VolumeGeometry& r = src.value()->geometry();
  EXPECT_EQ(r.width, g.width);
  EXPECT_EQ(r.height, g.height);
  EXPECT_NEAR(r.spacing_x, g.spacing_x, 1e-9);
  EXPECT_NEAR(r.spacing_y, g.spacing_y, 1e-9);
  EXPECT_NEAR(r.origin.x, g.origin.x, 1e-6);
  EXPECT_NEAR(r.origin.y, g.origin.y, 1e-6);
  EXPECT_NEAR(r.origin.z, g.origin.z, 1e-6);
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(r.orientation[k], g.orientation[k], 1e-12);
  ASSERT_EQ(r.slice_count(), g.slice_count());
  for (int i = 0; i < g.slice_count(); ++i) EXPECT_NEAR(r.z[i], g.z[i], 1e-6);
  EXPECT_EQ(r.rescale_slope, 0.5);
  EXPECT_EQ(r.rescale_intercept, -1024);
  EXPECT_EQ(r.bits_stored, 16);
  EXPECT_TRUE(r.pixel_signed);
  for (int i = 0; i < g.slice_count(); ++i) {
    ASSERT_TRUE(src.value()->read(i, s));
    for (int row = 0; row < g.height; ++row)
      for (int c = 0; c < g.width; ++c)
        ASSERT_NEAR(s.at(c, row), phantom_hu(i, c, row), 0.25 + 1e-4);  // slope / 2
  }
}

std::string tag_text(const gdcm::DataSet& ds, uint16_t g, uint16_t e) {
  const gdcm::DataElement& de = ds.GetDataElement(gdcm::Tag(g, e));
  const gdcm::ByteValue* bv = de.GetByteValue();
  if (!bv) return "(missing)";
  std::string s(bv->GetPointer(), bv->GetLength());
  while (!s.empty() && (s.back() == ' ' || s.back() == '\0')) s.pop_back();
  return s;
}

TEST(DicomWriter, HeaderTagsNamesAndDeterministicUids) {
  TempDir tmp;
  VolumeGeometry g;
  g.width = 3;
  g.height = 2;
  g.spacing_x = 0.25;
  g.spacing_y = 0.75;
  g.z = {0, 5, 10};
  g.origin = {1, 2, 3};
  WriteOptions o;
  o.manufacturer = "Sawyer test";
  o.series_description = "round trip";
  o.patient_name = "Log^0042";
  o.rescale_intercept = -1024;
  o.uid_seed = 42;
  auto write = [&](const fs::path& out, unsigned long long seed) {
    o.uid_seed = seed;
    auto sink = create_ct_writer(out, g, o);
    ASSERT_TRUE(sink);
    Slice s;
    s.width = 3;
    s.height = 2;
    s.hu = {-1000, 0, 1000, 40000, -40000, 12.5};
    for (int i = 0; i < 3; ++i) {
      s.index = i;
      ASSERT_TRUE(sink.value()->write(s));
    }
    ASSERT_TRUE(sink.value()->finish());
  };
  write(tmp / "a", 42);
  write(tmp / "b", 42);
  write(tmp / "c", 43);
  for (const char* f : {"slice_0001.dcm", "slice_0002.dcm", "slice_0003.dcm"})
    EXPECT_TRUE(fs::exists(tmp / "a" / f)) << f;

  gdcm::Reader r;
  r.SetFileName((tmp / "a" / "slice_0002.dcm").c_str());
  ASSERT_TRUE(r.Read());
  const gdcm::DataSet& ds = r.GetFile().GetDataSet();
  EXPECT_EQ(tag_text(ds, 0x0008, 0x0016), "1.2.840.10008.5.1.4.1.1.2");  // CT Image Storage
  EXPECT_EQ(tag_text(ds, 0x0008, 0x0060), "CT");
  EXPECT_EQ(tag_text(ds, 0x0008, 0x0070), "Sawyer test");
  EXPECT_EQ(tag_text(ds, 0x0008, 0x103e), "round trip");
  EXPECT_EQ(tag_text(ds, 0x0010, 0x0010), "Log^0042");
  EXPECT_EQ(tag_text(ds, 0x0020, 0x0013), "2");
  EXPECT_EQ(tag_text(ds, 0x0028, 0x0030), "0.75\\0.25");  // row spacing (y) first
  EXPECT_EQ(tag_text(ds, 0x0020, 0x0032), "1\\2\\8");
  EXPECT_EQ(tag_text(ds, 0x0020, 0x0037), "1\\0\\0\\0\\1\\0");
  EXPECT_EQ(tag_text(ds, 0x0020, 0x1041), "8");
  EXPECT_EQ(tag_text(ds, 0x0018, 0x0050), "5");
  EXPECT_EQ(tag_text(ds, 0x0018, 0x0088), "5");
  EXPECT_EQ(tag_text(ds, 0x0028, 0x1052), "-1024");
  EXPECT_EQ(tag_text(ds, 0x0028, 0x1053), "1");
  EXPECT_EQ(transfer_syntax_of(tmp / "a" / "slice_0002.dcm"), "1.2.840.10008.1.2.1");
  const std::string series = tag_text(ds, 0x0020, 0x000e);
  EXPECT_THAT(series, StartsWith("2.25."));
  EXPECT_LE(series.size(), 64u);
  EXPECT_EQ(series, series_uid_of(tmp / "b" / "slice_0001.dcm"));  // same seed, same UID
  EXPECT_NE(series, series_uid_of(tmp / "c" / "slice_0001.dcm"));
  EXPECT_NE(tag_text(ds, 0x0008, 0x0018), series);

  // Out-of-range HU clamp to the signed 16-bit range: 40000 -> 32767 + (-1024).
  auto src = open(tmp / "a");
  ASSERT_TRUE(src);
  Slice s;
  ASSERT_TRUE(src.value()->read(0, s));
  EXPECT_EQ(s.hu, (std::vector<float>{-1000, 0, 1000, 31743, -33792, 13}));
  EXPECT_THAT(src.value()->description(),
              HasSubstr("(CT, \"Sawyer test\", \"round trip\"), 3 files"));
}

// Output is all or nothing.
TEST(DicomWriter, AbandonedWriterLeavesNothing) {
  TempDir tmp;
  VolumeGeometry g = oblique_geometry(3, 4, 4);
  {
    auto sink = create_ct_writer(tmp / "out", g, {});
    ASSERT_TRUE(sink);
    Slice s;
    s.width = s.height = 4;
    s.hu.assign(16, 0.0f);
    s.index = 0;
    ASSERT_TRUE(sink.value()->write(s));
    const Status st = sink.value()->finish();  // 1 of 3 slices
    ASSERT_FALSE(st);
    EXPECT_THAT(st.error().message(), HasSubstr("only 1 of 3 slices were written"));
  }
  EXPECT_TRUE(fs::is_empty(tmp.path()));  // no output, no temporary folder
}

TEST(DicomWriter, FinishReplacesExistingFolderAndRunsBeforeCommit) {
  TempDir tmp;
  const fs::path out = tmp / "out";
  sawyer::test::write_file(out / "old_file.txt", "old");
  VolumeGeometry g = oblique_geometry(2, 4, 4);
  WriteOptions o;
  fs::path seen_tmp;
  o.before_commit = [&](const fs::path& t) -> Status {
    seen_tmp = t;
    EXPECT_FALSE(fs::exists(out / "slice_0001.dcm"));  // not yet in place
    EXPECT_TRUE(fs::exists(t / "slice_0002.dcm"));
    sawyer::test::write_file(t / "truth" / "log.json", "{}");
    return Status::Ok();
  };
  auto sink = create_ct_writer(out, g, o);
  ASSERT_TRUE(sink);
  Slice s;
  s.width = s.height = 4;
  s.hu.assign(16, 5.0f);
  for (int i = 0; i < 2; ++i) {
    s.index = i;
    ASSERT_TRUE(sink.value()->write(s));
  }
  ASSERT_TRUE(sink.value()->finish());
  EXPECT_EQ(seen_tmp.parent_path(), tmp.path());
  EXPECT_FALSE(fs::exists(seen_tmp));
  EXPECT_FALSE(fs::exists(out / "old_file.txt"));
  EXPECT_TRUE(fs::exists(out / "truth" / "log.json"));
  EXPECT_TRUE(fs::exists(out / "slice_0002.dcm"));
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(tmp.path())) ++entries;
  EXPECT_EQ(entries, 1);  // only out/: no temporary or backup folder left
}

TEST(DicomWriter, FailingBeforeCommitLeavesTheOldOutput) {
  TempDir tmp;
  const fs::path out = tmp / "out";
  sawyer::test::write_file(out / "old_file.txt", "old");
  WriteOptions o;
  o.before_commit = [](const fs::path&) -> Status { return Error("truth", "disk full"); };
  VolumeGeometry g = oblique_geometry(2, 4, 4);
  {
    auto sink = create_ct_writer(out, g, o);
    ASSERT_TRUE(sink);
    Slice s;
    s.width = s.height = 4;
    s.hu.assign(16, 5.0f);
    for (int i = 0; i < 2; ++i) {
      s.index = i;
      ASSERT_TRUE(sink.value()->write(s));
    }
    const Status st = sink.value()->finish();
    ASSERT_FALSE(st);
    EXPECT_EQ(st.error().message(), "truth: disk full");
  }
  EXPECT_TRUE(fs::exists(out / "old_file.txt"));
  EXPECT_FALSE(fs::exists(out / "slice_0001.dcm"));
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(tmp.path())) ++entries;
  EXPECT_EQ(entries, 1);
}

TEST(DicomWriter, RejectsWrongSliceSizeAndNaN) {
  TempDir tmp;
  VolumeGeometry g = oblique_geometry(2, 4, 4);
  auto sink = create_ct_writer(tmp / "out", g, {});
  ASSERT_TRUE(sink);
  Slice s;
  s.width = 5;
  s.height = 4;
  s.hu.assign(20, 0.0f);
  s.index = 0;
  Status st = sink.value()->write(s);
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message(), HasSubstr("slice 0: slice is 5 x 4, the geometry says 4 x 4"));
  s.width = 4;
  s.hu.assign(16, 0.0f);
  s.hu[6] = std::nanf("");
  st = sink.value()->write(s);
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message(), HasSubstr("HU value is NaN at column 2, row 1"));
}

// ---------------------------------------------------------------------------------------------
// Streaming

fs::path write_series(const fs::path& out, int n, int size, WriteOptions o = {}) {
  VolumeGeometry g;
  g.width = g.height = size;
  g.spacing_x = g.spacing_y = 0.8;
  for (int i = 0; i < n; ++i) g.z.push_back(1.0 * i);
  auto sink = create_ct_writer(out, g, o);
  EXPECT_TRUE(sink);
  Slice s;
  s.width = s.height = size;
  s.hu.resize(static_cast<size_t>(size) * size);
  for (int i = 0; i < n; ++i) {
    s.index = i;
    for (size_t k = 0; k < s.hu.size(); ++k)
      s.hu[k] = static_cast<float>(-1000 + static_cast<int>((k + 13 * i) % 2000));
    EXPECT_TRUE(sink.value()->write(s));
  }
  EXPECT_TRUE(sink.value()->finish());
  return out;
}

// Reads every slice; returns the peak heap growth during the reads, checks a pixel per slice.
long long peak_while_reading(SliceSource& src) {
  Slice s;
  PeakMeter meter;
  for (int i = 0; i < src.geometry().slice_count(); ++i) {
    EXPECT_TRUE(src.read(i, s));
    EXPECT_EQ(s.hu[5], static_cast<float>(-1000 + (5 + 13 * i) % 2000)) << i;
  }
  return meter.peak_above_start();
}

TEST(DicomStreaming, MemoryDoesNotGrowWithSliceCount) {
  TempDir tmp;
  const int size = 128;
  const long long slice_floats = static_cast<long long>(size) * size * 4;
  const long long slice_raw = static_cast<long long>(size) * size * 2;
  const long long lut = 65536 * 4;
  long long peak[2];
  int k = 0;
  for (int n : {20, 200}) {
    const fs::path dir = write_series(tmp / (std::string("n") + std::to_string(n)), n, size);
    auto src = open(dir);
    ASSERT_TRUE(src) << src.error().message();
    peak[k++] = peak_while_reading(*src.value());
  }
  // By construction: the caller's slice, one prefetched slice, a raw buffer and a lookup table
  // per thread. Allow a little for bookkeeping, nothing per slice.
  const long long budget = 2 * slice_floats + 2 * slice_raw + 2 * lut + 64 * 1024;
  EXPECT_LE(peak[0], budget);
  EXPECT_LE(peak[1], budget);
  EXPECT_LE(peak[1], peak[0] + 16 * 1024) << "peak grew with the slice count";
}

// The same through GDCM's decoder (RLE): GDCM's own buffers come and go per slice.
TEST(DicomStreaming, CompressedMemoryDoesNotGrowWithSliceCount) {
  TempDir tmp;
  ForeignSpec spec;
  spec.rows = spec.cols = 64;
  spec.ts = gdcm::TransferSyntax::RLELossless;
  long long peak[2];
  int k = 0;
  for (int n : {10, 60}) {
    const fs::path dir = tmp / (std::string("n") + std::to_string(n));
    fs::create_directories(dir);
    for (int i = 0; i < n; ++i) {
      ForeignSlice s;
      s.position = {0, 0, 1.0 * i};
      s.instance = i + 1;
      s.intercept = -1000;
      for (int p = 0; p < 64 * 64; ++p)
        s.words.push_back(static_cast<uint16_t>((p + 13 * i) % 2000));
      write_foreign(dir / (std::string("s") + std::to_string(i) + ".dcm"), spec, s);
    }
    auto src = open(dir);
    ASSERT_TRUE(src) << src.error().message();
    peak[k++] = peak_while_reading(*src.value());
  }
  const long long slice_floats = 64 * 64 * 4;
  EXPECT_LE(peak[1], peak[0] + 16 * 1024) << "peak grew with the slice count";
  EXPECT_LE(peak[1], 2 * 65536 * 4 + 12 * slice_floats);
}

// Opening reads headers only: 200 files of 512 x 512 open without ever holding one slice.
// Also prints the read throughput (informative, never asserted).
TEST(DicomStreaming, OpenReadsNoPixelsAndReportsThroughput) {
  TempDir tmp;
  const int n = 200, size = 512;
  const fs::path dir = write_series(tmp / "big", n, size);
  const long long one_slice_raw = static_cast<long long>(size) * size * 2;

  PeakMeter meter;
  const auto t0 = std::chrono::steady_clock::now();
  auto src = open(dir);
  const auto t1 = std::chrono::steady_clock::now();
  ASSERT_TRUE(src) << src.error().message();
  EXPECT_LT(meter.peak_above_start(), one_slice_raw);

  Slice s;
  double checksum = 0;
  const auto t2 = std::chrono::steady_clock::now();
  for (int i = 0; i < n; ++i) {
    ASSERT_TRUE(src.value()->read(i, s));
    checksum += s.hu[static_cast<size_t>(i)];
  }
  const auto t3 = std::chrono::steady_clock::now();
  EXPECT_EQ(s.hu[5], static_cast<float>(-1000 + (5 + 13 * (n - 1)) % 2000));
  const double open_s = std::chrono::duration<double>(t1 - t0).count();
  const double read_s = std::chrono::duration<double>(t3 - t2).count();
  const double mb = n * one_slice_raw / 1e6;
  std::printf(
      "[ info     ] open %d headers: %.3f s (%.0f files/s); read %d slices of %dx%d "
      "16-bit as HU: %.3f s = %.0f slices/s, %.0f MB/s (checksum %.1f)\n",
      n, open_s, n / open_s, n, size, size, read_s, n / read_s, mb / read_s, checksum);
  RecordProperty("slices_per_second", static_cast<int>(n / read_s));
}

}  // namespace
}  // namespace sawyer::ct

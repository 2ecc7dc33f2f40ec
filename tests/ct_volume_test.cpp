// Volume files (.vti, .mha/.mhd, .nrrd/.nhdr): write -> read round trips through Sawyer's
// volume writer (values within 16-bit rounding, geometry exact), and files written by VTK
// itself or by hand (detached headers, gzip, compressed .vti, uneven extents, flipped spaces),
// read through open_ct().
#include <gmock/gmock.h>
#include <gtest/gtest.h>

// tests/CMakeLists.txt gives this test no VTK include path; VTK's headers find each other by
// quoted includes, and the libraries come with sawyer::ct_io.
#include <vtkImageData.h>
#include <vtkMetaImageWriter.h>
#include <vtkSmartPointer.h>
#include <vtkXMLImageDataWriter.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "../ct_pipeline/io/src/readers.h"
#include "sawyer/ct/io/slice_sink.h"
#include "sawyer/ct/io/slice_source.h"
#include "sawyer/test/ct_pattern.h"
#include "sawyer/test/test_util.h"

namespace sawyer::ct {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

bool has_note(const SliceSource& src, const std::string& text) {
  for (const std::string& n : src.notes())
    if (n.find(text) != std::string::npos) return true;
  return false;
}

// A VTK image with the pattern (rounded to short), spacing and origin as given.
vtkSmartPointer<vtkImageData> vtk_pattern(int w, int h, int n, const double spacing[3],
                                          const double origin[3]) {
  auto img = vtkSmartPointer<vtkImageData>::New();
  img->SetDimensions(w, h, n);
  img->SetSpacing(spacing[0], spacing[1], spacing[2]);
  img->SetOrigin(origin[0], origin[1], origin[2]);
  img->AllocateScalars(VTK_SHORT, 1);
  auto* p = static_cast<int16_t*>(img->GetScalarPointer());
  for (int k = 0; k < n; ++k)
    for (int r = 0; r < h; ++r)
      for (int c = 0; c < w; ++c)
        p[(static_cast<size_t>(k) * h + r) * w + c] =
            static_cast<int16_t>(std::lround(pattern_hu(c, r, k)));
  return img;
}

std::vector<int16_t> pattern_samples(int w, int h, int n) {
  std::vector<int16_t> v;
  for (int k = 0; k < n; ++k)
    for (int r = 0; r < h; ++r)
      for (int c = 0; c < w; ++c)
        v.push_back(static_cast<int16_t>(std::lround(pattern_hu(c, r, k))));
  return v;
}

void write_bytes(const fs::path& p, const std::string& head, const void* data, size_t n) {
  std::ofstream f(p, std::ios::binary);
  f << head;
  f.write(static_cast<const char*>(data), static_cast<std::streamsize>(n));
}

// gzip with stored (uncompressed) deflate blocks: enough for a reader test, no zlib needed.
std::string gzip_stored(const std::string& data) {
  uint32_t table[256];
  for (uint32_t i = 0; i < 256; ++i) {
    uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    table[i] = c;
  }
  uint32_t crc = 0xFFFFFFFFu;
  for (unsigned char ch : data) crc = table[(crc ^ ch) & 0xFF] ^ (crc >> 8);
  crc ^= 0xFFFFFFFFu;
  std::string out("\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\xff", 10);
  size_t at = 0;
  do {
    const size_t len = std::min<size_t>(65535, data.size() - at);
    const bool last = at + len == data.size();
    out.push_back(last ? 1 : 0);
    const uint16_t l = static_cast<uint16_t>(len), nl = static_cast<uint16_t>(~l);
    out.append(reinterpret_cast<const char*>(&l), 2).append(reinterpret_cast<const char*>(&nl), 2);
    out.append(data, at, len);
    at += len;
  } while (at < data.size());
  const uint32_t size = static_cast<uint32_t>(data.size());
  out.append(reinterpret_cast<const char*>(&crc), 4)
      .append(reinterpret_cast<const char*>(&size), 4);
  return out;
}

// ---------------------------------------------------------------------------------------------

class CtVolumeRoundTrip : public ::testing::TestWithParam<std::pair<Format, const char*>> {};

TEST_P(CtVolumeRoundTrip, GeometryExactValuesWithinRounding) {
  test::TempDir dir;
  const VolumeGeometry g = test_geometry(37, 23, 6);
  WriteOptions o;
  o.format = GetParam().first;
  write_volume(dir / "vol", g, o);
  ASSERT_TRUE(fs::exists(dir / "vol" / GetParam().second));
  for (const fs::path& p : {dir / "vol", dir / "vol" / GetParam().second}) {
    auto src = open_ok(p);
    ASSERT_TRUE(src);
    EXPECT_EQ(src->format(), GetParam().first);
    expect_geometry(src->geometry(), g);
    EXPECT_EQ(src->geometry().bits_stored, 16);
    EXPECT_TRUE(src->geometry().pixel_signed);
    expect_pattern(*src, 0.5);
    EXPECT_TRUE(src->notes().empty()) << src->notes().front();
  }
}

INSTANTIATE_TEST_SUITE_P(Formats, CtVolumeRoundTrip,
                         ::testing::Values(std::make_pair(Format::kVti, "volume.vti"),
                                           std::make_pair(Format::kMetaImage, "volume.mha"),
                                           std::make_pair(Format::kNrrd, "volume.nrrd")),
                         [](const auto& param_info) {
                           return std::string(param_info.param.second).substr(7);
                         });

TEST(CtVolume, FloatVolumesAreExact) {
  test::TempDir dir;
  const VolumeGeometry g = test_geometry(12, 10, 3);
  for (Format f : {Format::kVti, Format::kMetaImage, Format::kNrrd}) {
    WriteOptions o;
    o.format = f;
    o.bits_stored = 32;
    write_volume(dir / "f", g, o);
    auto src = open_ok(dir / "f");
    ASSERT_TRUE(src);
    EXPECT_EQ(src->geometry().bits_stored, 32);
    expect_pattern(*src, 0.0);
  }
}

TEST(CtVolume, MetaImageWrittenByVtk) {
  test::TempDir dir;
  const double spacing[3] = {0.5, 0.75, 3.0}, origin[3] = {5, 6, 7};
  auto img = vtk_pattern(30, 20, 5, spacing, origin);
  for (bool compress : {false, true}) {
    auto w = vtkSmartPointer<vtkMetaImageWriter>::New();
    w->SetInputData(img);
    const fs::path file = dir / (compress ? "z.mhd" : "scan.mha");
    w->SetFileName(file.string().c_str());
    if (compress) w->SetRAWFileName((dir / "z.zraw").string().c_str());
    w->SetCompression(compress);
    w->Write();
    auto src = open_ok(file);
    ASSERT_TRUE(src);
    EXPECT_EQ(src->format(), Format::kMetaImage);
    EXPECT_EQ(src->geometry().width, 30);
    EXPECT_DOUBLE_EQ(src->geometry().spacing_x, 0.5);
    EXPECT_DOUBLE_EQ(src->geometry().spacing_y, 0.75);
    EXPECT_DOUBLE_EQ(src->geometry().slice_spacing(), 3.0);
    EXPECT_EQ(src->geometry().origin, (Vec3{5, 6, 7}));
    expect_pattern(*src, 0.5);
    EXPECT_EQ(has_note(*src, "whole volume"), compress);
  }
}

TEST(CtVolume, NrrdDetachedHeaderWithDirections) {
  test::TempDir dir;
  const std::vector<int16_t> v = pattern_samples(20, 14, 4);
  write_bytes(dir / "scan.raw", "", v.data(), v.size() * 2);
  test::write_file(dir / "scan.nhdr",
                   "NRRD0004\n# hand-written\ntype: short\ndimension: 3\nspace dimension: 3\n"
                   "sizes: 20 14 4\nspace directions: (0,0.5,0) (-0.8,0,0) (0,0,2)\n"
                   "space origin: (1,2,3)\nendian: little\nencoding: raw\ndata file: scan.raw\n");
  auto src = open_ok(dir / "scan.nhdr");
  ASSERT_TRUE(src);
  const VolumeGeometry& g = src->geometry();
  EXPECT_DOUBLE_EQ(g.spacing_x, 0.5);
  EXPECT_DOUBLE_EQ(g.spacing_y, 0.8);
  EXPECT_DOUBLE_EQ(g.slice_spacing(), 2.0);
  EXPECT_EQ(g.orientation, (std::array<double, 6>{0, 1, 0, -1, 0, 0}));
  EXPECT_EQ(g.origin, (Vec3{1, 2, 3}));
  expect_pattern(*src, 0.5);
}

TEST(CtVolume, GzipNrrdIsReadWhole) {
  test::TempDir dir;
  const std::vector<int16_t> v = pattern_samples(16, 12, 5);
  const std::string gz =
      gzip_stored(std::string(reinterpret_cast<const char*>(v.data()), v.size() * 2));
  test::write_file(dir / "scan.nrrd",
                   "NRRD0004\ntype: int16\ndimension: 3\nsizes: 16 12 5\n"
                   "spacings: 0.5 0.5 1\nendian: little\nencoding: gzip\n\n" +
                       gz);
  auto src = open_ok(dir / "scan.nrrd");
  ASSERT_TRUE(src);
  EXPECT_TRUE(has_note(*src, "whole volume"));
  expect_pattern(*src, 0.5);
  // A left-handed space keeps the rows in file order; its directions are mapped into LPS, the
  // scanner frame Sawyer uses (LAS's y points anterior: negated).
  test::write_file(dir / "las.nrrd",
                   "NRRD0004\ntype: int16\ndimension: 3\nspace: "
                   "left-anterior-superior\nsizes: 16 12 5\nspace directions: "
                   "(0.5,0,0) (0,0.5,0) (0,0,1)\nendian: little\nencoding: gz\n\n" +
                       gz);
  auto las = open_ok(dir / "las.nrrd");
  ASSERT_TRUE(las);
  expect_pattern(*las, 0.5);
  EXPECT_EQ(las->geometry().orientation, (std::array<double, 6>{1, 0, 0, 0, -1, 0}));
}

TEST(CtVolume, NrrdLeftHandedSpaceKeepsRowOrder) {
  // Rows stay in file order whatever the space (raw data does not go through vtkNrrdReader);
  // the directions are mapped into LPS (LAS: y negated).
  test::TempDir dir;
  const std::vector<int16_t> v = pattern_samples(12, 10, 3);
  write_bytes(dir / "las.nrrd",
              "NRRD0004\ntype: short\ndimension: 3\nspace: left-anterior-superior\nsizes: 12 10 3\n"
              "space directions: (1,0,0) (0,1,0) (0,0,1)\nendian: little\nencoding: raw\n\n",
              v.data(), v.size() * 2);
  auto src = open_ok(dir / "las.nrrd");
  ASSERT_TRUE(src);
  expect_pattern(*src, 0.5);
  EXPECT_EQ(src->geometry().orientation, (std::array<double, 6>{1, 0, 0, 0, -1, 0}));
}

TEST(CtVolume, CompressedVtiWrittenByVtkReadsPerSlice) {
  test::TempDir dir;
  const double spacing[3] = {0.3, 0.3, 1.25}, origin[3] = {0, 0, 0};
  auto img = vtk_pattern(25, 15, 6, spacing, origin);
  auto w = vtkSmartPointer<vtkXMLImageDataWriter>::New();
  w->SetInputData(img);
  w->SetFileName((dir / "c.vti").string().c_str());  // VTK's default: zlib, appended
  ASSERT_EQ(w->Write(), 1);
  auto src = open_ok(dir / "c.vti");
  ASSERT_TRUE(src);
  EXPECT_THAT(src->description(), HasSubstr("compressed"));
  Slice s;
  for (int i : {5, 0, 3}) {
    ASSERT_TRUE(src->read(i, s).ok());
    EXPECT_FLOAT_EQ(s.at(7, 9), std::lround(pattern_hu(7, 9, i)));
  }
}

TEST(CtVolume, VtiExtentNotAtZeroMovesTheOrigin) {
  test::TempDir dir;
  auto img = vtkSmartPointer<vtkImageData>::New();
  img->SetExtent(4, 13, 2, 9, 10, 12);
  img->SetSpacing(0.5, 0.25, 2.0);
  img->SetOrigin(100, 200, 300);
  img->AllocateScalars(VTK_FLOAT, 1);
  for (int k = 10; k <= 12; ++k)
    for (int r = 2; r <= 9; ++r)
      for (int c = 4; c <= 13; ++c)
        *static_cast<float*>(img->GetScalarPointer(c, r, k)) =
            static_cast<float>(c + 100 * r + 1000 * k);
  auto w = vtkSmartPointer<vtkXMLImageDataWriter>::New();
  w->SetInputData(img);
  w->SetFileName((dir / "e.vti").string().c_str());
  ASSERT_EQ(w->Write(), 1);
  auto src = open_ok(dir / "e.vti");
  ASSERT_TRUE(src);
  const VolumeGeometry& g = src->geometry();
  EXPECT_EQ(g.width, 10);
  EXPECT_EQ(g.height, 8);
  EXPECT_EQ(g.slice_count(), 3);
  EXPECT_EQ(g.origin, (Vec3{102, 200.5, 320}));
  Slice s;
  ASSERT_TRUE(src->read(1, s).ok());
  EXPECT_FLOAT_EQ(s.at(0, 0), 4 + 200 + 11000);
  EXPECT_FLOAT_EQ(s.at(9, 7), 13 + 900 + 11000);
}

TEST(CtVolume, EightBitVolumeWithRescaleOptions) {
  test::TempDir dir;
  std::vector<uint8_t> v(12 * 10 * 3);
  for (size_t p = 0; p < v.size(); ++p) v[p] = static_cast<uint8_t>(p % 251);
  write_bytes(dir / "u8.mha",
              "ObjectType = Image\nNDims = 3\nDimSize = 12 10 3\nElementSpacing = 1 1 1\n"
              "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n",
              v.data(), v.size());
  OpenOptions o;
  o.rescale_slope = 8;
  o.rescale_intercept = -1000;
  auto src = open_ok(dir / "u8.mha", o);
  ASSERT_TRUE(src);
  Slice s;
  ASSERT_TRUE(src->read(2, s).ok());
  EXPECT_FLOAT_EQ(s.at(5, 4), static_cast<float>((240 + 48 + 5) % 251) * 8 - 1000);
}

TEST(CtVolume, MetaImageIntensityKeysAreTheRescale) {
  test::TempDir dir;
  std::vector<uint16_t> v(12 * 10 * 2, 2024);
  write_bytes(dir / "u16.mha",
              "ObjectType = Image\nNDims = 3\nDimSize = 12 10 2\nElementSpacing = 1 1 1\n"
              "ElementToIntensityFunctionSlope = 1\nElementToIntensityFunctionOffset = -1024\n"
              "ElementType = MET_USHORT\nElementDataFile = LOCAL\n",
              v.data(), v.size() * 2);
  auto src = open_ok(dir / "u16.mha");
  ASSERT_TRUE(src);
  Slice s;
  ASSERT_TRUE(src->read(1, s).ok());
  EXPECT_FLOAT_EQ(s.at(3, 3), 1000);
  EXPECT_FALSE(has_note(*src, "unsigned 16-bit"));
}

TEST(CtVolume, UnsignedVolumeWithoutRescaleIsHuWithANote) {
  test::TempDir dir;
  std::vector<uint16_t> v(12 * 10 * 2, 700);
  write_bytes(dir / "u16.nrrd",
              "NRRD0004\ntype: ushort\ndimension: 3\nsizes: 12 10 2\nspacings: 1 1 1\n"
              "endian: little\nencoding: raw\n\n",
              v.data(), v.size() * 2);
  auto src = open_ok(dir / "u16.nrrd");
  ASSERT_TRUE(src);
  Slice s;
  ASSERT_TRUE(src->read(0, s).ok());
  EXPECT_FLOAT_EQ(s.at(0, 0), 700);
  EXPECT_TRUE(has_note(*src, "unsigned 16-bit"));
}

TEST(CtVolume, BigEndianMetaImageWithSeparateDataFile) {
  test::TempDir dir;
  std::vector<int16_t> v = pattern_samples(14, 11, 3);
  for (int16_t& x : v)
    x = static_cast<int16_t>((static_cast<uint16_t>(x) >> 8) | (static_cast<uint16_t>(x) << 8));
  write_bytes(dir / "be.raw", std::string(16, 'x'), v.data(), v.size() * 2);  // 16 bytes to skip
  test::write_file(dir / "be.mhd",
                   "ObjectType = Image\nNDims = 3\nDimSize = 14 11 3\nElementSpacing = 1 1 2\n"
                   "BinaryDataByteOrderMSB = True\nHeaderSize = 16\nElementType = MET_SHORT\n"
                   "ElementDataFile = be.raw\n");
  auto src = open_ok(dir / "be.mhd");
  ASSERT_TRUE(src);
  expect_pattern(*src, 0.5);
}

TEST(CtVolume, WriterRefusesUnevenZ) {
  test::TempDir dir;
  VolumeGeometry g = test_geometry(8, 8, 4);
  g.z = {0, 2, 4, 8};
  WriteOptions o;
  o.format = Format::kNrrd;
  auto w = create_ct_writer(dir / "v", g, o);
  ASSERT_FALSE(w.ok());
  EXPECT_THAT(w.error().message(), HasSubstr("evenly spaced slices"));
  EXPECT_THAT(w.error().message(), HasSubstr("slices 2 and 3 are 4 mm apart"));
  EXPECT_FALSE(fs::exists(dir / "v"));
}

TEST(CtVolume, WriterIsAllOrNothing) {
  test::TempDir dir;
  const VolumeGeometry g = test_geometry(8, 8, 3);
  for (Format f : {Format::kVti, Format::kMetaImage, Format::kNrrd}) {
    WriteOptions o;
    o.format = f;
    {
      auto sink = create_ct_writer(dir / "v", g, o);
      ASSERT_TRUE(sink.ok());
      ASSERT_TRUE(sink.value()->write(pattern_slice(g, 0)).ok());
    }
    EXPECT_TRUE(fs::is_empty(dir.path()));
  }
}

TEST(CtVolume, AnySliceOrderGivesTheSameSlices) {
  // A 200-slice volume read in order and out of order gives the same slices: the per-slice
  // update extent does not depend on what was read before.
  test::TempDir dir;
  const VolumeGeometry g = test_geometry(16, 16, 40);
  for (Format f : {Format::kVti, Format::kMetaImage, Format::kNrrd}) {
    WriteOptions o;
    o.format = f;
    write_volume(dir / "v", g, o);
    auto src = open_ok(dir / "v");
    ASSERT_TRUE(src);
    Slice s;
    for (int i : {39, 0, 20, 19, 38}) {
      ASSERT_TRUE(src->read(i, s).ok());
      EXPECT_NEAR(s.at(5, 6), pattern_hu(5, 6, i), 0.5) << format_name(f) << " slice " << i;
    }
  }
}

}  // namespace
}  // namespace sawyer::ct

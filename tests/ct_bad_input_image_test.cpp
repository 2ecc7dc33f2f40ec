// Bad image stacks and volume files: each case gets one Error line that names the file and the
// problem, never a crash or a half-read scan. One TEST per case (docs/ct_input.md lists them).
#include <OpenImageIO/imageio.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "sawyer/ct/io/slice_sink.h"
#include "sawyer/ct/io/slice_source.h"
#include "sawyer/test/test_util.h"

namespace sawyer::ct {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

template <typename T>
void write_image(const fs::path& file, int w, int h, int channels, OIIO::TypeDesc type,
                 const std::vector<T>& pixels) {
  OIIO::ImageSpec spec(w, h, channels, type);
  spec.attribute("compression", "none");
  auto out = OIIO::ImageOutput::create(file.string());
  ASSERT_TRUE(out);
  ASSERT_TRUE(out->open(file.string(), spec)) << out->geterror();
  ASSERT_TRUE(out->write_image(type, pixels.data())) << out->geterror();
  ASSERT_TRUE(out->close());
}

void write_u16(const fs::path& file, int w = 16, int h = 12, uint16_t v = 1000) {
  write_image(file, w, h, 1, OIIO::TypeDesc::UINT16,
              std::vector<uint16_t>(static_cast<size_t>(w) * h, v));
}

void write_bytes(const fs::path& p, const std::string& head, const void* data, size_t n) {
  std::ofstream f(p, std::ios::binary);
  f << head;
  f.write(static_cast<const char*>(data), static_cast<std::streamsize>(n));
}

std::string file_bytes(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

const char* kSpacing = R"({"pixel_spacing_mm": 0.5, "slice_spacing_mm": 1})";

// A valid two-slice TIFF stack with a sidecar.
void good_stack(const fs::path& dir) {
  write_u16(dir / "slice_1.tif");
  write_u16(dir / "slice_2.tif");
  test::write_file(dir / "sawyer_stack.json", kSpacing);
}

// The message of a failed open, or of the first failing read.
std::string problem(const fs::path& p, const OpenOptions& o = {}) {
  auto r = open_ct(p, o);
  if (!r.ok()) return r.error().message();
  Slice s;
  for (int i = 0; i < r.value()->geometry().slice_count(); ++i) {
    Status st = r.value()->read(i, s);
    if (!st) return st.error().message();
  }
  ADD_FAILURE() << p << " was read without complaint";
  return "";
}

void expect_one_line(const std::string& msg) {
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
}

// ---------------------------------------------------------------------------------------------
// Image stacks

TEST(CtBadInputImage, GarbageTiff) {
  test::TempDir dir;
  good_stack(dir.path());
  test::write_file(dir / "slice_2.tif", "this is not a TIFF file at all");
  const std::string msg = problem(dir.path());
  EXPECT_THAT(msg, HasSubstr("slice_2.tif"));
  EXPECT_THAT(msg, HasSubstr("cannot read as TIFF"));
  expect_one_line(msg);
}

TEST(CtBadInputImage, UnreadableFile) {
  if (geteuid() == 0) GTEST_SKIP() << "root reads every file";
  test::TempDir dir;
  good_stack(dir.path());
  fs::permissions(dir / "slice_2.tif", fs::perms::none);
  const std::string msg = problem(dir.path());
  EXPECT_THAT(msg, HasSubstr("slice_2.tif"));
}

TEST(CtBadInputImage, FileRemovedAfterOpen) {
  test::TempDir dir;
  good_stack(dir.path());
  auto src = open_ct(dir.path());
  ASSERT_TRUE(src.ok()) << src.error().message();
  fs::remove(dir / "slice_2.tif");
  Slice s;
  ASSERT_TRUE(src.value()->read(0, s).ok());
  Status st = src.value()->read(1, s);
  ASSERT_FALSE(st.ok());
  EXPECT_THAT(st.error().message(), HasSubstr("slice_2.tif: cannot read as TIFF"));
  expect_one_line(st.error().message());
}

TEST(CtBadInputImage, TruncatedTiffHeader) {
  test::TempDir dir;
  write_u16(dir / "slice_1.tif", 64, 64);
  write_u16(dir / "slice_2.tif", 64, 64);
  test::write_file(dir / "sawyer_stack.json", kSpacing);
  test::write_file(dir / "slice_2.tif", file_bytes(dir / "slice_2.tif").substr(0, 60));
  const std::string msg = problem(dir.path());
  EXPECT_THAT(msg, HasSubstr("slice_2.tif: cannot read as TIFF"));
  expect_one_line(msg);
}

TEST(CtBadInputImage, TruncatedTiffPixels) {
  test::TempDir dir;
  write_u16(dir / "slice_1.tif", 64, 64);
  write_u16(dir / "slice_2.tif", 64, 64);
  test::write_file(dir / "sawyer_stack.json", kSpacing);
  // OpenImageIO writes the directory first and the uncompressed strips after it: cut the strips
  // short, so the header opens and the pixel read comes up short.
  const std::string bytes = file_bytes(dir / "slice_2.tif");
  test::write_file(dir / "slice_2.tif", bytes.substr(0, bytes.size() - 3000));
  const std::string msg = problem(dir.path());
  EXPECT_THAT(msg, HasSubstr("slice_2.tif: corrupt or truncated image data"));
  expect_one_line(msg);
}

TEST(CtBadInputImage, TruncatedPng) {
  test::TempDir dir;
  std::vector<uint16_t> px(64 * 64);
  for (size_t p = 0; p < px.size(); ++p) px[p] = static_cast<uint16_t>(p * 2654435761u >> 16);
  write_image(dir / "s1.png", 64, 64, 1, OIIO::TypeDesc::UINT16, px);
  write_image(dir / "s2.png", 64, 64, 1, OIIO::TypeDesc::UINT16, px);
  test::write_file(dir / "sawyer_stack.json", kSpacing);
  const std::string bytes = file_bytes(dir / "s2.png");
  test::write_file(dir / "s2.png", bytes.substr(0, bytes.size() / 2));
  const std::string msg = problem(dir.path());
  EXPECT_THAT(msg, HasSubstr("s2.png"));
  expect_one_line(msg);
}

TEST(CtBadInputImage, MixedImageSizesNameBothFiles) {
  test::TempDir dir;
  write_u16(dir / "slice_1.tif", 16, 12);
  write_u16(dir / "slice_2.tif", 16, 12);
  write_u16(dir / "slice_3.tif", 20, 12);
  test::write_file(dir / "sawyer_stack.json", kSpacing);
  const std::string msg = problem(dir.path());
  EXPECT_THAT(msg,
              HasSubstr("mixed image sizes: slice_3.tif is 20 x 12 but slice_1.tif is 16 x 12"));
}

TEST(CtBadInputImage, MixedBitDepths) {
  test::TempDir dir;
  write_u16(dir / "slice_1.tif");
  write_image(dir / "slice_2.tif", 16, 12, 1, OIIO::TypeDesc::UINT8, std::vector<uint8_t>(192, 3));
  test::write_file(dir / "sawyer_stack.json", kSpacing);
  const std::string msg = problem(dir.path());
  EXPECT_THAT(msg, HasSubstr("mixed pixel types: slice_2.tif is 8-bit unsigned but slice_1.tif "
                             "is 16-bit unsigned"));
}

TEST(CtBadInputImage, ZeroSpacingInSidecar) {
  test::TempDir dir;
  good_stack(dir.path());
  test::write_file(dir / "sawyer_stack.json", R"({"pixel_spacing_mm": 0, "slice_spacing_mm": 1})");
  const std::string msg = problem(dir.path());
  EXPECT_THAT(msg, HasSubstr("sawyer_stack.json: \"pixel_spacing_mm\" must be positive, got 0"));
}

TEST(CtBadInputImage, NegativeSliceSpacingInSidecar) {
  test::TempDir dir;
  good_stack(dir.path());
  test::write_file(dir / "sawyer_stack.json", R"({"pixel_spacing_mm": 1, "slice_spacing_mm": -2})");
  EXPECT_THAT(problem(dir.path()), HasSubstr("\"slice_spacing_mm\" must be positive, got -2"));
}

TEST(CtBadInputImage, ZeroPixelSpacingOption) {
  test::TempDir dir;
  good_stack(dir.path());
  OpenOptions o;
  o.pixel_spacing = 0;
  EXPECT_THAT(problem(dir.path(), o),
              HasSubstr("OpenOptions::pixel_spacing must be a positive number of mm, got 0"));
}

TEST(CtBadInputImage, NegativeSliceSpacingOption) {
  test::TempDir dir;
  good_stack(dir.path());
  OpenOptions o;
  o.slice_spacing = -1.5;
  EXPECT_THAT(problem(dir.path(), o),
              HasSubstr("OpenOptions::slice_spacing must be a positive number of mm, got -1.5"));
}

TEST(CtBadInputImage, SingleSlice) {
  test::TempDir dir;
  write_u16(dir / "only.tif");
  test::write_file(dir / "sawyer_stack.json", kSpacing);
  const std::string msg = problem(dir.path());
  EXPECT_THAT(msg, HasSubstr("needs at least 2 slices, found 1 (only.tif)"));
}

TEST(CtBadInputImage, SinglePngSlice) {
  test::TempDir dir;
  write_image(dir / "only.png", 8, 8, 1, OIIO::TypeDesc::UINT16, std::vector<uint16_t>(64, 1));
  EXPECT_THAT(problem(dir.path()), HasSubstr("needs at least 2 slices"));
}

TEST(CtBadInputImage, EightBitWithoutRescale) {
  test::TempDir dir;
  for (const char* n : {"a1.png", "a2.png"})
    write_image(dir / n, 8, 8, 1, OIIO::TypeDesc::UINT8, std::vector<uint8_t>(64, 9));
  test::write_file(dir / "sawyer_stack.json", kSpacing);
  const std::string msg = problem(dir.path());
  EXPECT_THAT(msg, HasSubstr("a1.png"));
  EXPECT_THAT(
      msg,
      HasSubstr(
          "8-bit slices carry no HU scale: give rescale_slope/rescale_intercept "
          "in sawyer_stack.json or OpenOptions::rescale_slope/OpenOptions::rescale_intercept"));
}

TEST(CtBadInputImage, NanInFloatTiff) {
  test::TempDir dir;
  std::vector<float> px(16 * 12, -1000.0f);
  write_image(dir / "f1.tif", 16, 12, 1, OIIO::TypeDesc::FLOAT, px);
  px[3 * 16 + 5] = std::numeric_limits<float>::quiet_NaN();
  write_image(dir / "f2.tif", 16, 12, 1, OIIO::TypeDesc::FLOAT, px);
  test::write_file(dir / "sawyer_stack.json", kSpacing);
  const std::string msg = problem(dir.path());
  EXPECT_THAT(msg, HasSubstr("f2.tif: slice 1: value NaN at pixel (5, 3)"));
}

TEST(CtBadInputImage, ColourChannelsThatDiffer) {
  test::TempDir dir;
  std::vector<uint16_t> grey(8 * 6 * 3, 1500);
  write_image(dir / "c1.png", 8, 6, 3, OIIO::TypeDesc::UINT16, grey);
  std::vector<uint16_t> colour = grey;
  colour[(2 * 8 + 4) * 3 + 1] = 900;  // green differs at (4, 2)
  write_image(dir / "c2.png", 8, 6, 3, OIIO::TypeDesc::UINT16, colour);
  test::write_file(dir / "sawyer_stack.json", kSpacing);
  const std::string msg = problem(dir.path());
  EXPECT_THAT(msg, HasSubstr("c2.png: slice 1: colour image (3 channels) with differing channels "
                             "at pixel (4, 2); CT slices must be grey"));
}

TEST(CtBadInputImage, MalformedSidecarJson) {
  test::TempDir dir;
  good_stack(dir.path());
  test::write_file(dir / "sawyer_stack.json", R"({"pixel_spacing_mm": 0.5,)");
  const std::string msg = problem(dir.path());
  EXPECT_THAT(msg, HasSubstr("sawyer_stack.json: not valid JSON"));
  expect_one_line(msg);
}

TEST(CtBadInputImage, MalformedSidecarKeyIsNamed) {
  test::TempDir dir;
  good_stack(dir.path());
  test::write_file(dir / "sawyer_stack.json",
                   R"({"pixel_spacing_mm": 0.5, "slice_spacing_mm": 1, "rescale_slope": "one"})");
  EXPECT_THAT(problem(dir.path()),
              HasSubstr("\"rescale_slope\" must be a non-zero number, got \"one\""));
}

TEST(CtBadInputImage, SidecarOrientationNotUnit) {
  test::TempDir dir;
  good_stack(dir.path());
  test::write_file(
      dir / "sawyer_stack.json",
      R"({"pixel_spacing_mm": 0.5, "slice_spacing_mm": 1, "orientation": [1, 0, 0, 1, 0, 0]})");
  EXPECT_THAT(problem(dir.path()),
              HasSubstr("\"orientation\" must hold two perpendicular unit vectors"));
}

TEST(CtBadInputImage, SidecarZPositionsCountMismatch) {
  test::TempDir dir;
  good_stack(dir.path());
  test::write_file(dir / "sawyer_stack.json", R"({"pixel_spacing_mm": 0.5, "z_mm": [0, 1, 2]})");
  EXPECT_THAT(problem(dir.path()), HasSubstr("\"z_mm\" has 3 positions for 2 slices"));
}

TEST(CtBadInputImage, SidecarZPositionsNotIncreasing) {
  test::TempDir dir;
  good_stack(dir.path());
  test::write_file(dir / "sawyer_stack.json", R"({"pixel_spacing_mm": 0.5, "z_mm": [3, 1]})");
  EXPECT_THAT(problem(dir.path()), HasSubstr("\"z_mm\" must increase strictly"));
}

TEST(CtBadInputImage, SidecarListsAMissingFile) {
  test::TempDir dir;
  good_stack(dir.path());
  test::write_file(dir / "sawyer_stack.json", R"({"pixel_spacing_mm": 0.5, "slice_spacing_mm": 1, )"
                                              R"("files": ["slice_1.tif", "slice_9.tif"]})");
  EXPECT_THAT(problem(dir.path()),
              HasSubstr("\"files\" names slice_9.tif, which is not a file in"));
}

TEST(CtBadInputImage, NoSpacingSaysHowToGiveIt) {
  test::TempDir dir;
  write_u16(dir / "slice_1.tif");
  write_u16(dir / "slice_2.tif");
  const std::string msg = problem(dir.path());
  EXPECT_THAT(msg, HasSubstr("no pixel spacing: put \"pixel_spacing_mm\" in sawyer_stack.json "
                             "beside the slices or give OpenOptions::pixel_spacing (mm)"));
  OpenOptions o;
  o.pixel_spacing = 0.5;
  EXPECT_THAT(problem(dir.path(), o), HasSubstr("no slice spacing: put \"slice_spacing_mm\" (or "
                                                "\"z_mm\") in sawyer_stack.json"));
}

TEST(CtBadInputImage, MixedTiffAndPng) {
  test::TempDir dir;
  good_stack(dir.path());
  write_image(dir / "slice_3.png", 16, 12, 1, OIIO::TypeDesc::UINT16,
              std::vector<uint16_t>(192, 1));
  EXPECT_THAT(problem(dir.path()), HasSubstr("mixes TIFF (2) and PNG (1) files"));
}

TEST(CtBadInputImage, PngNamedTiff) {
  test::TempDir dir;
  good_stack(dir.path());
  write_image(dir / "x.png", 16, 12, 1, OIIO::TypeDesc::UINT16, std::vector<uint16_t>(192, 1));
  fs::rename(dir / "x.png", dir / "slice_2.tif");
  const std::string msg = problem(dir.path());
  EXPECT_THAT(msg, HasSubstr("slice_2.tif: cannot read as TIFF"));
}

// ---------------------------------------------------------------------------------------------
// Volume files

TEST(CtBadInputImage, MetaImageWithoutDimSize) {
  test::TempDir dir;
  test::write_file(dir / "v.mha",
                   "ObjectType = Image\nNDims = 3\nElementSpacing = 1 1 1\n"
                   "ElementType = MET_SHORT\nElementDataFile = LOCAL\n" +
                       std::string(400, '\0'));
  const std::string msg = problem(dir / "v.mha");
  EXPECT_THAT(msg, HasSubstr("v.mha: corrupt MetaImage header: missing DimSize"));
}

TEST(CtBadInputImage, MetaImageTruncatedData) {
  test::TempDir dir;
  test::write_file(dir / "v.mha",
                   "NDims = 3\nDimSize = 64 64 10\nElementSpacing = 1 1 1\n"
                   "ElementType = MET_SHORT\nElementDataFile = LOCAL\n" +
                       std::string(1000, '\0'));
  const std::string msg = problem(dir / "v.mha");
  EXPECT_THAT(msg, HasSubstr("v.mha: truncated: the header declares 64 x 64 x 10 16-bit signed "
                             "samples (81920 bytes) but v.mha holds 1000"));
}

TEST(CtBadInputImage, MetaImageZeroSpacing) {
  test::TempDir dir;
  test::write_file(dir / "v.mha",
                   "NDims = 3\nDimSize = 16 16 2\nElementSpacing = 1 0 1\n"
                   "ElementType = MET_SHORT\nElementDataFile = LOCAL\n" +
                       std::string(1024, '\0'));
  EXPECT_THAT(problem(dir / "v.mha"), HasSubstr("ElementSpacing must be positive, got 1 0 1"));
}

TEST(CtBadInputImage, MetaImageHugeDimSizeInATinyFile) {
  test::TempDir dir;
  test::write_file(dir / "v.mha",
                   "NDims = 3\nDimSize = 8000 8000 100000\nElementSpacing = 1 1 1\n"
                   "CompressedData = True\nElementType = MET_SHORT\n"
                   "ElementDataFile = LOCAL\nxxxx");
  EXPECT_THAT(problem(dir / "v.mha"), HasSubstr("v.mha: corrupt: the header declares"));
}

TEST(CtBadInputImage, MetaImageOverlongHeaderLine) {
  // vtkmetaio strcpy()s key names into 255-byte fields; such headers never reach it.
  test::TempDir dir;
  test::write_file(dir / "v.mha", "ObjectType = Image\nNDims = 3\nCompressedData = True\n" +
                                      std::string(300, 'K') +
                                      " = 1\nDimSize = 4 4 2\nElementSpacing = 1 1 1\n"
                                      "ElementType = MET_SHORT\nElementDataFile = LOCAL\nxx");
  EXPECT_THAT(problem(dir / "v.mha"),
              HasSubstr("v.mha: corrupt MetaImage header (a line longer than 255 characters)"));
}

TEST(CtBadInputImage, VtiCompressedBlockCountBeyondTheFile) {
  // VTK would allocate a table for the declared block count before reading anything.
  test::TempDir dir;
  const uint32_t header[3] = {1000000000u, 32768u, 100u};
  write_bytes(dir / "c.vti",
              "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\" version=\"0.1\" "
              "byte_order=\"LittleEndian\" header_type=\"UInt32\" "
              "compressor=\"vtkZLibDataCompressor\">\n<ImageData WholeExtent=\"0 19 0 15 0 4\" "
              "Origin=\"0 0 0\" Spacing=\"1 1 1\">\n<Piece Extent=\"0 19 0 15 0 4\">"
              "<PointData Scalars=\"s\"><DataArray type=\"Int16\" Name=\"s\" "
              "format=\"appended\" offset=\"0\"/></PointData></Piece>\n</ImageData>\n"
              "<AppendedData encoding=\"raw\">\n_",
              header, sizeof header);
  EXPECT_THAT(problem(dir / "c.vti"),
              HasSubstr("c.vti: corrupt: a compressed array declares 1000000000 blocks"));
}

TEST(CtBadInputImage, VtiXmlGarbage) {
  test::TempDir dir;
  test::write_file(dir / "v.vti",
                   "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\" version=\"1.0\">"
                   "<ImageData WholeExtent=\"0 9 0 9 0 3\" <<<>>> garbage &&&");
  const std::string msg = problem(dir / "v.vti");
  EXPECT_THAT(msg, HasSubstr("v.vti: corrupt VTK image file"));
  expect_one_line(msg);
}

TEST(CtBadInputImage, VtiNotXmlAtAll) {
  test::TempDir dir;
  test::write_file(dir / "v.vti", std::string("\x89PNG\r\n\x1a\n", 8) + std::string(100, 'x'));
  EXPECT_THAT(problem(dir / "v.vti"), HasSubstr("v.vti: not a VTK XML file"));
}

TEST(CtBadInputImage, VtiExtentLargerThanTheFile) {
  test::TempDir dir;
  // Written by Sawyer, then the declared extent inflated: the data cannot be there.
  VolumeGeometry g;
  g.width = g.height = 8;
  g.spacing_x = g.spacing_y = 1;
  g.z = {0, 1, 2};
  WriteOptions o;
  o.format = Format::kVti;
  auto sink = create_ct_writer(dir / "v", g, o);
  ASSERT_TRUE(sink.ok());
  Slice s;
  s.width = s.height = 8;
  s.hu.assign(64, 0.0f);
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(sink.value()->write(s).ok());
  ASSERT_TRUE(sink.value()->finish().ok());
  std::string text = file_bytes(dir / "v" / "volume.vti");
  for (size_t at = text.find("0 7 0 7 0 2"); at != std::string::npos; at = text.find("0 7 0 7 0 2"))
    text.replace(at, 11, "0 7 0 7 0 99999");
  test::write_file(dir / "v" / "volume.vti", text);
  const std::string msg = problem(dir / "v" / "volume.vti");
  EXPECT_THAT(msg, HasSubstr("volume.vti"));
  EXPECT_THAT(msg, HasSubstr("truncated or corrupt"));
}

TEST(CtBadInputImage, NanInVolume) {
  test::TempDir dir;
  std::vector<float> v(16 * 12 * 3, 20.0f);
  v[2 * 16 * 12 + 7 * 16 + 11] = std::numeric_limits<float>::infinity();
  write_bytes(dir / "f.mha",
              "NDims = 3\nDimSize = 16 12 3\nElementSpacing = 1 1 1\n"
              "ElementType = MET_FLOAT\nElementDataFile = LOCAL\n",
              v.data(), v.size() * 4);
  EXPECT_THAT(problem(dir / "f.mha"), HasSubstr("f.mha: slice 2: value inf at pixel (11, 7)"));
}

TEST(CtBadInputImage, EightBitVolumeWithoutRescale) {
  test::TempDir dir;
  std::vector<uint8_t> v(16 * 12 * 2, 1);
  write_bytes(dir / "b.nrrd",
              "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 16 12 2\nspacings: 1 1 1\n"
              "encoding: raw\n\n",
              v.data(), v.size());
  EXPECT_THAT(problem(dir / "b.nrrd"),
              HasSubstr("b.nrrd: 8-bit volume carries no HU scale: give "
                        "OpenOptions::rescale_slope/OpenOptions::rescale_intercept"));
}

TEST(CtBadInputImage, SingleSliceVolume) {
  test::TempDir dir;
  std::vector<int16_t> v(16 * 12, 1);
  write_bytes(dir / "one.nrrd",
              "NRRD0004\ntype: short\ndimension: 3\nsizes: 16 12 1\nspacings: 1 1 1\n"
              "endian: little\nencoding: raw\n\n",
              v.data(), v.size() * 2);
  EXPECT_THAT(problem(dir / "one.nrrd"), HasSubstr("one.nrrd: needs at least 2 slices"));
}

TEST(CtBadInputImage, NrrdAsciiEncoding) {
  test::TempDir dir;
  test::write_file(dir / "a.nrrd",
                   "NRRD0004\ntype: short\ndimension: 3\nsizes: 16 12 2\n"
                   "spacings: 1 1 1\nencoding: ascii\n\n1 2 3\n");
  EXPECT_THAT(problem(dir / "a.nrrd"),
              HasSubstr("a.nrrd: NRRD encoding \"ascii\" is not supported"));
}

TEST(CtBadInputImage, NrrdDataFilePatternIsRefused) {
  // vtkNrrdReader would pass the pattern to snprintf as a format string.
  test::TempDir dir;
  test::write_file(dir / "p.nhdr",
                   "NRRD0004\ntype: short\ndimension: 3\nsizes: 16 12 2\n"
                   "spacings: 1 1 1\nencoding: raw\ndata file: %s%s%s%n 1 2 1\n");
  EXPECT_THAT(problem(dir / "p.nhdr"), HasSubstr("p.nhdr: NRRD data split over several files"));
}

TEST(CtBadInputImage, NrrdNegativeSpacing) {
  test::TempDir dir;
  std::vector<int16_t> v(16 * 12 * 2, 1);
  write_bytes(dir / "n.nrrd",
              "NRRD0004\ntype: short\ndimension: 3\nsizes: 16 12 2\nspacings: 1 -1 1\n"
              "endian: little\nencoding: raw\n\n",
              v.data(), v.size() * 2);
  EXPECT_THAT(problem(dir / "n.nrrd"), HasSubstr("n.nrrd: spacing must be positive"));
}

TEST(CtBadInputImage, VolumeWriterRefusesNaN) {
  test::TempDir dir;
  VolumeGeometry g;
  g.width = g.height = 4;
  g.spacing_x = g.spacing_y = 1;
  g.z = {0, 1};
  WriteOptions o;
  o.format = Format::kMetaImage;
  auto sink = create_ct_writer(dir / "v", g, o);
  ASSERT_TRUE(sink.ok());
  Slice s;
  s.width = s.height = 4;
  s.hu.assign(16, 0.0f);
  s.hu[6] = std::numeric_limits<float>::quiet_NaN();
  Status st = sink.value()->write(s);
  ASSERT_FALSE(st.ok());
  EXPECT_THAT(st.error().message(), HasSubstr("slice 0: HU value nan at pixel (2, 1)"));
}

}  // namespace
}  // namespace sawyer::ct

// Bad DICOM input: one test per case. Each asserts that open_ct() (or read()) returns one line
// naming the file (or folder) and the problem, returns no source, and leaves the input untouched.
// Cases start from a good series written by Sawyer and are broken with GDCM's own API.
#include <gdcmAttribute.h>
#include <gdcmDataElement.h>
#include <gdcmDataSet.h>
#include <gdcmImageChangeTransferSyntax.h>
#include <gdcmImageReader.h>
#include <gdcmImageWriter.h>
#include <gdcmReader.h>
#include <gdcmTransferSyntax.h>
#include <gdcmWriter.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <string>

#include "sawyer/ct/io/slice_sink.h"
#include "sawyer/ct/io/slice_source.h"
#include "sawyer/test/test_util.h"

namespace sawyer::ct {
namespace {

namespace fs = std::filesystem;
using sawyer::test::TempDir;
using ::testing::AllOf;
using ::testing::HasSubstr;

// A good series: n slices of w x h, 2 mm apart, HU = 10 * index.
void write_series(const fs::path& out, int n = 4, int w = 8, int h = 6,
                  unsigned long long seed = 1) {
  VolumeGeometry g;
  g.width = w;
  g.height = h;
  g.spacing_x = 0.5;
  g.spacing_y = 0.5;
  for (int i = 0; i < n; ++i) g.z.push_back(2.0 * i);
  WriteOptions o;
  o.uid_seed = seed;
  auto sink = create_ct_writer(out, g, o);
  ASSERT_TRUE(sink) << sink.error().message();
  Slice s;
  s.width = w;
  s.height = h;
  for (int i = 0; i < n; ++i) {
    s.index = i;
    s.hu.assign(static_cast<size_t>(w) * h, 10.0f * i);
    ASSERT_TRUE(sink.value()->write(s));
  }
  ASSERT_TRUE(sink.value()->finish());
}

// Rewrites one file after `edit` changed its data set.
void edit_dicom(const fs::path& file, const std::function<void(gdcm::DataSet&)>& edit) {
  gdcm::Reader r;
  r.SetFileName(file.c_str());
  ASSERT_TRUE(r.Read()) << file;
  gdcm::File& f = r.GetFile();  // a reference: gdcm::File is reference counted
  edit(f.GetDataSet());
  gdcm::Writer w;
  w.SetFile(f);
  w.SetFileName(file.c_str());
  ASSERT_TRUE(w.Write()) << file;
}

void set_text(gdcm::DataSet& ds, uint16_t g, uint16_t e, const std::string& value) {
  gdcm::DataElement de = ds.GetDataElement(gdcm::Tag(g, e));
  std::string v = value;
  if (v.size() % 2) v.push_back(' ');
  de.SetByteValue(v.data(), static_cast<uint32_t>(v.size()));
  ds.Replace(de);
}

std::string read_bytes(const fs::path& f) {
  std::ifstream in(f, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Name and size of every entry under `dir`: what "nothing was written" compares.
std::map<std::string, uintmax_t> snapshot(const fs::path& dir) {
  std::map<std::string, uintmax_t> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    std::error_code ec;
    out[e.path().string()] = e.is_regular_file(ec) ? e.file_size(ec) : 0;
  }
  return out;
}

// Opens `path`, expects one error line containing every piece of `needles`, no source, and the
// folder unchanged.
void expect_refused(const fs::path& path, const std::vector<std::string>& needles,
                    OpenOptions options = {}) {
  const fs::path dir = fs::is_directory(path) ? path : path.parent_path();
  const auto before = snapshot(dir);
  auto r = open_ct(path, options);
  ASSERT_FALSE(r) << "opened, but expected a refusal containing " << needles.front();
  const std::string& m = r.error().message();
  for (const std::string& n : needles) EXPECT_THAT(m, HasSubstr(n));
  EXPECT_EQ(m.find('\n'), std::string::npos) << "not one line: " << m;
  EXPECT_EQ(snapshot(dir), before) << "the input folder changed";
}

TEST(DicomBadInput, EmptyFolder) {
  TempDir tmp;
  fs::create_directories(tmp / "empty");
  expect_refused(tmp / "empty", {(tmp / "empty").string() + ": the folder is empty"});
}

TEST(DicomBadInput, EmptyFile) {
  TempDir tmp;
  write_series(tmp / "s");
  sawyer::test::write_file(tmp / "s" / "slice_0009.dcm", "");
  expect_refused(tmp / "s", {(tmp / "s" / "slice_0009.dcm").string() + ": empty file"});
}

// Running as root makes permissions moot, so the portable case is a link that cannot be
// followed (a loop); the permission case runs too when the tests are not root.
TEST(DicomBadInput, UnreadableFile) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path loop = tmp / "s" / "slice_0005.dcm";
  fs::create_symlink(loop.filename(), loop);
  expect_refused(tmp / "s", {loop.string() + ": cannot read: ", "symbolic links"});
  fs::remove(loop);
  if (geteuid() != 0) {
    const fs::path locked = tmp / "s" / "slice_0002.dcm";
    ASSERT_EQ(::chmod(locked.c_str(), 0), 0);
    expect_refused(tmp / "s", {locked.string() + ": cannot read: Permission denied"});
    ::chmod(locked.c_str(), 0644);
  }
}

TEST(DicomBadInput, TruncatedPixelData) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0003.dcm";
  const uintmax_t size = fs::file_size(f);
  fs::resize_file(f, size - 30);
  expect_refused(tmp / "s", {f.string() + ": truncated: the pixel data needs 96 bytes from byte ",
                             "but the file ends at byte " + std::to_string(size - 30)});
}

TEST(DicomBadInput, PixelDataShorterThanTheImage) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0002.dcm";
  edit_dicom(f, [](gdcm::DataSet& ds) {
    gdcm::DataElement pd = ds.GetDataElement(gdcm::Tag(0x7fe0, 0x0010));
    const std::string bytes(40, '\0');
    pd.SetByteValue(bytes.data(), 40);
    ds.Replace(pd);
  });
  expect_refused(tmp / "s", {f.string() + ": Pixel Data holds 40 bytes, expected 96 "
                                          "(8 x 6 x 16 bits)"});
}

TEST(DicomBadInput, GarbageAfterPreamble) {
  TempDir tmp;
  write_series(tmp / "s");
  std::string junk(128, '\0');
  junk += "DICM";
  std::mt19937 rng(3);
  for (int i = 0; i < 2000; ++i) junk.push_back(static_cast<char>(rng()));
  const fs::path f = tmp / "s" / "slice_0099.dcm";
  sawyer::test::write_file(f, junk);
  expect_refused(tmp / "s", {f.string() + ": corrupt DICOM"});
}

TEST(DicomBadInput, UnsupportedTransferSyntax) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0002.dcm";
  std::string bytes = read_bytes(f);
  // Same length, so the meta header stays well formed: Explicit VR Little Endian becomes a UID
  // no codec knows.
  const std::string from("1.2.840.10008.1.2.1\0", 20), to("1.2.840.10008.1.2.9\0", 20);
  const size_t at = bytes.find(from);
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at, from.size(), to);
  sawyer::test::write_file(f, bytes);
  expect_refused(tmp / "s", {f.string() + ": unsupported transfer syntax 1.2.840.10008.1.2.9"});
}

TEST(DicomBadInput, TruncatedHeader) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0004.dcm";
  fs::resize_file(f, 300);  // inside the data set, long before the pixels
  expect_refused(tmp / "s", {f.string() + ": "});
}

// Converts a series written by Sawyer to RLE Lossless with GDCM.
void convert_to_rle(const fs::path& dir, int n) {
  for (int i = 1; i <= n; ++i) {
    const fs::path f = dir / (std::string("slice_000") + std::to_string(i) + ".dcm");
    gdcm::ImageReader r;
    r.SetFileName(f.c_str());
    ASSERT_TRUE(r.Read());
    gdcm::ImageChangeTransferSyntax change;
    change.SetTransferSyntax(gdcm::TransferSyntax::RLELossless);
    change.SetInput(r.GetImage());
    ASSERT_TRUE(change.Change());
    gdcm::ImageWriter w;
    w.SetFile(r.GetFile());
    w.SetImage(change.GetOutput());
    w.SetFileName(f.c_str());
    ASSERT_TRUE(w.Write());
  }
}

TEST(DicomBadInput, TruncatedCompressedPixelData) {
  TempDir tmp;
  write_series(tmp / "s", 3, 32, 32);
  convert_to_rle(tmp / "s", 3);
  const fs::path bad = tmp / "s" / "slice_0002.dcm";
  fs::resize_file(bad, fs::file_size(bad) - 200);  // cut into the RLE segments
  expect_refused(tmp / "s", {bad.string() + ": truncated: a pixel data fragment of "});
}

// A well-formed file whose compressed stream is garbage can only be caught by decoding: open
// succeeds, read() of that slice fails with the file and the codec named, other slices read.
TEST(DicomBadInput, CorruptCompressedPixelData) {
  TempDir tmp;
  write_series(tmp / "s", 3, 32, 32);
  convert_to_rle(tmp / "s", 3);
  const fs::path bad = tmp / "s" / "slice_0002.dcm";
  std::string bytes = read_bytes(bad);
  // Pixel Data (OB, undefined length), an empty offset table item, then the one fragment,
  // which starts with the RLE header: the number of segments, then 15 offsets.
  const std::string start(
      "\xe0\x7f\x10\x00OB\0\0\xff\xff\xff\xff\xfe\xff\x00\xe0\0\0\0\0"
      "\xfe\xff\x00\xe0",
      24);
  const size_t at = bytes.find(start);
  ASSERT_NE(at, std::string::npos);
  const size_t rle_header = at + start.size() + 4;
  for (size_t k = 0; k < 64; ++k) bytes[rle_header + k] = static_cast<char>(0x7f);
  sawyer::test::write_file(bad, bytes);

  auto src = open_ct(tmp / "s");
  ASSERT_TRUE(src) << src.error().message();
  Slice s;
  ASSERT_TRUE(src.value()->read(0, s));
  const Status st = src.value()->read(1, s);
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message(),
              AllOf(HasSubstr(bad.string() + ": "), HasSubstr("RLE Lossless pixel data")));
  ASSERT_TRUE(src.value()->read(2, s));
  EXPECT_EQ(s.at(3, 3), 20.0f);
}

TEST(DicomBadInput, MixedImageSizes) {
  TempDir tmp;
  write_series(tmp / "s", 4, 8, 6, 5);
  write_series(tmp / "t", 4, 6, 6, 5);  // same seed: the same series UID
  fs::rename(tmp / "t" / "slice_0003.dcm", tmp / "s" / "odd.dcm");
  expect_refused(tmp / "s", {(tmp / "s" / "odd.dcm").string() +
                             ": 6 x 6 pixels, but slice_0001.dcm in the same series is 8 x 6 "
                             "(mixed image sizes)"});
}

TEST(DicomBadInput, MixedSeries) {
  TempDir tmp;
  write_series(tmp / "s", 4, 8, 6, 1);
  write_series(tmp / "t", 3, 8, 6, 2);
  for (int i = 1; i <= 3; ++i)
    fs::rename(tmp / "t" / (std::string("slice_000") + std::to_string(i) + ".dcm"),
               tmp / "s" / (std::string("other_") + std::to_string(i) + ".dcm"));
  expect_refused(tmp / "s",
                 {(tmp / "s").string() + ": holds 2 DICOM series; choose one with "
                                         "OpenOptions::series (number or UID prefix): 1: 2.25.",
                  "\"Sawyer phantom\" CT, 4 files", "\"Sawyer phantom\" CT, 3 files"});
}

TEST(DicomBadInput, ZeroPixelSpacing) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0002.dcm";
  edit_dicom(f, [](gdcm::DataSet& ds) { set_text(ds, 0x0028, 0x0030, "0\\0.5"); });
  expect_refused(tmp / "s", {f.string() + ": Pixel Spacing \"0\\0.5\" must be positive (mm)"});
}

TEST(DicomBadInput, NegativePixelSpacing) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0001.dcm";
  edit_dicom(f, [](gdcm::DataSet& ds) { set_text(ds, 0x0028, 0x0030, "0.5\\-0.5"); });
  expect_refused(tmp / "s", {f.string() + ": Pixel Spacing \"0.5\\-0.5\" must be positive (mm)"});
}

TEST(DicomBadInput, UnparseablePixelSpacing) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0004.dcm";
  edit_dicom(f, [](gdcm::DataSet& ds) { set_text(ds, 0x0028, 0x0030, "0,5\\0,5"); });
  expect_refused(tmp / "s", {f.string() + ": Pixel Spacing \"0,5\\0,5\" is not two numbers"});
}

TEST(DicomBadInput, MissingPixelSpacing) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0003.dcm";
  edit_dicom(f, [](gdcm::DataSet& ds) { ds.Remove(gdcm::Tag(0x0028, 0x0030)); });
  expect_refused(tmp / "s", {f.string() + ": no Pixel Spacing (0028,0030)"});
}

TEST(DicomBadInput, DuplicatePositions) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0003.dcm";
  edit_dicom(f, [](gdcm::DataSet& ds) {
    set_text(ds, 0x0020, 0x0032, "0\\0\\2");  // slice_0002's position
  });
  expect_refused(tmp / "s", {(tmp / "s").string() + ": duplicate slice position z=2.000 mm: "
                                                    "slice_0002.dcm and slice_0003.dcm"});
}

TEST(DicomBadInput, SingleSlice) {
  TempDir tmp;
  write_series(tmp / "s", 1);
  expect_refused(tmp / "s", {(tmp / "s").string() + ": DICOM series 2.25.",
                             "has only 1 slice (slice_0001.dcm); a CT volume needs at least 2 "
                             "slices"});
}

TEST(DicomBadInput, InconsistentOrientation) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0004.dcm";
  edit_dicom(f, [](gdcm::DataSet& ds) { set_text(ds, 0x0020, 0x0037, "1\\0\\0\\0\\0\\-1"); });
  expect_refused(tmp / "s", {f.string() + ": Image Orientation (Patient) \"1\\0\\0\\0\\0\\-1\" "
                                          "differs from slice_0001.dcm (\"1\\0\\0\\0\\1\\0\"): "
                                          "inconsistent orientation within the series"});
}

TEST(DicomBadInput, OrientationNotOrthonormal) {
  TempDir tmp;
  write_series(tmp / "s");
  for (int i = 1; i <= 4; ++i)
    edit_dicom(tmp / "s" / (std::string("slice_000") + std::to_string(i) + ".dcm"),
               [](gdcm::DataSet& ds) { set_text(ds, 0x0020, 0x0037, "1\\0\\0\\1\\0\\0"); });
  expect_refused(tmp / "s", {(tmp / "s" / "slice_0001.dcm").string() +
                             ": Image Orientation (Patient) \"1\\0\\0\\1\\0\\0\" is not two "
                             "orthogonal unit vectors"});
}

TEST(DicomBadInput, NoPositionAndNoSliceLocation) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0002.dcm";
  edit_dicom(f, [](gdcm::DataSet& ds) {
    ds.Remove(gdcm::Tag(0x0020, 0x0032));
    ds.Remove(gdcm::Tag(0x0020, 0x1041));
  });
  expect_refused(tmp / "s", {f.string() + ": neither Image Position (Patient) nor Slice "
                                          "Location; cannot order the slices"});
}

TEST(DicomBadInput, ColourImage) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0001.dcm";
  edit_dicom(f, [](gdcm::DataSet& ds) {
    ds.Replace(gdcm::Attribute<0x0028, 0x0002>{3}.GetAsDataElement());
    set_text(ds, 0x0028, 0x0004, "RGB");
  });
  expect_refused(tmp / "s", {f.string() + ": Photometric Interpretation RGB with 3 samples per "
                                          "pixel: not a grey-scale CT slice"});
}

TEST(DicomBadInput, MultiFrame) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0001.dcm";
  edit_dicom(f, [](gdcm::DataSet& ds) {
    ds.Replace(gdcm::Attribute<0x0028, 0x0008>{12}.GetAsDataElement());
  });
  expect_refused(tmp / "s", {f.string() + ": multi-frame DICOM (12 frames in one file) is not "
                                          "supported"});
}

TEST(DicomBadInput, ZeroRescaleSlope) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0003.dcm";
  edit_dicom(f, [](gdcm::DataSet& ds) { set_text(ds, 0x0028, 0x1053, "0"); });
  expect_refused(tmp / "s", {f.string() + ": Rescale Slope \"0\" cannot map stored values to HU"});
}

TEST(DicomBadInput, UnsupportedBitsAllocated) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0002.dcm";
  edit_dicom(f, [](gdcm::DataSet& ds) {
    ds.Replace(gdcm::Attribute<0x0028, 0x0100>{32}.GetAsDataElement());
  });
  expect_refused(tmp / "s", {f.string() + ": Bits Allocated 32 is not supported (8 or 16)"});
}

// A DICOM file without pixels among the slices (a dose report, a DICOMDIR) is skipped with a
// note; a folder of nothing but such files is refused.
TEST(DicomBadInput, FilesWithoutPixelsAreSkippedOrRefused) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "report.dcm";
  fs::copy_file(tmp / "s" / "slice_0001.dcm", f);
  edit_dicom(f, [](gdcm::DataSet& ds) {
    ds.Remove(gdcm::Tag(0x7fe0, 0x0010));
    ds.Remove(gdcm::Tag(0x0028, 0x0010));
    ds.Remove(gdcm::Tag(0x0028, 0x0011));
  });
  auto src = open_ct(tmp / "s");
  ASSERT_TRUE(src) << src.error().message();
  EXPECT_THAT(src.value()->notes(),
              ::testing::Contains("ignored 1 DICOM file without image data: report.dcm"));

  fs::create_directories(tmp / "only");
  fs::rename(f, tmp / "only" / "report.dcm");
  expect_refused(tmp / "only", {(tmp / "only").string() + ": no DICOM images found"});
  expect_refused(tmp / "only" / "report.dcm", {"report.dcm: no DICOM images found"});
}

TEST(DicomBadInput, RowsWithoutPixelData) {
  TempDir tmp;
  write_series(tmp / "s");
  const fs::path f = tmp / "s" / "slice_0002.dcm";
  edit_dicom(f, [](gdcm::DataSet& ds) { ds.Remove(gdcm::Tag(0x7fe0, 0x0010)); });
  expect_refused(tmp / "s", {f.string() + ": no Pixel Data (truncated file?)"});
}

// Inputs the fuzzer found (tests/corpus/ct_dicom/fuzz_findings): each once made GDCM abort
// (an assertion in its libjpeg wrapper) or leak (its JPEG-LS and PVRG paths). Beside a valid
// slice of their series (as in the fuzz target) each must now give one error naming the file,
// at open or at read, and never bring the process down.
TEST(DicomBadInput, FuzzFindingsGiveErrorsNotCrashes) {
  const fs::path findings = sawyer::test::source_dir() / "tests/corpus/ct_dicom/fuzz_findings";
  int cases = 0;
  for (const auto& e : fs::directory_iterator(findings)) {
    TempDir tmp;
    write_series(tmp / "stage", 1, 32, 32, 7);  // the fuzz target's companion slice
    fs::rename(tmp / "stage" / "slice_0001.dcm", tmp / "companion.dcm");
    fs::remove_all(tmp / "stage");
    const fs::path input = tmp / "input.dcm";
    fs::copy_file(e.path(), input);
    ++cases;
    auto src = open_ct(tmp.path());
    if (!src) {
      EXPECT_THAT(src.error().message(), HasSubstr("input.dcm: ")) << e.path();
      continue;
    }
    bool failed = false;
    Slice s;
    for (int i = 0; i < src.value()->geometry().slice_count(); ++i) {
      const Status st = src.value()->read(i, s);
      if (!st) {
        failed = true;
        EXPECT_THAT(st.error().message(), HasSubstr("input.dcm: ")) << e.path();
      }
    }
    EXPECT_TRUE(failed) << e.path() << " read without an error";
  }
  EXPECT_EQ(cases, 4);
}

TEST(DicomBadInput, UnknownSeriesOption) {
  TempDir tmp;
  write_series(tmp / "s");
  OpenOptions o;
  o.series = "1.2.3";
  expect_refused(tmp / "s",
                 {(tmp / "s").string() + ": no DICOM series matches OpenOptions::series "
                                         "\"1.2.3\"; the folder holds: 1: 2.25."},
                 o);
}

}  // namespace
}  // namespace sawyer::ct

// Limits on CT input (sawyer/ct/io/limits.h): spacing, size, field of view, z extent and memory,
// checked where each value enters and once more in open_ct; how much resampling along z may
// invent; what a scan folder holds for the readers and the checksum (no link loops, no FIFOs).
// Each case asserts the refusal, one line naming the file (or option) and the value, and that a
// nearby good input still opens. Bad DICOM is made with GDCM's API from a series Sawyer wrote.
#include <fcntl.h>
#include <gdcmDataElement.h>
#include <gdcmDataSet.h>
#include <gdcmReader.h>
#include <gdcmWriter.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <string>
#include <tuple>
#include <vector>

#include "sawyer/ct/io/limits.h"
#include "sawyer/ct/io/slice_sink.h"
#include "sawyer/ct/io/slice_source.h"
#include "sawyer/register/ct_checksum.h"
#include "sawyer/test/test_util.h"

namespace sawyer::ct {
namespace {

namespace fs = std::filesystem;
using sawyer::test::TempDir;
using ::testing::HasSubstr;

VolumeGeometry geometry(int n, double dz, int w = 8, int h = 6, double px = 0.5) {
  VolumeGeometry g;
  g.width = w;
  g.height = h;
  g.spacing_x = g.spacing_y = px;
  for (int i = 0; i < n; ++i) g.z.push_back(dz * i);
  return g;
}

// A good volume in `format`: HU = 10 * slice index.
void write_volume(const fs::path& out, const VolumeGeometry& g, Format format = Format::kDicom) {
  WriteOptions o;
  o.format = format;
  auto sink = create_ct_writer(out, g, o);
  ASSERT_TRUE(sink) << sink.error().message();
  Slice s;
  s.width = g.width;
  s.height = g.height;
  for (int i = 0; i < g.slice_count(); ++i) {
    s.index = i;
    s.hu.assign(static_cast<size_t>(g.width) * g.height, 10.0f * i);
    ASSERT_TRUE(sink.value()->write(s));
  }
  ASSERT_TRUE(sink.value()->finish());
}

fs::path dicom_file(const fs::path& dir, int one_based) {
  char name[32];
  std::snprintf(name, sizeof name, "slice_%04d.dcm", one_based);
  return dir / name;
}

void set_dicom_text(const fs::path& file, uint16_t group, uint16_t element, std::string value) {
  gdcm::Reader r;
  r.SetFileName(file.c_str());
  ASSERT_TRUE(r.Read()) << file;
  gdcm::File& f = r.GetFile();
  gdcm::DataElement de = f.GetDataSet().GetDataElement(gdcm::Tag(group, element));
  if (value.size() % 2) value.push_back(' ');
  de.SetByteValue(value.data(), static_cast<uint32_t>(value.size()));
  f.GetDataSet().Replace(de);
  gdcm::Writer w;
  w.SetFile(f);
  w.SetFileName(file.c_str());
  ASSERT_TRUE(w.Write()) << file;
}

// Expects open_ct to refuse with one line holding every needle.
void expect_refused(const fs::path& path, const std::vector<std::string>& needles,
                    const OpenOptions& options = {}) {
  auto r = open_ct(path, options);
  ASSERT_FALSE(r.ok()) << path << " opened; expected a refusal with " << needles.front();
  const std::string& m = r.error().message();
  for (const std::string& n : needles) EXPECT_THAT(m, HasSubstr(n));
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
}

void expect_opens(const fs::path& path, const OpenOptions& options = {}) {
  auto r = open_ct(path, options);
  ASSERT_TRUE(r.ok()) << r.error().message();
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// ---- DICOM ----------------------------------------------------------------------------------

TEST(CtLimits, DicomHugePixelSpacingIsRefusedNamingFileAndValue) {
  for (const char* value : {"1e300\\1e300", "0.5\\1e6"}) {
    TempDir tmp;
    write_volume(tmp / "s", geometry(4, 2.0));
    expect_opens(tmp / "s");
    const fs::path f = dicom_file(tmp / "s", 2);
    set_dicom_text(f, 0x0028, 0x0030, value);
    expect_refused(tmp / "s",
                   {f.string() + ": Pixel Spacing \"" + value + "\"", "is outside 0.01-50 mm"});
  }
}

// Issue 44: a rescale no scanner writes was printed by `sawyer info`, which exited 0.
TEST(CtLimits, DicomAbsurdRescaleIsRefusedNamingFileAndValue) {
  for (const auto& [tag, value, needle] :
       {std::tuple{std::uint16_t{0x1053}, "1e30", "Rescale slope 1e+30 is outside 0.0001-100000"},
        std::tuple{std::uint16_t{0x1053}, "1e-9", "Rescale slope 1e-09 is outside"},
        std::tuple{std::uint16_t{0x1052}, "-1e12", "Rescale intercept -1e+12 HU is outside"}}) {
    TempDir tmp;
    write_volume(tmp / "s", geometry(4, 2.0));
    const fs::path f = dicom_file(tmp / "s", 3);
    set_dicom_text(f, 0x0028, tag, value);
    expect_refused(tmp / "s", {f.string() + ": " + needle, "no CT scanner writes it"});
    std::string out;
    EXPECT_EQ(test::run_sawyer("info " + test::quoted(tmp / "s"), &out), 1) << out;
    EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
    EXPECT_THAT(out, HasSubstr("sawyer: " + f.string() + ": " + needle)) << out;
  }
  // The slopes scanners do write still open (0.5 and 2, either sign of intercept).
  TempDir tmp;
  write_volume(tmp / "s", geometry(4, 2.0));
  set_dicom_text(dicom_file(tmp / "s", 1), 0x0028, 0x1053, "0.5");
  set_dicom_text(dicom_file(tmp / "s", 2), 0x0028, 0x1053, "2");
  set_dicom_text(dicom_file(tmp / "s", 2), 0x0028, 0x1052, "-8192");
  expect_opens(tmp / "s");
}

TEST(CtLimits, DicomSlicesAThousandthOfAMillimetreApartAreRefused) {
  TempDir tmp;
  write_volume(tmp / "s", geometry(4, 2.0));
  // Written at z = 0, 2, 4, 6; the last moved to 4.002, 0.002 mm past slice_0003.dcm.
  set_dicom_text(dicom_file(tmp / "s", 4), 0x0020, 0x0032, "0\\0\\4.002");
  expect_refused(tmp / "s", {(tmp / "s").string(), "slice_0003.dcm and slice_0004.dcm",
                             "0.002 mm apart", "0.01-50 mm"});
  set_dicom_text(dicom_file(tmp / "s", 4), 0x0020, 0x0032, "0\\0\\4.5");
  expect_opens(tmp / "s");  // uneven, but a real spacing: resampled as before
}

// One stray slice at z = 3000 mm behind a 0.4 m series: 520 slices would be made up.
TEST(CtLimits, StraySliceFarAwayIsRefusedUnlessGapsAreAllowed) {
  TempDir tmp;
  write_volume(tmp / "s", geometry(81, 5.0));
  set_dicom_text(dicom_file(tmp / "s", 81), 0x0020, 0x0032, "0\\0\\3000");
  expect_refused(tmp / "s",
                 {(tmp / "s").string(), "would invent 520 of 601 slices (86.5 %",
                  "z=395.0..3000.0 mm (2605.0 mm, limit 50 mm)", "OpenOptions::allow_gaps"});
  OpenOptions allow;
  allow.allow_gaps = true;
  auto r = open_ct(tmp / "s", allow);
  ASSERT_TRUE(r.ok()) << r.error().message();
  const VolumeGeometry& g = r.value()->geometry();
  EXPECT_EQ(g.slice_count(), 601);
  EXPECT_TRUE(g.z_resampling.resampled);
  EXPECT_EQ(g.z_resampling.source_slices, 81);
  EXPECT_EQ(g.z_resampling.invented_slices, 520);
  EXPECT_EQ(resampling_summary(g),
            "resampled along z: 81 slices in the files, 601 out at 5.0 mm; 520 invented "
            "(86.5 %) in 1 gap, widest 2605.0 mm at z=395.0..3000.0 mm");

  // The command line: refused with one line, accepted with --allow-gaps and then stated.
  std::string out;
  EXPECT_NE(test::run_sawyer("info " + test::quoted(tmp / "s"), &out), 0) << out;
  EXPECT_THAT(out, HasSubstr("would invent 520 of 601 slices"));
  ASSERT_EQ(test::run_sawyer("info " + test::quoted(tmp / "s") + " --allow-gaps", &out), 0) << out;
  EXPECT_THAT(out, HasSubstr("z grid         resampled along z: 81 slices in the files"));
}

// 100 mm of slices missing inside a 1 m log: under 10 % of the slices, but a whorl fits in it.
TEST(CtLimits, WideGapInsideALogIsRefusedButSingleDropsAreNot) {
  TempDir tmp;
  write_volume(tmp / "s", geometry(201, 5.0));
  for (int i = 101; i <= 119; ++i) fs::remove(dicom_file(tmp / "s", i));  // z=500..590 mm
  expect_refused(tmp / "s", {"would invent 19 of 201 slices (9.5 %, limit 10 %)",
                             "widest z=495.0..595.0 mm (100.0 mm, limit 50 mm)"});
  OpenOptions allow;
  allow.allow_gaps = true;
  expect_opens(tmp / "s", allow);

  // Single dropped slices here and there (5 % of them) are what scanners do: resampled, stated.
  TempDir ok;
  write_volume(ok / "s", geometry(201, 5.0));
  for (int i = 10; i <= 200; i += 20) fs::remove(dicom_file(ok / "s", i));
  auto r = open_ct(ok / "s");
  ASSERT_TRUE(r.ok()) << r.error().message();
  EXPECT_EQ(r.value()->geometry().z_resampling.invented_slices, 10);
  EXPECT_THAT(resampling_summary(r.value()->geometry()),
              HasSubstr("191 slices in the files, 201 out at 5.0 mm; 10 invented (5.0 %) in 10 "
                        "gaps, widest 10.0 mm"));
}

TEST(CtLimits, EvenSeriesHasNoResamplingSummary) {
  TempDir tmp;
  write_volume(tmp / "s", geometry(6, 2.0));
  auto r = open_ct(tmp / "s");
  ASSERT_TRUE(r.ok()) << r.error().message();
  EXPECT_FALSE(r.value()->geometry().z_resampling.resampled);
  EXPECT_EQ(resampling_summary(r.value()->geometry()), "");
}

TEST(CtLimits, VolumeLargerThanMemoryIsRefusedNamingBothFigures) {
  TempDir tmp;
  write_volume(tmp / "s", geometry(4, 2.0, 64, 64));
  OpenOptions o;
  o.memory_available_bytes = 40000;  // 64 * 64 * 4 * 2 = 32768 bytes > 75 % of 40000
  expect_refused(tmp / "s",
                 {(tmp / "s").string(), "64 x 64 x 4 voxels need 0.0 GiB",
                  "more than 75 % of the 0.0 GiB of memory available"},
                 o);
  o.memory_available_bytes = 50000;
  expect_opens(tmp / "s", o);
  expect_opens(tmp / "s");  // this machine's MemAvailable
}

// ---- volume files ---------------------------------------------------------------------------

TEST(CtLimits, VtiSpacingNanIsRefusedNotReadAsOneMillimetre) {
  TempDir tmp;
  write_volume(tmp / "v", geometry(3, 1.6, 8, 6, 1.6), Format::kVti);
  const fs::path vti = tmp / "v" / "volume.vti";
  expect_opens(vti);
  std::string xml = read_text(vti);
  const size_t at = xml.find("Spacing=\"");
  ASSERT_NE(at, std::string::npos);
  const size_t end = xml.find('"', at + 9);
  xml.replace(at + 9, end - at - 9, "1.6 1.6 nan");
  test::write_file(vti, xml);
  expect_refused(vti, {vti.string() + ": Spacing \"1.6 1.6 nan\" is not 3 finite numbers"});
}

TEST(CtLimits, MetaImageSpacingAndSizeOutsideTheLimits) {
  TempDir tmp;
  const auto mha = [&](const std::string& dims, const std::string& spacing, size_t bytes) {
    test::write_file(tmp / "v.mha", "NDims = 3\nDimSize = " + dims +
                                        "\nElementSpacing = " + spacing +
                                        "\nElementType = MET_SHORT\n"
                                        "ElementDataFile = LOCAL\n" +
                                        std::string(bytes, '\0'));
  };
  mha("16 16 2", "1e6 1 1", 1024);
  expect_refused(tmp / "v.mha", {(tmp / "v.mha").string() + ": ElementSpacing 1000000 1 1:",
                                 "1e+06 mm is outside 0.01-50 mm"});
  mha("16 16 2", "0.001 1 1", 1024);
  expect_refused(tmp / "v.mha", {"0.001 mm is outside 0.01-50 mm"});
  mha("20000 1 2", "0.05 0.05 1", 80000);
  expect_refused(tmp / "v.mha",
                 {(tmp / "v.mha").string() + ": image size: 20000 columns is outside 1-16384"});
  mha("1000 1000 2", "2.5 2.5 1", 4000000);  // 2.5 m across
  expect_refused(tmp / "v.mha", {"field of view 2500 x 2500 mm", "more than 2000 mm across"});
  mha("16 16 2", "1 1 1", 1024);
  expect_opens(tmp / "v.mha");
}

// ---- image stacks ---------------------------------------------------------------------------

void stack_with_sidecar(const fs::path& dir, const std::string& sidecar) {
  write_volume(dir, geometry(3, 2.0), Format::kTiffStack);
  test::write_file(dir / "sawyer_stack.json", sidecar);
}

TEST(CtLimits, SidecarZPositionsKilometresApartAreRefused) {
  TempDir tmp;
  stack_with_sidecar(tmp / "s", R"({"pixel_spacing_mm": 0.5, "z_mm": [0, 10000000, 20000000]})");
  expect_refused(tmp / "s", {(tmp / "s" / "sawyer_stack.json").string() +
                             ": \"z_mm\" spans 20000000 mm (0 to 20000000), more than 30000 mm"});
  stack_with_sidecar(tmp / "t", R"({"pixel_spacing_mm": 0.5, "z_mm": [0, 0.004, 2]})");
  expect_refused(tmp / "t", {"\"z_mm\" elements 0 and 1 are 0.004 mm apart"});
  stack_with_sidecar(tmp / "u", R"({"pixel_spacing_mm": 0.5, "z_mm": [0, 2, 4]})");
  expect_opens(tmp / "u");
}

TEST(CtLimits, SidecarSpacingOutsideTheLimits) {
  TempDir tmp;
  stack_with_sidecar(tmp / "s", R"({"pixel_spacing_mm": 1e300, "slice_spacing_mm": 2})");
  expect_refused(tmp / "s", {(tmp / "s" / "sawyer_stack.json").string() +
                             ": \"pixel_spacing_mm\" 1e+300 mm is outside 0.01-50 mm"});
  stack_with_sidecar(tmp / "t", R"({"pixel_spacing_mm": 0.5, "slice_spacing_mm": 400})");
  expect_refused(tmp / "t", {"\"slice_spacing_mm\" 400 mm is outside 0.01-50 mm"});
  // A spacing from the library caller (the command line's --pixel-spacing) is held to it too.
  stack_with_sidecar(tmp / "u", R"({"pixel_spacing_mm": 0.5, "slice_spacing_mm": 2})");
  expect_opens(tmp / "u");
  OpenOptions o;
  o.pixel_spacing = 1e6;
  expect_refused(tmp / "u",
                 {(tmp / "u").string() + ": OpenOptions::pixel_spacing 1e+06 mm is outside"}, o);
}

TEST(CtLimits, CommandLineSpacingAndRescaleHaveRanges) {
  TempDir tmp;
  stack_with_sidecar(tmp / "s", R"({"pixel_spacing_mm": 0.5, "slice_spacing_mm": 2})");
  const std::string info = "info " + test::quoted(tmp / "s");
  std::string out;
  for (const std::string bad :
       {"--pixel-spacing 100", "--pixel-spacing nan", "--slice-spacing 0.001",
        "--slice-spacing inf", "--rescale-slope 1e-300", "--rescale-slope nan",
        "--rescale-intercept 1e9"}) {
    EXPECT_NE(test::run_sawyer(info + " " + bad, &out), 0) << bad << ": " << out;
    EXPECT_THAT(out, HasSubstr(bad.substr(0, bad.find(' ')))) << bad;
    EXPECT_THAT(out, HasSubstr("outside")) << bad << ": " << out;
  }
  EXPECT_EQ(test::run_sawyer(info + " --pixel-spacing 0.8 --rescale-slope 1 --rescale-intercept "
                                    "-1024",
                             &out),
            0)
      << out;
}

// ---- what a scan folder holds -----------------------------------------------------------------

std::string checksum(const fs::path& p) {
  Result<std::string> c = reg::ct_checksum(p);
  EXPECT_TRUE(c.ok()) << c.error().message();
  return c.ok() ? c.value() : "";
}

TEST(CtLimits, ChecksumDoesNotFollowALinkLoopAndSeesWhatTheReadersSee) {
  TempDir tmp;
  write_volume(tmp / "s", geometry(4, 2.0));
  const std::string plain = checksum(tmp / "s");
  fs::create_directory_symlink(".", tmp / "s" / "a");  // ln -s . a
  fs::create_directories(tmp / "s" / "truth");
  test::write_file(tmp / "s" / "truth" / "notes.txt", "not a slice");
  test::write_file(tmp / "s" / ".DS_Store", "hidden");
  EXPECT_EQ(checksum(tmp / "s"), plain);  // none of it is read: the readers skip it all too
  auto r = open_ct(tmp / "s");
  ASSERT_TRUE(r.ok()) << r.error().message();
  EXPECT_EQ(r.value()->geometry().slice_count(), 4);
  // A link to a slice file is a file to both.
  fs::rename(dicom_file(tmp / "s", 4), tmp / "elsewhere.dcm");
  fs::create_symlink(tmp / "elsewhere.dcm", dicom_file(tmp / "s", 4));
  EXPECT_EQ(checksum(tmp / "s"), plain);
}

TEST(CtLimits, FifoInAScanFolderHangsNeitherChecksumNorReader) {
  TempDir tmp;
  write_volume(tmp / "s", geometry(4, 2.0));
  const std::string plain = checksum(tmp / "s");
  const fs::path fifo = tmp / "s" / "slice_0005.dcm";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  // Bounded: if the checksum blocked on the FIFO, opening its write end releases it.
  auto sum = std::async(std::launch::async, [&] { return reg::ct_checksum(tmp / "s"); });
  if (sum.wait_for(std::chrono::seconds(60)) != std::future_status::ready) {
    const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    if (fd >= 0) ::close(fd);
    ADD_FAILURE() << "ct_checksum blocked on a FIFO";
  }
  Result<std::string> c = sum.get();
  ASSERT_TRUE(c.ok()) << c.error().message();
  EXPECT_EQ(c.value(), plain);
  // The reader through the command line, bounded by timeout(1).
  std::string out;
  const int rc = test::run_command(
      "timeout 60 " + test::sawyer_bin() + " info " + test::quoted(tmp / "s"), &out);
  EXPECT_EQ(rc, 0) << out;
  EXPECT_THAT(out, HasSubstr("4 of 8 x 6 pixels"));
}

}  // namespace
}  // namespace sawyer::ct

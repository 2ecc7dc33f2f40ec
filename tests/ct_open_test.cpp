// open_ct's dispatch: what a path holds decides the reader, and paths that hold no CT scan are
// refused with one line that names the path and says what was expected.
#include "sawyer/ct/io/slice_sink.h"
#include "sawyer/ct/io/slice_source.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sawyer/test/test_util.h"

namespace sawyer::ct {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string open_error(const fs::path& p) {
  auto r = open_ct(p);
  EXPECT_FALSE(r.ok()) << p;
  return r.ok() ? std::string() : r.error().message();
}

TEST(OpenCt, MissingPathIsNamed) {
  test::TempDir dir;
  const std::string msg = open_error(dir / "nowhere");
  EXPECT_THAT(msg, HasSubstr("nowhere"));
  EXPECT_THAT(msg, HasSubstr("no such file or folder"));
}

TEST(OpenCt, EmptyFolderIsRefused) {
  test::TempDir dir;
  EXPECT_THAT(open_error(dir.path()), HasSubstr("the folder is empty"));
}

TEST(OpenCt, HiddenFilesDoNotCount) {
  test::TempDir dir;
  test::write_file(dir / ".DS_Store", "junk");
  EXPECT_THAT(open_error(dir.path()), HasSubstr("the folder is empty"));
}

TEST(OpenCt, FolderWithoutSlicesSaysWhatWasExpected) {
  test::TempDir dir;
  test::write_file(dir / "notes.txt", "scanned on Tuesday");
  test::write_file(dir / "readme.md", "# log 42");
  const std::string msg = open_error(dir.path());
  EXPECT_THAT(msg, HasSubstr("no CT slices found among 2 files"));
  EXPECT_THAT(msg, HasSubstr("DICOM"));
}

TEST(OpenCt, OnePngIsNotAStack) {
  test::TempDir dir;
  test::write_file(dir / "slice_0001.png", "not really a png");
  EXPECT_THAT(open_error(dir / "slice_0001.png"), HasSubstr("give the folder of the stack"));
}

TEST(OpenCt, UnknownFileTypeIsRefused) {
  test::TempDir dir;
  test::write_file(dir / "scan.xyz", "0123456789");
  EXPECT_THAT(open_error(dir / "scan.xyz"), HasSubstr("not a CT file Sawyer reads"));
}

TEST(OpenCt, SeveralVolumeFilesAreAmbiguous) {
  test::TempDir dir;
  test::write_file(dir / "a.mha", "ObjectType = Image\n");
  test::write_file(dir / "b.nrrd", "NRRD0004\n");
  const std::string msg = open_error(dir.path());
  EXPECT_THAT(msg, HasSubstr("holds 2 volume files (a.mha, b.nrrd)"));
}

TEST(OpenCt, WriterRefusesAnEmptyGeometry) {
  test::TempDir dir;
  VolumeGeometry g;
  auto w = create_ct_writer(dir / "out", g, {});
  ASSERT_FALSE(w.ok());
  EXPECT_THAT(w.error().message(), HasSubstr("empty geometry"));
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(OpenCt, WriterRefusesZeroSpacing) {
  test::TempDir dir;
  VolumeGeometry g;
  g.width = g.height = 4;
  g.z = {0, 1};
  g.spacing_x = 0;
  g.spacing_y = 1;
  auto w = create_ct_writer(dir / "out", g, {});
  ASSERT_FALSE(w.ok());
  EXPECT_THAT(w.error().message(), HasSubstr("pixel spacing must be positive"));
}

TEST(OpenCt, MedianSliceSpacingIgnoresOneGap) {
  VolumeGeometry g;
  g.z = {0, 5, 10, 25, 30, 35};
  EXPECT_DOUBLE_EQ(g.slice_spacing(), 5.0);
  EXPECT_DOUBLE_EQ(g.z_extent(), 35.0);
}

}  // namespace
}  // namespace sawyer::ct

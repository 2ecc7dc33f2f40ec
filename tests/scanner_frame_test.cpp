// The scanner frame end to end (issue 19, item 1): a scan whose file puts its pixels somewhere
// in the scanner, with rows and columns in any axial direction, gives log.json's pith where the
// scanner says the pith is. The scenes are one phantom section whose slices are re-laid into
// each file: DICOM series written with GDCM's own API, MetaImage and NRRD headers written by
// hand, VTK image data and a TIFF stack with its sidecar through Sawyer's writers.
#include <gdcmAttribute.h>
#include <gdcmDataElement.h>
#include <gdcmDataSet.h>
#include <gdcmFile.h>
#include <gdcmWriter.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "sawyer/ct/io/scanner_frame.h"
#include "sawyer/ct/io/slice_sink.h"
#include "sawyer/ct/phantom/phantom.h"
#include "sawyer/model/log_json.h"
#include "sawyer/test/test_util.h"

namespace sawyer::ct {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// The scene: pixel (col, row) of phantom slice p lies at scanner (kA + col·px, kA + row·px,
// kZ0 + p·dz). The pith is off the image centre, so a mirrored or transposed reading puts it
// tens of mm away; the log is tilted, so reading z the wrong way round moves it too.
constexpr double kA = -204.8, kZ0 = 1234.5;

struct Scene {
  std::unique_ptr<Phantom> phantom;
  LogModel truth;  // image frame (truth_log())
  std::vector<Slice> slices;
  int w = 0;
  double px = 0, dz = 0;
};

const Scene& scene() {
  static const Scene s = [] {
    Scene sc;
    PhantomOptions o;
    o.image_size = 512;
    o.pixel_mm = 0.8;
    o.slice_spacing_mm = 5.0;
    o.from_mm = 2000;
    o.to_mm = 2200;
    o.seed = 5;
    o.placement.offset_x_mm = 25;
    o.placement.offset_y_mm = -15;
    o.placement.tilt_x_deg = 3;
    o.placement.tilt_y_deg = -2;
    auto ph = Phantom::create(test::sample_model("pine_8"), o);
    EXPECT_TRUE(ph.ok()) << (ph.ok() ? "" : ph.error().message());
    if (!ph) return sc;
    sc.phantom = std::move(ph).value();
    sc.truth = sc.phantom->truth_log();
    sc.w = o.image_size;
    sc.px = o.pixel_mm;
    sc.dz = o.slice_spacing_mm;
    for (int i = 0; i < sc.phantom->nominal_count(); ++i)
      sc.slices.push_back(sc.phantom->render_slice(i));
    return sc;
  }();
  return s;
}

// A file's axial orientation: rows along `row`, columns along `col` (each ±x or ±y).
struct Axes {
  Vec3 row{1, 0, 0}, col{0, 1, 0};
  Vec3 normal() const { return cross(row, col); }
};

// Where the file's pixel (0, 0) of its first slice must lie for the file to show the scene,
// and the scene pixel a file pixel shows.
struct Layout {
  Axes ax;
  int w;
  double px;
  // Scene pixel index at file index 0 along x and y: 0, or the last pixel for a flipped axis.
  int ox() const { return ax.row.x + ax.col.x < 0 ? w - 1 : 0; }
  int oy() const { return ax.row.y + ax.col.y < 0 ? w - 1 : 0; }
  int scene_col(int i, int j) const {
    return ox() + i * static_cast<int>(ax.row.x) + j * static_cast<int>(ax.col.x);
  }
  int scene_row(int i, int j) const {
    return oy() + i * static_cast<int>(ax.row.y) + j * static_cast<int>(ax.col.y);
  }
  Vec3 origin_xy() const { return {kA + ox() * px, kA + oy() * px, 0}; }
};

// File slice k shows scene slice p(k): the file's slices run along its normal, so a normal
// along -z starts at the scene's last slice.
int scene_slice(const Axes& ax, int k, int n) { return ax.normal().z < 0 ? n - 1 - k : k; }

Slice file_slice(const Scene& sc, const Layout& L, int k) {
  const int n = static_cast<int>(sc.slices.size());
  const Slice& src = sc.slices[static_cast<size_t>(scene_slice(L.ax, k, n))];
  Slice out;
  out.index = k;
  out.z = k * sc.dz;
  out.width = out.height = sc.w;
  out.hu.resize(static_cast<size_t>(sc.w) * sc.w);
  for (int j = 0; j < sc.w; ++j)
    for (int i = 0; i < sc.w; ++i)
      out.hu[static_cast<size_t>(j) * sc.w + i] = src.at(L.scene_col(i, j), L.scene_row(i, j));
  return out;
}

// Scanner position of file slice k's pixel (0, 0).
Vec3 file_position(const Scene& sc, const Layout& L, int k) {
  const int n = static_cast<int>(sc.slices.size());
  return L.origin_xy() + Vec3{0, 0, kZ0 + scene_slice(L.ax, k, n) * sc.dz};
}

// One DICOM file of a series through GDCM's own writer: int16 HU, Image Position and
// Orientation (Patient) as given; k of n sets the instance number (in a random order) and the
// file's name.
void write_gdcm_file(const fs::path& dir, const Slice& s, const Vec3& p,
                     const std::vector<double>& iop, double px, int k, int n) {
  gdcm::Writer w;
  gdcm::DataSet& ds = w.GetFile().GetDataSet();
  const std::string series = "1.2.826.0.1.3680043.9.7778.1";
  const std::string sop = series + ".1." + std::to_string(k + 1);
  ds.Replace(gdcm::Attribute<0x0008, 0x0016>{"1.2.840.10008.5.1.4.1.1.2"}.GetAsDataElement());
  ds.Replace(gdcm::Attribute<0x0008, 0x0018>{sop.c_str()}.GetAsDataElement());
  ds.Replace(gdcm::Attribute<0x0008, 0x0060>{"CT"}.GetAsDataElement());
  ds.Replace(gdcm::Attribute<0x0020, 0x000d>{"1.2.826.0.1.3680043.9.7778"}.GetAsDataElement());
  ds.Replace(gdcm::Attribute<0x0020, 0x000e>{series.c_str()}.GetAsDataElement());
  ds.Replace(gdcm::Attribute<0x0020, 0x0013>{(k * 7) % n + 1}.GetAsDataElement());
  gdcm::Attribute<0x0020, 0x0032> ipp = {{p.x, p.y, p.z}};
  ds.Replace(ipp.GetAsDataElement());
  gdcm::Attribute<0x0020, 0x0037> orientation;
  for (unsigned q = 0; q < 6; ++q) orientation.SetValue(iop[q], q);
  ds.Replace(orientation.GetAsDataElement());
  ds.Replace(gdcm::Attribute<0x0028, 0x0002>{1}.GetAsDataElement());
  ds.Replace(gdcm::Attribute<0x0028, 0x0004>{"MONOCHROME2"}.GetAsDataElement());
  ds.Replace(
      gdcm::Attribute<0x0028, 0x0010>{static_cast<unsigned short>(s.height)}.GetAsDataElement());
  ds.Replace(
      gdcm::Attribute<0x0028, 0x0011>{static_cast<unsigned short>(s.width)}.GetAsDataElement());
  gdcm::Attribute<0x0028, 0x0030> spacing = {{px, px}};
  ds.Replace(spacing.GetAsDataElement());
  ds.Replace(gdcm::Attribute<0x0028, 0x0100>{16}.GetAsDataElement());
  ds.Replace(gdcm::Attribute<0x0028, 0x0101>{16}.GetAsDataElement());
  ds.Replace(gdcm::Attribute<0x0028, 0x0102>{15}.GetAsDataElement());
  ds.Replace(gdcm::Attribute<0x0028, 0x0103>{1}.GetAsDataElement());
  ds.Replace(gdcm::Attribute<0x0028, 0x1052>{0.0}.GetAsDataElement());
  ds.Replace(gdcm::Attribute<0x0028, 0x1053>{1.0}.GetAsDataElement());
  std::vector<char> bytes;
  for (float v : s.hu) {
    const auto word = static_cast<uint16_t>(static_cast<int16_t>(std::lround(v)));
    bytes.push_back(static_cast<char>(word & 0xff));
    bytes.push_back(static_cast<char>(word >> 8));
  }
  gdcm::DataElement pixels(gdcm::Tag(0x7fe0, 0x0010));
  pixels.SetVR(gdcm::VR::OW);
  pixels.SetByteValue(bytes.data(), static_cast<uint32_t>(bytes.size()));
  ds.Replace(pixels);
  w.GetFile().GetHeader().SetDataSetTransferSyntax(gdcm::TransferSyntax::ExplicitVRLittleEndian);
  const fs::path file =
      dir / ("IM" + std::to_string(1000 + (k * 13) % 97) + "_" + std::to_string(k) + ".dcm");
  w.SetFileName(file.c_str());
  ASSERT_TRUE(w.Write()) << file;
}

// A DICOM series of the scene laid out along `ax`, random instance order, Image Orientation
// (Patient) `iop`.
void write_gdcm_series(const fs::path& dir, const Scene& sc, const Axes& ax,
                       const std::vector<double>& iop) {
  fs::create_directories(dir);
  const Layout L{ax, sc.w, sc.px};
  const int n = static_cast<int>(sc.slices.size());
  for (int k = 0; k < n; ++k)
    write_gdcm_file(dir, file_slice(sc, L, k), file_position(sc, L, k), iop, sc.px, k, n);
}

std::vector<double> iop_of(const Axes& ax) {
  return {ax.row.x, ax.row.y, ax.row.z, ax.col.x, ax.col.y, ax.col.z};
}

// Raw little-endian floats of every file slice, in file order.
std::string raw_volume(const Scene& sc, const Layout& L) {
  std::string data;
  for (int k = 0; k < static_cast<int>(sc.slices.size()); ++k) {
    const Slice s = file_slice(sc, L, k);
    data.append(reinterpret_cast<const char*>(s.hu.data()), s.hu.size() * sizeof(float));
  }
  return data;
}

// A MetaImage (.mha) whose header a user wrote: Offset and TransformMatrix (index axes 0, 1, 2).
void write_mha(const fs::path& file, const Scene& sc, const Axes& ax) {
  const Layout L{ax, sc.w, sc.px};
  const Vec3 o = file_position(sc, L, 0), n = ax.normal();
  std::ofstream out(file, std::ios::binary);
  out << "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
      << "TransformMatrix = " << ax.row.x << " " << ax.row.y << " " << ax.row.z << " " << ax.col.x
      << " " << ax.col.y << " " << ax.col.z << " " << n.x << " " << n.y << " " << n.z
      << "\nOffset = " << o.x << " " << o.y << " " << o.z << "\nElementSpacing = " << sc.px << " "
      << sc.px << " " << sc.dz << "\nDimSize = " << sc.w << " " << sc.w << " " << sc.slices.size()
      << "\nElementType = MET_FLOAT\nElementDataFile = LOCAL\n";
  out << raw_volume(sc, L);
}

// An NRRD with space directions (spacing times direction) and a space origin. With a `space`,
// every vector is written in that space: `signs` turns the scene's LPS x, y, z into it (RAS:
// -1, -1, 1); without one, "space dimension: 3" and the vectors as they are.
void write_nrrd(const fs::path& file, const Scene& sc, const Axes& ax,
                const std::string& space = "", const Vec3& signs = {1, 1, 1}) {
  const Layout L{ax, sc.w, sc.px};
  const Vec3 o = file_position(sc, L, 0), n = ax.normal();
  const auto v = [&](const Vec3& d, double s) {
    std::ostringstream t;
    t << "(" << std::to_string(s * signs.x * d.x) << "," << std::to_string(s * signs.y * d.y) << ","
      << std::to_string(s * signs.z * d.z) << ")";
    return t.str();
  };
  std::ofstream out(file, std::ios::binary);
  out << "NRRD0004\ntype: float\ndimension: 3\n"
      << (space.empty() ? "space dimension: 3" : "space: " + space) << "\nsizes: " << sc.w << " "
      << sc.w << " " << sc.slices.size() << "\nspace directions: " << v(ax.row, sc.px) << " "
      << v(ax.col, sc.px) << " " << v(n, sc.dz) << "\nspace origin: " << v(o, 1.0)
      << "\nendian: little\nencoding: raw\n\n";
  out << raw_volume(sc, L);
}

// Through Sawyer's writers: geometry with the file's origin and orientation.
void write_with_sawyer(const fs::path& dir, const Scene& sc, const Axes& ax, Format f) {
  const Layout L{ax, sc.w, sc.px};
  VolumeGeometry g;
  g.width = g.height = sc.w;
  g.spacing_x = g.spacing_y = sc.px;
  for (size_t k = 0; k < sc.slices.size(); ++k) g.z.push_back(k * sc.dz);
  g.origin = file_position(sc, L, 0);
  g.orientation = {ax.row.x, ax.row.y, ax.row.z, ax.col.x, ax.col.y, ax.col.z};
  WriteOptions o;
  o.format = f;
  o.bits_stored = f == Format::kVti ? 32 : 16;
  auto sink = create_ct_writer(dir, g, o);
  ASSERT_TRUE(sink.ok()) << sink.error().message();
  for (int k = 0; k < g.slice_count(); ++k)
    ASSERT_TRUE(sink.value()->write(file_slice(sc, L, k)).ok());
  ASSERT_TRUE(sink.value()->finish().ok());
}

// `sawyer scan` of `input`; log.json's pith against the scene's, both in the scanner frame:
// every stem sample's height goes back to the scanner's z through log.json's scanner_frame,
// then to the scene's slice, where the truth's pith (image frame) plus kA is the answer.
void expect_pith_in_scanner_frame(const fs::path& input, const fs::path& out) {
  const Scene& sc = scene();
  ASSERT_FALSE(sc.slices.empty()) << "no phantom";
  std::string text;
  ASSERT_EQ(test::run_sawyer("scan " + test::quoted(input) + " -o " + test::quoted(out), &text), 0)
      << text;
  auto log = read_log_json(out / "log.json");
  ASSERT_TRUE(log.ok()) << log.error().message();
  ASSERT_TRUE(log.value().scanner_frame.has_value()) << "log.json has no scanner_frame";
  const ScannerFrame& f = *log.value().scanner_frame;
  const Stem& st = log.value().stem;
  std::vector<double> err;
  for (int i = 0; i < st.slice_count(); ++i) {
    const double z_scene = f.scanner_z(st.z_at(i)) - kZ0;
    if (z_scene < 10 || z_scene > sc.dz * (sc.slices.size() - 1) - 10) continue;
    const Vec2 want = sc.truth.stem.pith_at(z_scene) + Vec2{kA, kA};
    err.push_back((st.pith[static_cast<size_t>(i)] - want).norm());
    if (getenv("SF_DEBUG"))
      std::printf("z %.1f scene %.1f got (%.2f, %.2f) want (%.2f, %.2f)\n", st.z_at(i), z_scene,
                  st.pith[static_cast<size_t>(i)].x, st.pith[static_cast<size_t>(i)].y, want.x,
                  want.y);
  }
  ASSERT_GE(err.size(), 20u);
  std::sort(err.begin(), err.end());
  EXPECT_LE(err[err.size() / 2], 0.5) << "median pith error, scanner frame";
  EXPECT_LE(err.back(), 1.5) << "worst pith error, scanner frame";
}

struct Case {
  const char* name;
  Axes ax;
};

const Case kAxial[] = {
    {"standard", {{1, 0, 0}, {0, 1, 0}}},        {"row_flipped", {{-1, 0, 0}, {0, 1, 0}}},
    {"column_flipped", {{1, 0, 0}, {0, -1, 0}}}, {"both_flipped", {{-1, 0, 0}, {0, -1, 0}}},
    {"swapped", {{0, 1, 0}, {1, 0, 0}}},         {"swapped_flipped", {{0, -1, 0}, {1, 0, 0}}},
};

class DicomAxes : public ::testing::TestWithParam<Case> {};

TEST_P(DicomAxes, PithWhereTheScannerSaysItIs) {
  ASSERT_FALSE(scene().slices.empty());
  test::TempDir dir;
  write_gdcm_series(dir / "ct", scene(), GetParam().ax, iop_of(GetParam().ax));
  expect_pith_in_scanner_frame(dir / "ct", dir / "scan");
  // The frame records the file's own origin and directions.
  auto log = read_log_json(dir / "scan" / "log.json");
  ASSERT_TRUE(log.ok());
  const ScannerFrame& f = *log.value().scanner_frame;
  // The reader's first slice is file slice 0 (the files run along the normal).
  const Vec3 want_first = file_position(scene(), Layout{GetParam().ax, scene().w, scene().px}, 0);
  EXPECT_NEAR(f.origin_mm.x, want_first.x, 1e-6);
  EXPECT_NEAR(f.origin_mm.y, want_first.y, 1e-6);
  EXPECT_NEAR(f.origin_mm.z, want_first.z, 1e-6);
  EXPECT_EQ(f.row_dir, GetParam().ax.row);
  EXPECT_EQ(f.col_dir, GetParam().ax.col);
  EXPECT_EQ(f.z_dir, GetParam().ax.normal().z);
}

INSTANTIATE_TEST_SUITE_P(ScannerFrame, DicomAxes, ::testing::ValuesIn(kAxial),
                         [](const ::testing::TestParamInfo<Case>& p) {
                           return std::string(p.param.name);
                         });

TEST(ScannerFrame, MetaImageWithFlippedRowsAndOrigin) {
  test::TempDir dir;
  fs::create_directories(dir / "ct");
  write_mha(dir / "ct" / "volume.mha", scene(), {{-1, 0, 0}, {0, 1, 0}});
  expect_pith_in_scanner_frame(dir / "ct" / "volume.mha", dir / "scan");
}

TEST(ScannerFrame, NrrdWithSwappedAxesAndOrigin) {
  test::TempDir dir;
  fs::create_directories(dir / "ct");
  write_nrrd(dir / "ct" / "volume.nrrd", scene(), {{0, 1, 0}, {1, 0, 0}});
  expect_pith_in_scanner_frame(dir / "ct" / "volume.nrrd", dir / "scan");
}

// NRRD's `space` (issue 19): the same scene written in RAS (x and y negated against LPS) gives
// the same scanner-frame pith and frame as when it is written in LPS, Sawyer's frame.
TEST(ScannerFrame, NrrdInRasGivesThePithOfLps) {
  ASSERT_FALSE(scene().slices.empty()) << "no phantom";
  test::TempDir dir;
  fs::create_directories(dir / "ct");
  const Axes ax{{-1, 0, 0}, {0, 1, 0}};
  write_nrrd(dir / "ct" / "lps.nrrd", scene(), ax, "left-posterior-superior");
  write_nrrd(dir / "ct" / "ras.nrrd", scene(), ax, "right-anterior-superior", {-1, -1, 1});
  expect_pith_in_scanner_frame(dir / "ct" / "ras.nrrd", dir / "ras");
  std::string text;
  ASSERT_EQ(test::run_sawyer("scan " + test::quoted(dir / "ct" / "lps.nrrd") + " -o " +
                                 test::quoted(dir / "lps"),
                             &text),
            0)
      << text;
  auto lps = read_log_json(dir / "lps" / "log.json");
  auto ras = read_log_json(dir / "ras" / "log.json");
  ASSERT_TRUE(lps.ok() && ras.ok());
  ASSERT_EQ(lps.value().stem.slice_count(), ras.value().stem.slice_count());
  for (int i = 0; i < lps.value().stem.slice_count(); ++i) {
    const auto k = static_cast<size_t>(i);
    EXPECT_NEAR(ras.value().stem.pith[k].x, lps.value().stem.pith[k].x, 1e-6) << i;
    EXPECT_NEAR(ras.value().stem.pith[k].y, lps.value().stem.pith[k].y, 1e-6) << i;
  }
  const ScannerFrame& f = *ras.value().scanner_frame;
  const Vec3 want = file_position(scene(), Layout{ax, scene().w, scene().px}, 0);
  EXPECT_NEAR(f.origin_mm.x, want.x, 1e-6);
  EXPECT_NEAR(f.origin_mm.y, want.y, 1e-6);
  EXPECT_NEAR(f.origin_mm.z, want.z, 1e-6);
  EXPECT_EQ(f.row_dir, ax.row);
  EXPECT_EQ(f.col_dir, ax.col);
}

// A tiny NRRD (12 x 10 x 3, axes along the space's x, y, z) in `space`.
fs::path write_small_nrrd(const fs::path& dir, const std::string& space) {
  fs::create_directories(dir);
  const fs::path file = dir / "v.nrrd";
  std::ofstream out(file, std::ios::binary);
  out << "NRRD0004\ntype: short\ndimension: 3\nspace: " << space
      << "\nsizes: 12 10 3\nspace directions: (0.5,0,0) (0,0.5,0) (0,0,2)\n"
      << "space origin: (10,20,30)\nendian: little\nencoding: raw\n\n"
      << std::string(12 * 10 * 3 * 2, '\0');
  return file;
}

// Each axis that points the other way from LPS is negated, in the origin and the directions;
// the scanner's own frames are as given.
TEST(ScannerFrame, NrrdSpacesMapToLps) {
  const struct {
    const char* space;
    Vec3 origin, row, col, slices;
  } kSpaces[] = {
      {"right-anterior-superior", {-10, -20, 30}, {-1, 0, 0}, {0, -1, 0}, {0, 0, 1}},
      {"RAS", {-10, -20, 30}, {-1, 0, 0}, {0, -1, 0}, {0, 0, 1}},
      {"left-anterior-superior", {10, -20, 30}, {1, 0, 0}, {0, -1, 0}, {0, 0, 1}},
      {"left-posterior-superior", {10, 20, 30}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}},
      {"right-posterior-inferior", {-10, 20, -30}, {-1, 0, 0}, {0, 1, 0}, {0, 0, -1}},
      {"scanner-xyz", {10, 20, 30}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}},
      {"3D-right-handed", {10, 20, 30}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}},
  };
  test::TempDir dir;
  for (const auto& c : kSpaces) {
    auto src = open_ct(write_small_nrrd(dir / c.space, c.space));
    ASSERT_TRUE(src.ok()) << c.space << ": " << src.error().message();
    const VolumeGeometry& g = src.value()->geometry();
    EXPECT_EQ(g.origin, c.origin) << c.space;
    EXPECT_EQ(g.orientation,
              (std::array<double, 6>{c.row.x, c.row.y, c.row.z, c.col.x, c.col.y, c.col.z}))
        << c.space;
    EXPECT_EQ(g.slice_dir, c.slices) << c.space;
    EXPECT_DOUBLE_EQ(g.spacing_x, 0.5) << c.space;
  }
}

// A space Sawyer cannot map (a left-handed frame of no named axes, a time axis, a misspelling)
// is refused with one line naming the file and the space; nothing is written.
TEST(ScannerFrame, UnknownNrrdSpaceRefused) {
  test::TempDir dir;
  for (const char* space : {"3D-left-handed", "right-anterior-superior-time", "left-up-superior"}) {
    const fs::path file = write_small_nrrd(dir / "ct", space);
    const fs::path out = dir / "scan";
    std::string text;
    EXPECT_EQ(test::run_sawyer("scan " + test::quoted(file) + " -o " + test::quoted(out), &text), 1)
        << text;
    EXPECT_THAT(text, HasSubstr(file.string() + ": NRRD space \"" + space + "\"")) << text;
    EXPECT_FALSE(fs::exists(out)) << space;
  }
}

TEST(ScannerFrame, VtiWithFlippedColumnsAndOrigin) {
  test::TempDir dir;
  write_with_sawyer(dir / "ct", scene(), {{1, 0, 0}, {0, -1, 0}}, Format::kVti);
  expect_pith_in_scanner_frame(dir / "ct", dir / "scan");
}

TEST(ScannerFrame, TiffStackSidecarOriginAndOrientation) {
  test::TempDir dir;
  write_with_sawyer(dir / "ct", scene(), {{-1, 0, 0}, {0, -1, 0}}, Format::kTiffStack);
  expect_pith_in_scanner_frame(dir / "ct", dir / "scan");
}

// Coronal and sagittal series (issue 41, item 4): the scene's slices as they are, stacked along
// their normal, which is the scanner's y or x. The scan reads them as stored: log.json's pith is
// in the slices' own axes (x = column·pixel, y = row·pixel from pixel (0, 0), as the truth's),
// and its scanner_frame carries the directions that put every point back where the file puts
// it: pixel (col, row) of slice k at kCrossOrigin + col·px·row + row·px·col + k·dz·(row × col).
const Vec3 kCrossOrigin{-111.25, 222.5, 1234.5};

void write_cross_sections(const fs::path& dir, const Scene& sc, const Axes& ax) {
  fs::create_directories(dir);
  const int n = static_cast<int>(sc.slices.size());
  for (int k = 0; k < n; ++k)
    write_gdcm_file(dir, sc.slices[static_cast<size_t>(k)],
                    kCrossOrigin + (k * sc.dz) * ax.normal(), iop_of(ax), sc.px, k, n);
}

struct CrossCase {
  const char* name;
  Axes ax;
  int slice_axis;     // the scanner axis the slices are stacked along
  const char* words;  // what `sawyer info` and the scan's note say
};

const CrossCase kCross[] = {
    // The real coronal disc's orientation: rows along +x, columns along -z, slices along +y.
    {"coronal", {{1, 0, 0}, {0, 0, -1}}, 1, "coronal slices: the log's z along the scanner's +y"},
    // Rows along +y, columns along -z: slices along -x, so z runs against the scanner's x.
    {"sagittal", {{0, 1, 0}, {0, 0, -1}}, 0, "sagittal slices: the log's z along the scanner's -x"},
};

class CrossSections : public ::testing::TestWithParam<CrossCase> {};

TEST_P(CrossSections, PithMapsBackToTheScanner) {
  const Scene& sc = scene();
  ASSERT_FALSE(sc.slices.empty()) << "no phantom";
  const CrossCase& c = GetParam();
  const Vec3 normal = c.ax.normal();
  test::TempDir dir;
  write_cross_sections(dir / "ct", sc, c.ax);
  std::string text;
  ASSERT_EQ(test::run_sawyer("info " + test::quoted(dir / "ct"), &text), 0) << text;
  EXPECT_THAT(text, HasSubstr(c.words)) << text;
  ASSERT_EQ(test::run_sawyer(
                "scan " + test::quoted(dir / "ct") + " -o " + test::quoted(dir / "scan"), &text),
            0)
      << text;
  auto log = read_log_json(dir / "scan" / "log.json");
  ASSERT_TRUE(log.ok()) << log.error().message();
  ASSERT_TRUE(log.value().scanner_frame.has_value()) << "log.json has no scanner_frame";
  const ScannerFrame& f = *log.value().scanner_frame;
  EXPECT_FALSE(f.axial());
  EXPECT_EQ(f.slice_axis(), c.slice_axis);
  EXPECT_EQ(f.origin_mm, kCrossOrigin);
  EXPECT_EQ(f.row_dir, c.ax.row);
  EXPECT_EQ(f.col_dir, c.ax.col);
  EXPECT_EQ(f.slice_dir, normal);
  EXPECT_EQ(f.z_dir, c.slice_axis == 0 ? normal.x : normal.y);
  EXPECT_EQ(f.z0_mm, c.slice_axis == 0 ? kCrossOrigin.x : kCrossOrigin.y);

  const Stem& st = log.value().stem;
  std::vector<double> err_model, err_scanner;
  for (int i = 0; i < st.slice_count(); ++i) {
    const double z = st.z_at(i);
    if (z < 10 || z > sc.dz * (sc.slices.size() - 1) - 10) continue;
    const Vec2 got = st.pith[static_cast<size_t>(i)], want = sc.truth.stem.pith_at(z);
    // In the slices' own axes, with no scanner origin added (what a reader of the pixels
    // expects)...
    err_model.push_back((got - want).norm());
    // ... and through the frame, where the file put the phantom's pith in the scanner.
    const Vec3 placed = kCrossOrigin + (want.x * c.ax.row + want.y * c.ax.col) + z * normal;
    err_scanner.push_back((f.to_scanner({got.x, got.y, z}) - placed).norm());
    EXPECT_NEAR(f.scanner_z(z), c.slice_axis == 0 ? placed.x : placed.y, 1e-9) << z;
  }
  ASSERT_GE(err_model.size(), 20u);
  std::sort(err_model.begin(), err_model.end());
  std::sort(err_scanner.begin(), err_scanner.end());
  EXPECT_LE(err_model[err_model.size() / 2], 0.5) << "median pith error, slice axes";
  EXPECT_LE(err_scanner[err_scanner.size() / 2], 0.5) << "median pith error, scanner frame";
  EXPECT_LE(err_scanner.back(), 1.5) << "worst pith error, scanner frame";

  // The frame, slice_dir included, reads back from log.json as written.
  std::ifstream in(dir / "scan" / "log.json");
  const std::string json((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_THAT(json, HasSubstr("\"slice_dir\""));
}

INSTANTIATE_TEST_SUITE_P(ScannerFrame, CrossSections, ::testing::ValuesIn(kCross),
                         [](const ::testing::TestParamInfo<CrossCase>& p) {
                           return std::string(p.param.name);
                         });

// log.json's frame of a coronal scan: slice_dir is written and reads back; an axial frame's file
// is as before slice_dir existed (no key; read, it is (0, 0, z_dir)); a slice_dir in the slices'
// plane, or a z_dir against it, is refused naming the key.
TEST(ScannerFrame, CrossSectionFrameInLogJson) {
  LogModel log = scene().truth;
  ScannerFrame f;
  f.origin_mm = kCrossOrigin;
  f.row_dir = {1, 0, 0};
  f.col_dir = {0, 0, -1};
  f.slice_dir = {0, 1, 0};
  f.z0_mm = kCrossOrigin.y;
  const Vec2 pith0 = log.stem.pith[0];
  place_in_scanner_frame(log, {kCrossOrigin.x, kCrossOrigin.y}, f);
  EXPECT_EQ(log.stem.pith[0], pith0) << "a coronal model stays in the slices' axes";
  EXPECT_EQ(f.to_scanner({2, 3, 5}), (kCrossOrigin + Vec3{2, 5, -3}));
  const std::string text = log_to_json(log);
  Result<LogModel> back = log_from_json(text);
  ASSERT_TRUE(back) << back.error().message();
  EXPECT_EQ(back.value().scanner_frame->slice_dir, f.slice_dir);
  EXPECT_EQ(log_to_json(back.value()), text);

  ScannerFrame axial;
  axial.z_dir = -1;
  log.scanner_frame = axial;
  const std::string axial_text = log_to_json(log);
  EXPECT_EQ(axial_text.find("slice_dir"), std::string::npos);
  back = log_from_json(axial_text);
  ASSERT_TRUE(back) << back.error().message();
  EXPECT_EQ(back.value().scanner_frame->slice_dir, (Vec3{0, 0, -1}));
  EXPECT_EQ(back.value().scanner_frame->to_scanner({2, 3, 5}), (Vec3{2, 3, -5}));

  const auto refused = [&](const std::function<void(nlohmann::ordered_json&)>& edit) {
    auto j = nlohmann::ordered_json::parse(text);
    edit(j["scanner_frame"]);
    Result<LogModel> r = log_from_json(j.dump());
    return r ? std::string("(accepted)") : r.error().message();
  };
  EXPECT_THAT(refused([](auto& fj) { fj["z_dir"] = -1; }),
              HasSubstr("scanner_frame.z_dir: -1 points against slice_dir (0, 1, 0)"));
  EXPECT_THAT(refused([](auto& fj) {
                fj["slice_dir"] = {1, 0, 0};
              }),
              HasSubstr("scanner_frame.slice_dir: is not perpendicular to row_dir and col_dir"));
  EXPECT_THAT(refused([](auto& fj) {
                fj["slice_dir"] = {0, 2, 0};
              }),
              HasSubstr("scanner_frame.slice_dir: (0, 2, 0) is not a unit vector"));
}

// A tiny NRRD (12 x 10 x 3) whose index axes run along `row`, `col` and `slices`.
fs::path write_oriented_nrrd(const fs::path& dir, const Vec3& row, const Vec3& col,
                             const Vec3& slices) {
  fs::create_directories(dir);
  const fs::path file = dir / "v.nrrd";
  const auto v = [](const Vec3& d, double s) {
    std::ostringstream t;
    t.precision(17);
    t << "(" << s * d.x << "," << s * d.y << "," << s * d.z << ")";
    return t.str();
  };
  std::ofstream out(file, std::ios::binary);
  out << "NRRD0004\ntype: short\ndimension: 3\nspace dimension: 3\nsizes: 12 10 3\n"
      << "space directions: " << v(row, 0.5) << " " << v(col, 0.5) << " " << v(slices, 2.0)
      << "\nspace origin: (10,20,30)\nendian: little\nencoding: raw\n\n";
  std::vector<int16_t> data(12 * 10 * 3);
  for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<int16_t>(i);
  out.write(reinterpret_cast<const char*>(data.data()),
            static_cast<std::streamsize>(data.size() * sizeof(int16_t)));
  return file;
}

// to_scanner_axes on its own: every series along the scanner's axes is accepted, a coronal or
// sagittal one as stored (same geometry, same pixels) with a note naming its orientation; a
// direction off every axis is refused with one line naming the input and the orientation.
TEST(ScannerFrame, AnyAxisAlignedOrientationOnlyObliqueRefused) {
  test::TempDir dir;
  const struct {
    const char* name;
    Vec3 row, col, slices;
    const char* words;
  } kAccepted[] = {
      {"coronal",
       {1, 0, 0},
       {0, 0, -1},
       {0, 1, 0},
       "coronal slices: the log's z along the "
       "scanner's +y"},
      {"coronal_rows_along_z", {0, 0, 1}, {1, 0, 0}, {0, 1, 0}, "coronal slices"},
      {"sagittal",
       {0, 1, 0},
       {0, 0, -1},
       {-1, 0, 0},
       "sagittal slices: the log's z along the "
       "scanner's -x"},
      {"sagittal_reversed", {0, 0, 1}, {0, 1, 0}, {1, 0, 0}, "sagittal slices"},
  };
  for (const auto& c : kAccepted) {
    const fs::path file = write_oriented_nrrd(dir / c.name, c.row, c.col, c.slices);
    auto opened = open_ct(file);
    ASSERT_TRUE(opened.ok()) << c.name << ": " << opened.error().message();
    EXPECT_THAT(slice_orientation_text(opened.value()->geometry()), HasSubstr(c.words));
    const VolumeGeometry before = opened.value()->geometry();
    auto src = to_scanner_axes(std::move(opened).value(), c.name);
    ASSERT_TRUE(src.ok()) << c.name << ": " << src.error().message();
    const VolumeGeometry& g = src.value()->geometry();
    EXPECT_EQ(g.origin, before.origin) << c.name;
    EXPECT_EQ(g.orientation, before.orientation) << c.name;
    EXPECT_EQ(g.slice_dir, before.slice_dir) << c.name;
    EXPECT_FALSE(g.file_axes.has_value()) << c.name;
    ASSERT_FALSE(src.value()->notes().empty()) << c.name;
    EXPECT_THAT(src.value()->notes().back(), HasSubstr(c.words)) << c.name;
    Slice s;
    ASSERT_TRUE(src.value()->read(1, s).ok()) << c.name;
    EXPECT_EQ(s.width, 12);
    EXPECT_EQ(s.at(7, 3), 120 + 3 * 12 + 7) << c.name;
  }

  // Coronal with its columns 10 degrees off -z, and a volume whose third axis is not the
  // slices' normal but lies in their plane: neither is a stack of cross-sections.
  const double cs = std::cos(10 * kPi / 180), sn = std::sin(10 * kPi / 180);
  const struct {
    const char* name;
    Vec3 row, col, slices;
    const char* words;
  } kRefused[] = {
      {"coronal_tilted",
       {1, 0, 0},
       {0, sn, -cs},
       {0, cs, sn},
       "slice orientation rows (1, 0, 0), columns (0, 0.173648, -0.984808), slices along (0, "
       "0.984808, 0.173648) is oblique"},
      {"slices_in_plane",
       {1, 0, 0},
       {0, 1, 0},
       {1, 0, 0},
       "slice orientation rows (1, 0, 0), columns (0, 1, 0), slices along (1, 0, 0) is oblique"},
  };
  for (const auto& c : kRefused) {
    const fs::path file = write_oriented_nrrd(dir / c.name, c.row, c.col, c.slices);
    auto opened = open_ct(file);
    if (!opened.ok()) {
      // The reader may refuse a degenerate volume first; either way it is not read.
      ADD_FAILURE() << c.name << ": the reader refused it: " << opened.error().message();
      continue;
    }
    EXPECT_THAT(slice_orientation_text(opened.value()->geometry()), HasSubstr("oblique"));
    auto src = to_scanner_axes(std::move(opened).value(), c.name);
    ASSERT_FALSE(src.ok()) << c.name;
    EXPECT_THAT(src.error().message(), HasSubstr(std::string(c.name) + ": " + c.words));
    EXPECT_THAT(src.error().message(), HasSubstr("Sawyer does not resample oblique scans"));
    EXPECT_EQ(src.error().message().find('\n'), std::string::npos) << "one line";
  }
}

// A series tilted 10 degrees about x (a tilted gantry's columns) is refused with one line that
// names the input and the orientation; nothing is written.
TEST(ScannerFrame, ObliqueSeriesRefused) {
  ASSERT_FALSE(scene().slices.empty()) << "no phantom";
  test::TempDir dir;
  const double c = std::cos(10 * kPi / 180), s = std::sin(10 * kPi / 180);
  write_gdcm_series(dir / "ct", scene(), {{1, 0, 0}, {0, 1, 0}}, {1, 0, 0, 0, c, s});
  std::string text;
  EXPECT_EQ(test::run_sawyer(
                "scan " + test::quoted(dir / "ct") + " -o " + test::quoted(dir / "scan"), &text),
            1)
      << text;
  EXPECT_THAT(text, HasSubstr((dir / "ct").string() + ": slice orientation rows (1, 0, 0), "
                                                      "columns (0, 0.984808, 0.173648)"));
  EXPECT_THAT(text, HasSubstr("slices along (0, -0.173648, 0.984808) is oblique"));
  EXPECT_FALSE(fs::exists(dir / "scan"));
}

// to_scanner_axes on its own: a transposed, flipped source reads back as the scene's pixels,
// with the origin at the scene's pixel (0, 0).
TEST(ScannerFrame, TurnedSourceShowsTheScene) {
  ASSERT_FALSE(scene().slices.empty()) << "no phantom";
  test::TempDir dir;
  const Axes ax{{0, -1, 0}, {-1, 0, 0}};
  write_gdcm_series(dir / "ct", scene(), ax, iop_of(ax));
  auto opened = open_ct(dir / "ct");
  ASSERT_TRUE(opened.ok()) << opened.error().message();
  auto turned = to_scanner_axes(std::move(opened).value(), "ct");
  ASSERT_TRUE(turned.ok()) << turned.error().message();
  const VolumeGeometry& g = turned.value()->geometry();
  EXPECT_NEAR(g.origin.x, kA, 1e-6);
  EXPECT_NEAR(g.origin.y, kA, 1e-6);
  EXPECT_EQ(g.orientation, (std::array<double, 6>{1, 0, 0, 0, 1, 0}));
  ASSERT_TRUE(g.file_axes.has_value());
  EXPECT_EQ(g.file_axes->orientation[1], -1.0);
  Slice s;
  ASSERT_TRUE(turned.value()->read(0, s).ok());
  // (0,-1,0) x (-1,0,0) = (0,0,-1): the first slice is the scene's last.
  EXPECT_EQ(g.slice_dir.z, -1.0);
  const Slice& want = scene().slices.back();
  for (int row : {0, 57, 200, 511})
    for (int col : {0, 13, 160, 511})
      EXPECT_NEAR(s.at(col, row), std::round(want.at(col, row)), 0.5) << col << " " << row;
}

}  // namespace
}  // namespace sawyer::ct

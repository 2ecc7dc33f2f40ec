// to_scanner_axes(): axial slices mirrored and/or transposed so that x runs along the scanner's
// +x and y along +y; coronal and sagittal ones kept as stored; oblique ones refused (see
// scanner_frame.h).
#include "sawyer/ct/io/scanner_frame.h"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace sawyer::ct {

namespace {

// The scanner axis (0 = x, 1 = y, 2 = z) a unit vector runs along, or -1 when it is further
// than kAxialTolerance off every axis.
int axis_of(const Vec3& d) {
  const Vec3 u = d.normalized();
  const double c[3] = {std::abs(u.x), std::abs(u.y), std::abs(u.z)};
  for (int a = 0; a < 3; ++a) {
    if (c[(a + 1) % 3] <= kAxialTolerance && c[(a + 2) % 3] <= kAxialTolerance) return a;
  }
  return -1;
}

double component(const Vec3& v, int a) { return a == 0 ? v.x : a == 1 ? v.y : v.z; }

std::string vec_text(const Vec3& v) {
  char s[96];
  std::snprintf(s, sizeof s, "(%.6g, %.6g, %.6g)", v.x, v.y, v.z);
  return s;
}

std::string tolerance_text() {
  char s[32];
  std::snprintf(s, sizeof s, "%g", kAxialTolerance);
  return s;
}

// "+x", "-y", ...: the scanner axis `a` that direction d runs along, with its sign.
std::string axis_text(const Vec3& d, int a) {
  return std::string(component(d, a) < 0 ? "-" : "+") + "xyz"[a];
}

// The three directions of a geometry, each named by the scanner axis it runs along (-1: none).
struct SliceAxes {
  Vec3 row, col;
  int row_axis, col_axis, slice_axis;
  bool along_axes() const {
    return row_axis >= 0 && col_axis >= 0 && slice_axis >= 0 && row_axis != col_axis &&
           row_axis != slice_axis && col_axis != slice_axis;
  }
};

SliceAxes slice_axes(const VolumeGeometry& g) {
  const auto& o = g.orientation;
  SliceAxes a{{o[0], o[1], o[2]}, {o[3], o[4], o[5]}, 0, 0, 0};
  a.row_axis = axis_of(a.row);
  a.col_axis = axis_of(a.col);
  a.slice_axis = axis_of(g.slice_dir);
  return a;
}

// "coronal slices: the log's z along the scanner's +y", for a geometry along the axes.
std::string orientation_name(const VolumeGeometry& g, int slice_axis) {
  static const char* const kPlane[3] = {"sagittal", "coronal", "axial"};
  return std::string(kPlane[slice_axis]) + " slices: the log's z along the scanner's " +
         axis_text(g.slice_dir, slice_axis);
}

// How new pixel (i', j') reads file pixel (i, j): along each new axis, which file index it
// follows and whether it counts down.
struct PixelMap {
  bool transposed = false;  // new columns follow the file's rows
  bool flip_x = false;      // new column 0 is the last file index along x
  bool flip_y = false;      // new row 0 is the last file index along y
  bool identity() const { return !transposed && !flip_x && !flip_y; }
};

class ScannerAxesSource final : public SliceSource {
 public:
  ScannerAxesSource(std::unique_ptr<SliceSource> src, const PixelMap& m, VolumeGeometry g,
                    std::string note)
      : src_(std::move(src)), map_(m), geometry_(std::move(g)), notes_(src_->notes()) {
    notes_.push_back(std::move(note));
  }

  Format format() const override { return src_->format(); }
  const VolumeGeometry& geometry() const override { return geometry_; }
  std::string description() const override { return src_->description(); }
  const std::vector<std::string>& notes() const override { return notes_; }

  Status read(int i, Slice& out) override {
    if (map_.identity()) return src_->read(i, out);  // only a note added: no copy
    if (Status st = src_->read(i, buf_); !st) return st;
    const int w = buf_.width, h = buf_.height;
    const int nw = map_.transposed ? h : w, nh = map_.transposed ? w : h;
    out.index = buf_.index;
    out.z = buf_.z;
    out.width = nw;
    out.height = nh;
    out.hu.resize(static_cast<size_t>(nw) * nh);
    for (int r = 0; r < nh; ++r) {
      const int ny = map_.flip_y ? nh - 1 - r : r;
      for (int c = 0; c < nw; ++c) {
        const int nx = map_.flip_x ? nw - 1 - c : c;
        // (nx, ny) index the file along the new x and y; transposed, new x is the file's row.
        const int col = map_.transposed ? ny : nx, row = map_.transposed ? nx : ny;
        out.hu[static_cast<size_t>(r) * nw + c] = buf_.hu[static_cast<size_t>(row) * w + col];
      }
    }
    return Status::Ok();
  }

 private:
  std::unique_ptr<SliceSource> src_;
  PixelMap map_;
  VolumeGeometry geometry_;
  std::vector<std::string> notes_;
  Slice buf_;
};

}  // namespace

Result<std::unique_ptr<SliceSource>> to_scanner_axes(std::unique_ptr<SliceSource> source,
                                                     const std::string& where) {
  const VolumeGeometry& g = source->geometry();
  const SliceAxes a = slice_axes(g);
  const Vec3 &row = a.row, &col = a.col;
  if (!a.along_axes()) {
    return Error(where, "slice orientation rows " + vec_text(row) + ", columns " + vec_text(col) +
                            ", slices along " + vec_text(g.slice_dir) +
                            " is oblique: rows, columns and slices must each run along one of "
                            "the scanner's axes (direction cosines within " +
                            tolerance_text() + "); Sawyer does not resample oblique scans");
  }
  if (a.slice_axis != 2) {
    // Coronal or sagittal: no turn of the slices puts x and y on the scanner's x and y, and the
    // slices are the log's cross-sections as they are, so they are read as stored;
    // scanner_frame_of() records the frame that maps the model back (ScannerFrame).
    std::string note = orientation_name(g, a.slice_axis) + " (rows " + vec_text(row) +
                       ", columns " + vec_text(col) +
                       " in the file); x and y are measured in the slices as stored";
    VolumeGeometry same = g;
    return std::unique_ptr<SliceSource>(
        new ScannerAxesSource(std::move(source), PixelMap{}, std::move(same), std::move(note)));
  }
  PixelMap m;
  m.transposed = a.row_axis == 1;
  // The file direction that becomes the new x (and y), and whether it points the wrong way.
  const Vec3& along_x = m.transposed ? col : row;
  const Vec3& along_y = m.transposed ? row : col;
  m.flip_x = component(along_x, 0) < 0;
  m.flip_y = component(along_y, 1) < 0;
  const double dir_z = g.slice_dir.z < 0 ? -1.0 : 1.0;
  // Along the axes already (within the tolerance): nothing to turn; z's sign is slice_dir.z.
  if (m.identity()) return source;

  VolumeGeometry n = g;
  n.file_axes = VolumeGeometry::FileAxes{g.origin, g.orientation};
  if (m.transposed) {
    n.width = g.height;
    n.height = g.width;
    n.spacing_x = g.spacing_y;
    n.spacing_y = g.spacing_x;
  }
  // File pixel of the new pixel (0, 0): the far end of each flipped axis.
  const int last_x = (m.transposed ? g.height : g.width) - 1;
  const int last_y = (m.transposed ? g.width : g.height) - 1;
  const int fx = m.flip_x ? last_x : 0, fy = m.flip_y ? last_y : 0;
  const int fcol = m.transposed ? fy : fx, frow = m.transposed ? fx : fy;
  n.origin = g.origin + (fcol * g.spacing_x) * row + (frow * g.spacing_y) * col;
  n.orientation = {1, 0, 0, 0, 1, 0};
  n.slice_dir = {0, 0, dir_z};
  std::string note = "slices ";
  if (m.flip_x || m.flip_y) {
    note += std::string("mirrored") + (m.flip_x ? " in x" : "") +
            (m.flip_x && m.flip_y ? " and" : "") + (m.flip_y ? " in y" : "");
  }
  if (m.transposed) note += std::string(m.flip_x || m.flip_y ? " and " : "") + "transposed";
  note += " (rows " + vec_text(row) + ", columns " + vec_text(col) +
          " in the file) so that x and y run along the scanner's +x and +y";
  return std::unique_ptr<SliceSource>(new ScannerAxesSource(std::move(source), m, n, note));
}

std::string slice_orientation_text(const VolumeGeometry& g) {
  const SliceAxes a = slice_axes(g);
  if (!a.along_axes()) return "oblique slices: the scan refuses them";
  return orientation_name(g, a.slice_axis);
}

}  // namespace sawyer::ct

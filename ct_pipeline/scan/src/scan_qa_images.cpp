// QA images of a scan (see scan_log.h).
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>

#include "sawyer/core/file_util.h"
#include "sawyer/ct/scan/scan_log.h"

namespace sawyer::ct {

namespace fs = std::filesystem;

namespace {

// A slice as an 8-bit image (window -1000..+500 HU) with the stem drawn on it: outer contour
// green, heartwood border yellow, pith a red cross. Pixel (col, row) is (x / sx, y / sy) in the
// scan's image axes (rows along the scanner's +x); the label gives the pith in the scanner frame
// (log.json's x, y; for a coronal or sagittal scan its x, y, z) and the height both from the
// first slice and as the scanner's coordinate along the slices.
cv::Mat qa_image(const Slice& s, const VolumeGeometry& g, const StemSliceRecord& r) {
  cv::Mat grey(s.height, s.width, CV_8UC1);
  for (int row = 0; row < s.height; ++row)
    for (int col = 0; col < s.width; ++col) {
      const double v = (s.at(col, row) + 1000.0) / 1500.0 * 255.0;
      grey.at<unsigned char>(row, col) = static_cast<unsigned char>(std::clamp(v, 0.0, 255.0));
    }
  cv::Mat img;
  cv::cvtColor(grey, img, cv::COLOR_GRAY2BGR);
  const auto to_px = [&](double x, double y) {
    return cv::Point(static_cast<int>(std::lround(x / g.spacing_x)),
                     static_cast<int>(std::lround(y / g.spacing_y)));
  };
  const auto draw = [&](const std::vector<double>& radius, const std::vector<bool>& valid,
                        const cv::Scalar& colour) {
    const int n = static_cast<int>(radius.size());
    for (int k = 0; k < n; ++k) {
      const int k2 = (k + 1) % n;
      if (!valid[k] || !valid[k2]) continue;
      const double w1 = kTwoPi * k / n, w2 = kTwoPi * k2 / n;
      cv::line(img, to_px(r.pith.x + radius[k] * std::cos(w1), r.pith.y + radius[k] * std::sin(w1)),
               to_px(r.pith.x + radius[k2] * std::cos(w2), r.pith.y + radius[k2] * std::sin(w2)),
               colour, 1, cv::LINE_AA);
    }
  };
  draw(r.contour.radius, r.contour.valid, cv::Scalar(0, 220, 0));
  if (r.heartwood.present) draw(r.heartwood.radius, r.heartwood.valid, cv::Scalar(0, 220, 255));
  cv::drawMarker(img, to_px(r.pith.x, r.pith.y), cv::Scalar(0, 0, 255), cv::MARKER_CROSS, 12, 2);
  char text[2][96];
  if (const ScannerFrame f = scanner_frame_of(g); !f.axial()) {
    // Coronal or sagittal: log.json stays in the slices' axes; the label says where in the
    // scanner the pith and the slice are.
    const Vec3 p = f.to_scanner({r.pith.x, r.pith.y, r.z});
    std::snprintf(text[0], sizeof text[0], "z %.1f mm (scanner %c %.1f mm)", r.z,
                  "xyz"[f.slice_axis()], f.scanner_z(r.z));
    std::snprintf(text[1], sizeof text[1], "pith (%.1f, %.1f, %.1f) mm, scanner frame", p.x, p.y,
                  p.z);
  } else {
    std::snprintf(text[0], sizeof text[0], "z %.1f mm (scanner z %.1f mm)", r.z,
                  g.origin.z + (g.slice_dir.z < 0 ? -r.z : r.z));
    std::snprintf(text[1], sizeof text[1], "pith (%.1f, %.1f) mm, scanner frame",
                  r.pith.x + g.origin.x, r.pith.y + g.origin.y);
  }
  for (int line = 0; line < 2; ++line)
    cv::putText(img, text[line], {8, 20 + 18 * line}, cv::FONT_HERSHEY_SIMPLEX, 0.5,
                cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  return img;
}

// The pith's x and y against z: raw detections as dots, the smoothed track as a line, outliers
// in red. Each coordinate is drawn relative to its mean, ±20 mm over the plot's height.
cv::Mat pith_plot(const StemScan& scan, const ScanQaDetail& qa) {
  const int w = 900, h = 420, pad = 40;
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  const auto& s = scan.slices;
  if (s.size() < 2) return img;
  double mx = 0, my = 0;
  for (const auto& r : s) {
    mx += r.pith.x;
    my += r.pith.y;
  }
  mx /= s.size();
  my /= s.size();
  const double z0 = s.front().z, z1 = s.back().z;
  const int half = (h - 3 * pad) / 4;  // two panels
  // Heights where the QA verdict found the pith suspect, shaded across both panels.
  for (size_t i = 0; i < s.size() && i < qa.slices.size(); ++i) {
    if (!qa.slices[i].pith_suspect) continue;
    const double zl = i > 0 ? 0.5 * (s[i - 1].z + s[i].z) : s[i].z;
    const double zr = i + 1 < s.size() ? 0.5 * (s[i].z + s[i + 1].z) : s[i].z;
    const auto px = [&](double z) {
      return pad + static_cast<int>((z - z0) / std::max(z1 - z0, 1e-9) * (w - 2 * pad));
    };
    cv::rectangle(img, {px(zl), pad / 2}, {std::max(px(zr), px(zl) + 1), h - pad},
                  cv::Scalar(200, 220, 255), cv::FILLED);
  }
  for (int panel = 0; panel < 2; ++panel) {
    const int cy = pad + half + panel * (2 * half + pad);
    cv::line(img, {pad, cy}, {w - pad, cy}, cv::Scalar(200, 200, 200));
    cv::putText(img, panel == 0 ? "pith x - mean (+-20 mm)" : "pith y - mean (+-20 mm)",
                {pad, cy - half - 5}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1,
                cv::LINE_AA);
    cv::Point prev;
    for (size_t i = 0; i < s.size(); ++i) {
      const int x = pad + static_cast<int>((s[i].z - z0) / std::max(z1 - z0, 1e-9) * (w - 2 * pad));
      const double v = panel == 0 ? s[i].pith.x - mx : s[i].pith.y - my;
      const cv::Point p(x, cy - static_cast<int>(v / 20.0 * half));
      if (i > 0) cv::line(img, prev, p, cv::Scalar(160, 60, 0), 2, cv::LINE_AA);
      prev = p;
      if (s[i].pith_refined.found) {
        const double rv =
            panel == 0 ? s[i].pith_refined.pith_mm.x - mx : s[i].pith_refined.pith_mm.y - my;
        cv::circle(img, {x, cy - static_cast<int>(rv / 20.0 * half)}, 2,
                   s[i].pith_outlier ? cv::Scalar(0, 0, 255) : cv::Scalar(60, 60, 60), -1);
      }
    }
  }
  char text[96];
  std::snprintf(text, sizeof text, "z %.0f .. %.0f mm (shaded: pith suspect)", z0, z1);
  cv::putText(img, text, {w / 2 - 60, h - 10}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0),
              1, cv::LINE_AA);
  return img;
}

// The unrolled view with each fitted knot crossing its cylinder drawn where its formula puts
// it, a circle of its fitted diameter (red: dead there, green: sound) with its id.
cv::Mat unrolled_image(const UnrolledView& v, const std::vector<Knot>& knots) {
  const double r = v.r_mm, z_first = v.z_first, scale = v.px_per_mm;
  const int w = v.width;
  cv::Mat grey(v.height, v.width, CV_8UC1, const_cast<std::uint8_t*>(v.grey.data()));
  cv::Mat img;
  cv::cvtColor(grey, img, cv::COLOR_GRAY2BGR);
  for (const Knot& k : knots) {
    if (r > k.r_end) continue;
    const cv::Point at(static_cast<int>(k.azimuth_at(r) / kTwoPi * w),
                       static_cast<int>((k.height_at(r) - z_first) * scale));
    const int rad = std::max(2, static_cast<int>(0.5 * k.diameter_at(r) * scale));
    const cv::Scalar colour = k.dead_at(r) ? cv::Scalar(0, 0, 255) : cv::Scalar(0, 200, 0);
    cv::circle(img, at, rad, colour, 1, cv::LINE_AA);
    cv::putText(img, std::to_string(k.id), at + cv::Point(rad + 2, 4), cv::FONT_HERSHEY_SIMPLEX,
                0.35, colour, 1, cv::LINE_AA);
  }
  char text[64];
  std::snprintf(text, sizeof text, "r = %.0f mm", r);
  cv::putText(img, text, {4, 14}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(255, 255, 0), 1,
              cv::LINE_AA);
  return img;
}

// One line per knot: the fitted formula, the diameter profile and the fit's quality.
std::string knot_table(const KnotScan& k) {
  std::string out =
      "id,z0_mm,a,b,omega0_rad,twist,r_dead_mm,r_end_mm,d_dead_mm,exponent,height_at_50_mm,"
      "azimuth_at_50_deg,axis_rms_mm,diameter_rms_mm,shells\n";
  char line[512];
  for (size_t i = 0; i < k.knots.size(); ++i) {
    const Knot& q = k.knots[i];
    std::snprintf(line, sizeof line,
                  "%d,%.2f,%.4f,%.4f,%.4f,%.4f,%.1f,%.1f,%.2f,%.3f,%.1f,%.1f,%.2f,%.2f,%d\n", q.id,
                  q.z0, q.a, q.b, q.omega0, q.twist, q.r_dead, q.r_end, q.diameter.d_dead,
                  q.diameter.exponent, q.height_at(50), q.azimuth_at(50) * 180 / kPi,
                  k.fits[i].axis_rms_mm, k.fits[i].diameter_rms_mm, q.support);
    out += line;
  }
  return out;
}

}  // namespace

// The log's cylinder of pith distance r unrolled: azimuth 0..2π left to right, height down the
// image, both at the same scale (2 px/mm for a short scan, down to 0.5 px/mm for a long one, so
// knots keep their shape), HU windowed -700..+200 so knots stand out of the dry heartwood; rows
// between two slices take the nearer slice.
UnrolledViewBuilder::UnrolledViewBuilder(const VolumeGeometry& g, const Stem& stem, double r)
    : stem_(&stem), z_(g.z), sx_(g.spacing_x), sy_(g.spacing_y) {
  const int n = g.slice_count();
  const std::vector<double>& zs = g.z;
  const double z_first = n ? zs.front() : 0.0, extent = n ? zs.back() - zs.front() : 0.0;
  const double scale = std::clamp(2000.0 / std::max(extent, 1.0), 0.5, 2.0);  // px per mm
  const int w = std::max(16, static_cast<int>(std::lround(kTwoPi * r * scale)));
  const int h = std::max(1, static_cast<int>(std::lround(extent * scale)) + 1);
  view_.r_mm = r;
  view_.z_first = z_first;
  view_.px_per_mm = scale;
  view_.width = w;
  view_.height = h;
  view_.grey.assign(static_cast<size_t>(w) * h, 0);
  rows_of_.assign(static_cast<size_t>(n), {});
  for (int row = 0; row < h && n > 0; ++row) {
    const double z = z_first + row / scale;
    const auto it = std::lower_bound(zs.begin(), zs.end(), z);
    int i = static_cast<int>(it - zs.begin());
    if (i >= n || (i > 0 && z - zs[static_cast<size_t>(i - 1)] < zs[static_cast<size_t>(i)] - z))
      --i;
    const double zi = zs[static_cast<size_t>(i)];
    if (zi < stem.z_begin() || zi > stem.z_end()) continue;
    rows_of_[static_cast<size_t>(i)].push_back(row);
  }
}

template <class Sample>
void UnrolledViewBuilder::fill(int i, const Sample& hu_at) {
  if (i < 0 || i >= static_cast<int>(rows_of_.size())) return;
  const std::vector<int>& rows = rows_of_[static_cast<size_t>(i)];
  if (rows.empty()) return;
  const Vec2 c = stem_->pith_at(z_[static_cast<size_t>(i)]);
  const int w = view_.width;
  const double r = view_.r_mm;
  std::vector<std::uint8_t> line(static_cast<size_t>(w));
  for (int k = 0; k < w; ++k) {
    const double om = kTwoPi * (k + 0.5) / w;
    const double hu = hu_at(c.x + r * std::cos(om), c.y + r * std::sin(om));
    line[static_cast<size_t>(k)] =
        static_cast<std::uint8_t>(std::clamp((hu + 700.0) / 900.0 * 255.0, 0.0, 255.0));
  }
  for (int row : rows)
    std::copy(line.begin(), line.end(), &view_.grey[static_cast<size_t>(row) * w]);
}

void UnrolledViewBuilder::add(int i, const LogVolume& volume) {
  fill(i, [&](double x, double y) { return volume.at(i, x, y); });
}

void UnrolledViewBuilder::add(int i, const Slice& s) {
  // LogVolume::at on the whole slice: bilinear on the 16-bit HU, air outside.
  fill(i, [&](double x, double y) {
    return bilinear_hu([&](std::size_t k) { return static_cast<float>(quantise_hu(s.hu[k])); },
                       s.width, s.height, x / sx_, y / sy_);
  });
}

UnrolledView unroll_view(const LogVolume& vol, const Stem& stem, double r) {
  UnrolledViewBuilder b(vol.geometry(), stem, r);
  for (int i = 0; i < vol.slice_count(); ++i) b.add(i, vol);
  return b.take();
}

std::vector<int> qa_image_slices(int n, int slices) {
  std::vector<int> out;
  const int k = std::max(1, slices);
  for (int q = 0; q < k && n > 0; ++q) out.push_back(static_cast<int>((q + 0.5) * n / k));
  return out;
}

Status write_scan_qa_images(const ScanResult& scan, SliceSource& src, const fs::path& dir,
                            int slices) {
  const StemScan& s = scan.stem;
  const int n = src.geometry().slice_count();
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return Error(dir.string(), "cannot create the QA folder: " + ec.message());
  Slice slice;
  for (int i : qa_image_slices(n, slices)) {
    if (Status r = src.read(i, slice); !r) return r;
    char name[32];
    std::snprintf(name, sizeof name, "slice_%04d.png", i + 1);
    if (!cv::imwrite((dir / name).string(),
                     qa_image(slice, src.geometry(), s.slices[static_cast<size_t>(i)])))
      return Error((dir / name).string(), "cannot write the QA image");
  }
  if (!cv::imwrite((dir / "pith_track.png").string(), pith_plot(s, scan.qa)))
    return Error((dir / "pith_track.png").string(), "cannot write the QA image");
  for (const UnrolledView& v : scan.unrolled) {
    const std::string name = "unrolled_r" + std::to_string(static_cast<int>(v.r_mm)) + ".png";
    if (!cv::imwrite((dir / name).string(), unrolled_image(v, scan.knots.knots)))
      return Error((dir / name).string(), "cannot write the QA image");
  }
  return write_text_file_atomic(dir / "knots.csv", knot_table(scan.knots));
}

}  // namespace sawyer::ct

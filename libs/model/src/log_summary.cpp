#include "sawyer/model/log_summary.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <ostream>

namespace sawyer {
namespace {

double equal_area_diameter(double area) { return 2.0 * std::sqrt(std::max(area, 0.0) / kPi); }

// Mean equal-area diameter over the samples within `span` mm of the first (from_top = false) or
// last sample; at least one sample.
double end_diameter(const Stem& s, double span, bool from_top) {
  const int n = s.slice_count();
  const int count = std::clamp(static_cast<int>(std::floor(span / s.dz_mm)) + 1, 1, n);
  double acc = 0;
  for (int c = 0; c < count; ++c) acc += equal_area_diameter(s.area(from_top ? n - 1 - c : c));
  return acc / count;
}

}  // namespace

LogSummary summarize(const LogModel& log) {
  LogSummary out;
  const Stem& s = log.stem;
  const int n = s.slice_count();
  if (n == 0) return out;
  out.length_mm = s.length_mm();
  out.butt_diameter_mm = end_diameter(s, 100.0, false);
  out.top_diameter_mm = end_diameter(s, 100.0, true);
  double dsum = 0, vol = 0, oval = 0;
  out.min_radius_mm = 1e300;
  out.max_radius_mm = 0;
  for (int i = 0; i < n; ++i) {
    const double a = s.area(i);
    vol += a * s.dz_mm;
    dsum += equal_area_diameter(a);
    const auto& row = s.radius[i];
    const auto [mn, mx] = std::minmax_element(row.begin(), row.end());
    out.min_radius_mm = std::min(out.min_radius_mm, *mn);
    out.max_radius_mm = std::max(out.max_radius_mm, *mx);
    // Diameter across the pith at each angle: r(ω) + r(ω + π).
    const int na = s.n_angles;
    double dmin = 1e300, dmax = 0;
    for (int k = 0; k < na / 2; ++k) {
      const double d = row[k] + row[(k + na / 2) % na];
      dmin = std::min(dmin, d);
      dmax = std::max(dmax, d);
    }
    oval += dmax > 0 ? 1.0 - dmin / dmax : 0.0;
  }
  out.mean_diameter_mm = dsum / n;
  out.volume_m3 = vol * 1e-9;
  out.ovality = oval / n;
  out.taper_mm_per_m =
      out.length_mm > 0 ? (out.butt_diameter_mm - out.top_diameter_mm) / (out.length_mm * 1e-3) : 0;

  // Pith: least-squares straight line x(z), y(z); wander = largest distance from it.
  double mz = 0, mx = 0, my = 0;
  for (int i = 0; i < n; ++i) mz += s.z_at(i), mx += s.pith[i].x, my += s.pith[i].y;
  mz /= n, mx /= n, my /= n;
  double szz = 0, szx = 0, szy = 0;
  for (int i = 0; i < n; ++i) {
    const double dz = s.z_at(i) - mz;
    szz += dz * dz, szx += dz * (s.pith[i].x - mx), szy += dz * (s.pith[i].y - my);
  }
  const double kx = szz > 0 ? szx / szz : 0, ky = szz > 0 ? szy / szz : 0;
  out.pith_tilt_mm_per_m = std::hypot(kx, ky) * 1e3;
  for (int i = 0; i < n; ++i) {
    const double dz = s.z_at(i) - mz;
    const double ex = s.pith[i].x - (mx + kx * dz), ey = s.pith[i].y - (my + ky * dz);
    out.pith_wander_mm = std::max(out.pith_wander_mm, std::hypot(ex, ey));
  }

  out.knot_count = static_cast<int>(log.knots.size());
  for (size_t i = 0; i < log.knots.size(); ++i) {
    const Knot& k = log.knots[i];
    if (k.has_dead_part())
      ++out.dead_knots;
    else
      ++out.sound_knots;
    if (k.max_diameter() > out.largest_knot_diameter_mm) {
      out.largest_knot_diameter_mm = k.max_diameter();
      out.largest_knot = static_cast<int>(i);
    }
  }
  out.has_heartwood = s.has_heartwood();
  if (out.has_heartwood) {
    double h = 0;
    size_t c = 0;
    for (const auto& row : s.heartwood)
      for (double v : row) h += v, ++c;
    out.mean_heartwood_radius_mm = c ? h / c : 0;
  }
  return out;
}

void print_summary(std::ostream& os, const LogModel& log, const LogSummary& s) {
  const auto old_flags = os.flags();
  const auto old_prec = os.precision();
  os << std::fixed;
  auto line = [&](const char* label) -> std::ostream& {
    return os << "  " << std::left << std::setw(24) << label << std::right;
  };
  os << "log " << (log.id.empty() ? "(no id)" : log.id);
  if (!log.species.empty()) os << "  species " << log.species;
  os << "\n";
  if (!log.source.empty()) line("source") << log.source << "\n";
  line("length") << std::setprecision(3) << s.length_mm * 1e-3 << " m  (" << log.stem.slice_count()
                 << " samples of " << std::setprecision(1) << log.stem.dz_mm << " mm)\n";
  line("diameter butt") << std::setprecision(1) << s.butt_diameter_mm << " mm\n";
  line("diameter top") << s.top_diameter_mm << " mm\n";
  line("diameter mean") << s.mean_diameter_mm << " mm\n";
  line("radius range") << std::setprecision(2) << s.min_radius_mm << " .. " << s.max_radius_mm
                       << " mm\n";
  line("volume") << std::setprecision(4) << s.volume_m3 << " m3\n";
  line("taper") << std::setprecision(2) << s.taper_mm_per_m << " mm/m\n";
  line("ovality") << std::setprecision(1) << 100.0 * s.ovality << " %\n";
  line("pith wander") << std::setprecision(1) << s.pith_wander_mm
                      << " mm  (from its straight line; tilt " << std::setprecision(2)
                      << s.pith_tilt_mm_per_m << " mm/m)\n";
  if (s.has_heartwood)
    line("heartwood radius mean") << std::setprecision(1) << s.mean_heartwood_radius_mm << " mm\n";
  line("knots") << s.knot_count << "  (sound " << s.sound_knots << ", with a dead part "
                << s.dead_knots << ")\n";
  if (s.largest_knot >= 0) {
    const Knot& k = log.knots[s.largest_knot];
    line("largest knot") << "id " << k.id << ": " << std::setprecision(1)
                         << s.largest_knot_diameter_mm << " mm at z " << std::setprecision(0)
                         << k.z0 << " mm, azimuth " << std::setprecision(0)
                         << wrap_angle(k.omega0) * 180.0 / kPi << " deg\n";
  }
  os.flags(old_flags);
  os.precision(old_prec);
}

}  // namespace sawyer

// Sawing inputs by name (see setup.h).
#include "sawyer/sawing/setup.h"

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "sawyer/sawing/optimise.h"

namespace sawyer::sawing {

namespace fs = std::filesystem;

std::filesystem::path bundled_data_dir() {
  // A user's own copy first, then an installed tree (<prefix>/bin/sawyer next to
  // <prefix>/share/sawyer/data), then the source tree the build came from.
  if (const char* env = std::getenv("SAWYER_DATA_DIR"); env && *env) return env;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / "share" / "sawyer" / "data";
    if (fs::is_directory(installed / "grading", ec)) return installed;
  }
  return SAWYER_DATA_DIR;
}

Result<Pattern> pattern_by_name(const std::string& s) {
  if (s == "2ex") return two_ex_pattern({});
  if (s == "4ex") return four_ex_pattern(four_ex_options());
  if (s == "tt") {
    const ThroughAndThroughOptions t;
    return through_and_through_pattern(t.boards, t.thickness_mm, t.max_width_mm, t.kerf_mm);
  }
  return read_pattern_file(s);
}

Result<PatternSet> pattern_set_by_name(const std::string& s) {
  if (s == "nordic") return read_pattern_set_file(bundled_data_dir() / "patterns/nordic.json");
  return read_pattern_set_file(s);
}

Result<GradingRules> grading_by_name(const std::string& s) {
  if (s == "nordic")
    return read_grading_file(bundled_data_dir() / "grading/nordic_appearance.json");
  if (s == "gost") return read_grading_file(bundled_data_dir() / "grading/gost_8486_like.json");
  return read_grading_file(s);
}

Result<PriceTable> prices_by_name(const std::string& file) {
  return read_price_file(file.empty() ? bundled_data_dir() / "prices/example_prices.json"
                                      : std::filesystem::path(file));
}

namespace {

std::string part_text(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace

Result<LogPosition> parse_position(const std::string& s) {
  std::vector<double> v;
  std::stringstream ss(s);
  std::string part;
  try {
    while (std::getline(ss, part, ',')) {
      size_t used = 0;
      v.push_back(std::stod(part, &used));
      if (used != part.size() || !std::isfinite(v.back())) throw std::invalid_argument(part);
    }
  } catch (const std::exception&) {
    v.clear();
  }
  if (v.empty() || v.size() > 3)
    return Error("SawNames::position", "'" + s + "' is not rot[,x[,y]] (degrees, mm, mm)");
  // A turn either way and offsets within the largest log (the optimiser's limits).
  if (std::abs(v[0]) > 360)
    return Error("SawNames::position", "rotation " + part_text(v[0]) + "° is outside -360 to 360°");
  for (size_t i = 1; i < v.size(); ++i)
    if (std::abs(v[i]) > kMaxOffsetMm)
      return Error("SawNames::position", std::string(i == 1 ? "x" : "y") + " offset " +
                                             part_text(v[i]) + " mm is outside -" +
                                             part_text(kMaxOffsetMm) + " to " +
                                             part_text(kMaxOffsetMm) + " mm");
  LogPosition p;
  p.rotation_deg = v[0];
  if (v.size() > 1) p.offset_x_mm = v[1];
  if (v.size() > 2) p.offset_y_mm = v[2];
  return p;
}

}  // namespace sawyer::sawing

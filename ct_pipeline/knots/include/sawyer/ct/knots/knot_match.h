// Found knots against true knots (issue 5's accuracy measure; bench/knot_bench and the tests).
//
// A pair has its azimuth within max_azimuth_rad and its height within max_height_mm at
// r = min(50 mm, the true knot's r_end, the found knot's r_end), nearest first (each knot in one
// pair at most). True knots count when they lie whole inside [z_lo, z_hi] and, for recall, are at
// least min_diameter_mm thick; a found knot is spurious when it pairs with no true knot at all
// (true knots outside the range included, so a knot cut by a section's end is not spurious).
#pragma once

#include <string>
#include <vector>

#include "sawyer/model/log_model.h"

namespace sawyer::ct {

struct KnotMatchOptions {
  double max_azimuth_rad = 15.0 * 3.14159265358979323846 / 180.0;
  double max_height_mm = 15.0;
  double min_diameter_mm = 10.0;
  double z_lo = -1e300, z_hi = 1e300;
};

struct KnotMatch {
  int truth_counted = 0;  // true knots inside the range, at least min_diameter_mm thick
  int truth_found = 0;    // of which paired
  int found = 0, spurious = 0;
  // Errors over the pairs whose true knot lies inside the range (any thickness).
  std::vector<double> azimuth_deg;       // |Δω| at r = min(50, both r_end)
  std::vector<double> height_mm;         // |Δz| at the same r
  std::vector<double> r_dead_mm;         // true knots with a dead part before their end
  std::vector<double> r_dead_signed_mm;  // the same pairs, found − true (> 0: dead part too short)
  std::vector<double> r_end_mm;          // true end = min(r_end, outer radius there)
  double diameter_sum2 = 0;  // squared diameter errors every 2 mm over the common length
  long diameter_count = 0;
  std::vector<std::string> missed, spurious_list;  // one line each
  std::vector<std::string> pairs;  // each pair's diameters, r_dead and r_end, true and found
  std::vector<int> found_pair;     // per found knot: the index of its true knot, -1 spurious
  double recall() const { return truth_counted ? double(truth_found) / truth_counted : 1.0; }
  double precision() const { return found ? double(found - spurious) / found : 1.0; }
  double diameter_rmse() const;
};

// `truth_stem` gives the outer radius where a true knot reaches the bark.
KnotMatch match_knots(const std::vector<Knot>& found, const std::vector<Knot>& truth,
                      const Stem& truth_stem, const KnotMatchOptions& options = {});

// Median of a list (NaN when empty).
double median_of(std::vector<double> v);

}  // namespace sawyer::ct

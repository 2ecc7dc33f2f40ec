// Figures a sawmill engineer reads first about a log (what `sawyer info` prints).
#pragma once

#include <iosfwd>

#include "sawyer/model/log_model.h"

namespace sawyer {

struct LogSummary {
  double length_mm = 0;
  // Equal-area diameters under bark (mm): mean over the 100 mm at each end, and over the log.
  double butt_diameter_mm = 0, top_diameter_mm = 0, mean_diameter_mm = 0;
  double min_radius_mm = 0, max_radius_mm = 0;
  double volume_m3 = 0;           // sum of cross-section areas × dz
  double taper_mm_per_m = 0;      // (butt − top diameter) / length
  double pith_wander_mm = 0;      // largest pith distance from its least-squares straight line
  double pith_tilt_mm_per_m = 0;  // slope of that line
  double ovality = 0;             // mean over heights of 1 − min/max diameter across angles
  int knot_count = 0, sound_knots = 0, dead_knots = 0;  // dead = has a dead part
  int largest_knot = -1;                                // index into knots, -1 if none
  double largest_knot_diameter_mm = 0;
  bool has_heartwood = false;
  double mean_heartwood_radius_mm = 0;
};

LogSummary summarize(const LogModel& log);

// A human-readable table, one figure a line.
void print_summary(std::ostream& os, const LogModel& log, const LogSummary& s);

}  // namespace sawyer

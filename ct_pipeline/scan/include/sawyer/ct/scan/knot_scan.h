// The knot pass of `sawyer scan` (issue 5): knots detected and segmented in the log's voxels
// around the stem (knot_detect.h), each fitted with the knot formula (knot_fit.h), numbered,
// with the time of every stage.
//
//   LogVolume vol = LogVolume::empty_like(source.geometry());
//   StemScanOptions so; so.volume = &vol;
//   auto stem = scan_stem(source, so);
//   auto knots = scan_knots(vol, stem.value().stem, {});
//   log.knots = knots.value().knots;
#pragma once

#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/ct/knots/knot_detect.h"
#include "sawyer/ct/knots/knot_fit.h"
#include "sawyer/ct/knots/log_volume.h"
#include "sawyer/model/log_model.h"

namespace sawyer::ct {

struct KnotScanOptions {
  KnotDetectOptions detect;
  KnotFitOptions fit;
  KnotWindowOptions window;  // the streamed pass's windows along the log
  int threads = 0;           // 0: hardware concurrency (detection and fits)
  // Fitted knots whose largest diameter is below this are dropped (noise), mm.
  double min_diameter_mm = 4.0;
};

struct KnotScan {
  std::vector<Knot> knots;          // ids from 1, ordered by height at the pith
  std::vector<KnotTrace> traces;    // the evidence of each kept knot, same order
  std::vector<KnotFitReport> fits;  // same order
  int traces_found = 0;             // detected before fitting
  int duplicates = 0;               // fitted knots dropped as another's double (knot_scan.cpp)
  // Knot candidates rejected as rings (shell blobs shaped as sheets, runs sliding round the log;
  // detect.rejected_* has every reason) and the detection's signal, thresholds and timings.
  int rejected_as_rings = 0;
  KnotDetectSummary detect;
  std::vector<std::string> rejected;  // traces not fitted, why (one line each)
  double seconds_detect = 0, seconds_fit = 0, seconds = 0;
};

Result<KnotScan> scan_knots(const LogVolume& volume, const Stem& stem,
                            const KnotScanOptions& options = {});
// Streamed: the scan read again in windows (detect_knots over a SliceSource, knot_detect.h).
Result<KnotScan> scan_knots(SliceSource& source, const Stem& stem, const std::vector<char>* has_log,
                            const KnotScanOptions& options = {},
                            const KnotSliceVisitor& visit = {});

}  // namespace sawyer::ct

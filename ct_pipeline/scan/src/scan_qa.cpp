// The scan's verdict on itself (see scan_qa.h).
#include "sawyer/ct/scan/scan_qa.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "sawyer/core/vec.h"
#include "sawyer/ct/stem/pith_track.h"

namespace sawyer::ct {

namespace {

// Area centroid (pith_track.h contour_centre) and mean radius of a closed polar outline around
// `c`; false with fewer than half the azimuths valid.
bool outline_centre(const std::vector<double>& radius, const std::vector<bool>& valid, Vec2 c,
                    Vec2* centre, double* mean_r) {
  if (!contour_centre(c, radius, valid, centre)) return false;
  double sum = 0;
  int n = 0;
  for (size_t k = 0; k < radius.size(); ++k)
    if (valid[k] && radius[k] > 0) sum += radius[k], ++n;
  if (n == 0) return false;
  *mean_r = sum / n;
  return true;
}

double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  const size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(m), v.end());
  return v[m];
}

// RMS of the radius about its running median over ±half azimuths (valid entries only).
double roughness(const std::vector<double>& r, const std::vector<bool>& valid, int half) {
  const int n = static_cast<int>(r.size());
  double ss = 0;
  int cnt = 0;
  std::vector<double> win;
  for (int k = 0; k < n; ++k) {
    if (!valid[static_cast<size_t>(k)]) continue;
    win.clear();
    for (int d = -half; d <= half; ++d) {
      const int j = ((k + d) % n + n) % n;
      if (valid[static_cast<size_t>(j)]) win.push_back(r[static_cast<size_t>(j)]);
    }
    const double m = median_of(win);
    ss += (r[static_cast<size_t>(k)] - m) * (r[static_cast<size_t>(k)] - m);
    ++cnt;
  }
  return cnt ? std::sqrt(ss / cnt) : 0.0;
}

// "z 1.20-1.80 m" (heights from the first slice).
std::string z_span(double z0, double z1) {
  char s[64];
  if (std::max(std::abs(z0), std::abs(z1)) >= 1000)
    std::snprintf(s, sizeof s, "z %.2f-%.2f m", z0 * 1e-3, z1 * 1e-3);
  else
    std::snprintf(s, sizeof s, "z %.0f-%.0f mm", z0, z1);
  return s;
}

struct Run {
  double z0 = 0, z1 = 0;
  int count = 0;
};

// Runs of consecutive measured slices flagged by `flag` (unmeasured slices do not break a run).
template <class F>
std::vector<Run> runs_of(const std::vector<QaSlice>& s, F flag) {
  std::vector<Run> out;
  bool open = false;
  for (const QaSlice& q : s) {
    if (!q.measured) continue;
    if (flag(q)) {
      if (!open) out.push_back({q.z, q.z, 0});
      open = true;
      out.back().z1 = q.z;
      ++out.back().count;
    } else {
      open = false;
    }
  }
  return out;
}

std::string pct(double share) {
  char s[16];
  std::snprintf(s, sizeof s, "%.0f %%", 100 * share);
  return s;
}

}  // namespace

namespace {

// The slices' mean step along z (mm; 1 for a single slice).
double mean_step(const VolumeGeometry& g) {
  return g.slice_count() > 1 ? std::abs(g.z.back() - g.z.front()) / (g.slice_count() - 1) : 1.0;
}

// The scan class (issue 20's targets): fine scans resolve rings where they are wide enough;
// coarse industrial ones do not, and their pith comes from the log's shape.
bool coarse_scan(const VolumeGeometry& g, const QaOptions& o) {
  return !(g.spacing_x <= o.fine_pixel_mm && g.spacing_y <= o.fine_pixel_mm &&
           mean_step(g) < o.coarse_slice_mm);
}

// The 95th percentile the pith's expected error is held to: by scan class, and for fine scans
// by whether the rings were resolved.
double pith_p95_limit(bool coarse, bool resolved, const QaOptions& o) {
  return coarse ? o.pith_coarse_p95_mm : resolved ? o.pith_fine_p95_mm : o.pith_narrow_p95_mm;
}

}  // namespace

std::vector<QaSlice> assess_slices(const StemScan& scan, const VolumeGeometry& g,
                                   const QaOptions& o) {
  const size_t n = scan.slices.size();
  std::vector<QaSlice> out(n);
  const double dz = mean_step(g);
  const bool coarse = coarse_scan(g, o);
  const StemSliceRecord* prev = nullptr;
  for (size_t i = 0; i < n; ++i) {
    const StemSliceRecord& r = scan.slices[i];
    QaSlice& q = out[i];
    q.z = r.z;
    q.measured = r.measured;
    if (!r.measured) {
      prev = nullptr;
      continue;
    }
    // Pith.
    if (r.pith_refined.found) {
      q.ring_share = r.pith_refined.confidence;
      q.pith_residual_mm = (r.pith_refined.pith_mm - r.pith).norm();
    }
    Vec2 centre;
    double mean_r = 0;
    const bool have_outline =
        outline_centre(r.contour.radius, r.contour.valid, r.pith, &centre, &mean_r);
    if (have_outline && mean_r > 0) q.eccentricity = (r.pith - centre).norm() / mean_r;
    bool outside_core = false;
    if (r.heartwood.present) {
      Vec2 hc;
      double hr = 0;
      if (outline_centre(r.heartwood.radius, r.heartwood.valid, r.pith, &hc, &hr) && hr > 0)
        outside_core = (r.pith - hc).norm() > 0.6 * hr;
    }
    q.expected_error_mm = r.pith_expected_error_mm;
    const bool weak = !r.pith_refined.found || q.ring_share < o.pith_min_ring_share;
    const bool off_track = r.pith_outlier || q.pith_residual_mm > o.pith_residual_mm;
    if (have_outline && q.eccentricity > o.pith_max_eccentricity) {
      q.pith_suspect = true;
      q.pith_why = "near the bark";
    } else if (outside_core) {
      q.pith_suspect = true;
      q.pith_why = "outside the heartwood";
    } else if (weak && off_track) {
      q.pith_suspect = true;
      q.pith_why = "rings weak, off the track";
    } else if (r.rings_resolved && r.whorl_used &&
               (r.pith_whorl - r.pith).norm() >
                   o.pith_whorl_disagree_mm +
                       2.0 * std::hypot(r.whorl_error_mm, q.expected_error_mm)) {
      // The knots of a whorl meet elsewhere: the rings may be locked one ring off or onto a
      // pattern that is not the pith's.
      q.pith_suspect = true;
      q.pith_why = "rings and knot whorls disagree";
    } else if (q.expected_error_mm > pith_p95_limit(coarse, r.rings_resolved, o)) {
      q.pith_suspect = true;
      q.pith_why = r.rings_resolved                ? "rings faint"
                   : r.pith_cue == PithCue::whorls ? "rings unresolved, pith from the knot whorls"
                                                   : "rings unresolved, pith from the log's shape";
    }
    // Outline.
    const int na = static_cast<int>(r.contour.radius.size());
    int filled = 0;
    for (int k = 0; k < na; ++k) filled += !r.contour.valid[static_cast<size_t>(k)];
    q.filled_share = na ? static_cast<double>(filled) / na : 1.0;
    q.roughness_mm = na ? roughness(r.contour.radius, r.contour.valid, std::max(1, na / 72)) : 0.0;
    if (prev && prev->contour.radius.size() == r.contour.radius.size()) {
      std::vector<double> dr;
      for (int k = 0; k < na; ++k)
        if (r.contour.valid[static_cast<size_t>(k)] && prev->contour.valid[static_cast<size_t>(k)])
          dr.push_back(std::abs(r.contour.radius[static_cast<size_t>(k)] -
                                prev->contour.radius[static_cast<size_t>(k)]));
      // The pith moves between slices too; its move is not the outline's.
      const double pith_move = (r.pith - prev->pith).norm();
      q.jump_mm_per_mm = std::max(0.0, median_of(dr) - pith_move) / std::max(dz, 1e-6);
    }
    if (g.width > 0 && g.height > 0) {
      int edge = 0, seen = 0;
      const double xmax = (g.width - 1.5) * g.spacing_x, ymax = (g.height - 1.5) * g.spacing_y;
      for (int k = 0; k < na; ++k) {
        if (!r.contour.valid[static_cast<size_t>(k)]) continue;
        const double w = kTwoPi * k / na, rr = r.contour.radius[static_cast<size_t>(k)];
        const double x = r.pith.x + rr * std::cos(w), y = r.pith.y + rr * std::sin(w);
        ++seen;
        edge += x < 1.5 * g.spacing_x || y < 1.5 * g.spacing_y || x > xmax || y > ymax;
      }
      q.at_edge_share = seen ? static_cast<double>(edge) / seen : 0.0;
    }
    // The bark's step under the outer wood, in the wood's own spread (the levels this slice's
    // contour used: its own where they agree with the scan's).
    if (scan.levels.valid && r.contour.bark_seen) {
      const ScanLevels used = slice_levels_or_scan(r.levels, scan.levels);
      const double step = used.wood_high_hu - r.contour.bark_hu;
      q.bark_step_sigmas = step / std::max(1.0, used.noise_hu());
      q.bark_step_share = step / std::max(1.0, used.wood_high_hu - used.air_hu);
    }
    q.outline_suspect = q.at_edge_share > o.outline_max_at_edge ||
                        q.filled_share > o.outline_max_filled ||
                        q.roughness_mm > o.outline_max_roughness_mm ||
                        q.jump_mm_per_mm > o.outline_max_jump_mm_per_mm;
    prev = &r;
  }
  return out;
}

ScanQaDetail assess_scan(const StemScan& scan, const KnotScan* knots, const VolumeGeometry& g,
                         const QaOptions& o) {
  return assess_scan(scan, knots, g, o, assess_slices(scan, g, o));
}

ScanQaDetail assess_scan(const StemScan& scan, const KnotScan* knots, const VolumeGeometry& g,
                         const QaOptions& o, std::vector<QaSlice> slices) {
  ScanQaDetail d;
  const size_t n = scan.slices.size();
  d.slices = std::move(slices);
  d.slices.resize(n);
  d.coarse = coarse_scan(g, o);
  d.verdict.scan_class = d.coarse ? "coarse" : "fine";
  const double dz = mean_step(g);

  // ---- per slice: the tallies ----
  std::vector<double> shares;
  int measured = 0, pith_suspects = 0, outline_suspects = 0, at_edge = 0;
  int bark_seen = 0, weak_bark = 0;
  std::vector<double> bark_steps, bark_shares;
  for (size_t i = 0; i < n; ++i) {
    const StemSliceRecord& r = scan.slices[i];
    const QaSlice& q = d.slices[i];
    if (!r.measured) continue;
    ++measured;
    if (r.pith_refined.found) shares.push_back(q.ring_share);
    pith_suspects += q.pith_suspect;
    if (g.width > 0 && g.height > 0 && q.at_edge_share > o.outline_max_at_edge) ++at_edge;
    if (scan.levels.valid && r.contour.bark_seen) {
      ++bark_seen;
      bark_steps.push_back(q.bark_step_sigmas);
      bark_shares.push_back(q.bark_step_share);
      weak_bark += q.bark_step_sigmas < o.outline_min_bark_sigmas ||
                   q.bark_step_share < o.outline_min_bark_share;
    }
    outline_suspects += q.outline_suspect;
  }

  ScanQa& v = d.verdict;
  std::vector<std::string> warnings;

  // ---- levels: the scan's own ----
  {
    ScanQa::Stage st{"levels", true, 1.0, {}};
    const ScanLevels& L = scan.levels;
    if (measured == 0) {
      st.ok = false;
      st.confidence = 0;
      st.notes.push_back("no slice holds a log: the scan does not look like a log");
      warnings.push_back("no slice holds a log: the scan does not look like a log");
    } else if (!L.valid) {
      st.ok = false;
      st.confidence = 0.2;
      const std::string w =
          "no clear air and wood levels in the scan's histogram: it does not "
          "look like a log in air" +
          (L.notes.empty() ? std::string() : " (" + L.notes + ")");
      st.notes.push_back(w);
      warnings.push_back(w);
    } else {
      st.notes.push_back("levels: " + describe(L));
      char line[200];
      if (std::abs(L.shift_hu) >= o.levels_shift_note_hu) {
        std::snprintf(line, sizeof line,
                      "HU appear shifted by about %+.0f (air reads %.0f): thresholds were set from "
                      "the scan's own levels",
                      L.shift_hu, L.air_hu);
        st.notes.push_back(line);
        warnings.push_back(line);
      }
      if (L.dried) {
        std::snprintf(line, sizeof line,
                      "the wood reads about %.0f HU with no wet sapwood: a dried log", L.wood_hu);
        st.notes.push_back(line);
      }
      if (L.air_clipped)
        st.notes.push_back("air is clipped at the data's floor: a windowed export");
      if (!L.notes.empty()) st.notes.push_back(L.notes);
    }
    v.stages.push_back(std::move(st));
  }

  // ---- pith ----
  {
    ScanQa::Stage st{"pith", true, 1.0, {}};
    d.pith_suspect_share = measured ? static_cast<double>(pith_suspects) / measured : 1.0;
    d.pith_median_ring_share = median_of(shares);
    std::vector<double> expected;
    int resolved = 0;
    for (size_t i = 0; i < n; ++i)
      if (d.slices[i].measured) {
        expected.push_back(d.slices[i].expected_error_mm);
        resolved += scan.slices[i].rings_resolved;
      }
    d.rings_resolved_share = measured ? static_cast<double>(resolved) / measured : 0.0;
    d.pith_expected_median_mm = median_of(expected);
    if (!expected.empty()) {
      std::sort(expected.begin(), expected.end());
      d.pith_expected_p95_mm =
          expected[std::min(expected.size() - 1, static_cast<size_t>(0.95 * expected.size()))];
    }
    const bool mostly_resolved = 2 * resolved >= measured;
    d.pith_limit_median_mm = d.coarse          ? o.pith_coarse_median_mm
                             : mostly_resolved ? o.pith_fine_median_mm
                                               : o.pith_narrow_median_mm;
    d.pith_limit_p95_mm = pith_p95_limit(d.coarse, mostly_resolved, o);
    const auto runs = runs_of(d.slices, [](const QaSlice& q) { return q.pith_suspect; });
    for (const Run& r : runs)
      d.pith_longest_run_mm = std::max(d.pith_longest_run_mm, r.z1 - r.z0 + dz);
    char line[256];
    std::snprintf(line, sizeof line,
                  "%d of %d slices suspect (%s); median ring alignment %.2f; longest suspect run "
                  "%.0f mm",
                  pith_suspects, measured, pct(d.pith_suspect_share).c_str(),
                  d.pith_median_ring_share, d.pith_longest_run_mm);
    st.notes.push_back(line);
    std::snprintf(line, sizeof line,
                  "%s scan; rings resolved on %s of the slices, knot whorls met on %d; expected "
                  "pith error median %.2f mm, 95th percentile %.2f mm (limits %.1f and %.1f mm)",
                  d.coarse ? "coarse" : "fine", pct(d.rings_resolved_share).c_str(),
                  scan.pith_summary.whorl_slices, d.pith_expected_median_mm, d.pith_expected_p95_mm,
                  d.pith_limit_median_mm, d.pith_limit_p95_mm);
    st.notes.push_back(line);
    if (scan.ring_shape_share != 1.0) {
      std::snprintf(line, sizeof line,
                    "rings rounder than the log: they line up best following %.0f %% of the "
                    "outline's shape (measured on slices along the log)",
                    100 * scan.ring_shape_share);
      st.notes.push_back(line);
    }
    if (scan.ring_drift.norm() > 0) {
      std::snprintf(line, sizeof line,
                    "eccentric growth: the rings' centre moves %.2f mm per mm of radius towards "
                    "%.0f deg (probes agree within %.2f); the pith is where they close in",
                    scan.ring_drift.norm(),
                    wrap_angle(std::atan2(scan.ring_drift.y, scan.ring_drift.x)) * 180 / kPi,
                    scan.ring_drift_spread);
      st.notes.push_back(line);
    }
    if (scan.inner_used && scan.inner_shift_mm > 0.5) {
      std::snprintf(line, sizeof line,
                    "the innermost rings (within %.0f mm) are centred %.1f mm from where all rings "
                    "line up (median; growth that moved off with age): the pith follows them",
                    scan.inner_ring_mm, scan.inner_shift_mm);
      st.notes.push_back(line);
    }
    // Where, and why (the most common reason in each run); the three longest runs.
    std::vector<Run> sorted = runs;
    std::sort(sorted.begin(), sorted.end(),
              [](const Run& a, const Run& b) { return a.z1 - a.z0 > b.z1 - b.z0; });
    for (size_t k = 0; k < sorted.size() && k < 3; ++k) {
      const Run& r = sorted[k];
      if (r.count < 2) continue;
      std::string why;
      int best = 0;
      for (const char* reason : {"near the bark", "outside the heartwood",
                                 "rings weak, off the track", "rings and knot whorls disagree",
                                 "rings faint", "rings unresolved, pith from the knot whorls",
                                 "rings unresolved, pith from the log's shape"}) {
        int c = 0;
        for (const QaSlice& q : d.slices)
          if (q.pith_suspect && q.z >= r.z0 && q.z <= r.z1 && q.pith_why == reason) ++c;
        if (c > best) best = c, why = reason;
      }
      st.notes.push_back("pith uncertain over " + z_span(r.z0, r.z1) + ": " + why);
    }
    st.confidence = std::clamp(
        1.0 - d.pith_suspect_share / std::max(o.pith_max_suspect_share, 1e-6) * 0.5, 0.0, 1.0);
    const bool expected_too_big = d.pith_expected_median_mm > d.pith_limit_median_mm ||
                                  d.pith_expected_p95_mm > d.pith_limit_p95_mm;
    if (measured > 0 && (d.pith_suspect_share > o.pith_max_suspect_share ||
                         d.pith_longest_run_mm > o.pith_max_run_mm || expected_too_big)) {
      st.ok = false;
      std::string w = "pith uncertain on " + pct(d.pith_suspect_share) + " of the slices";
      if (!sorted.empty() && sorted.front().count >= 2)
        w += " (worst " + z_span(sorted.front().z0, sorted.front().z1) + ")";
      if (expected_too_big) {
        std::snprintf(line, sizeof line,
                      "; expected error median %.1f mm, 95th percentile %.1f mm (%s)",
                      d.pith_expected_median_mm, d.pith_expected_p95_mm,
                      d.rings_resolved_share < 0.5 ? "rings unresolved" : "rings faint");
        w += line;
      }
      warnings.push_back(w);
    }
    v.stages.push_back(std::move(st));
  }

  // ---- outline ----
  {
    ScanQa::Stage st{"outline", true, 1.0, {}};
    d.outline_suspect_share = measured ? static_cast<double>(outline_suspects) / measured : 1.0;
    std::vector<double> rough, fill;
    for (const QaSlice& q : d.slices)
      if (q.measured) rough.push_back(q.roughness_mm), fill.push_back(q.filled_share);
    char line[256];
    std::snprintf(
        line, sizeof line,
        "%d of %d slices suspect (%s); median roughness %.2f mm; median share filled in %s",
        outline_suspects, measured, pct(d.outline_suspect_share).c_str(), median_of(rough),
        pct(median_of(fill)).c_str());
    st.notes.push_back(line);
    st.confidence = std::clamp(1.0 - d.outline_suspect_share, 0.0, 1.0);
    if (scan.outline_z_outliers > 0) {
      std::snprintf(line, sizeof line,
                    "%d outline values left their neighbours along z and were replaced by their "
                    "median (a chain on the log, a bad slice)",
                    scan.outline_z_outliers);
      st.notes.push_back(line);
    }
    if (bark_seen > 0) {
      d.outline_weak_bark_share = static_cast<double>(weak_bark) / bark_seen;
      d.outline_bark_step_sigmas = median_of(bark_steps);
      d.outline_bark_step_share = median_of(bark_shares);
      std::snprintf(
          line, sizeof line,
          "bark seen on %d of %d slices, lighter than the outer wood by %.1f noise sigmas "
          "and %.0f %% of the wood-air span (medians)",
          bark_seen, measured, d.outline_bark_step_sigmas, 100 * d.outline_bark_step_share);
      st.notes.push_back(line);
    }
    d.outline_at_edge_share = measured ? static_cast<double>(at_edge) / measured : 0.0;
    if (measured > 0 &&
        at_edge >= std::min(2, measured)) {  // one slice can be a log end's odd shape
      st.ok = false;
      const std::string w = "the log reaches the image's edge on " + std::to_string(at_edge) +
                            " of " + std::to_string(measured) +
                            " slices: cut by the field of view, its outline there is the image's";
      st.notes.push_back(w);
      warnings.push_back(w);
    } else if (bark_seen > 0 && d.outline_weak_bark_share > o.outline_max_weak_bark_share) {
      st.ok = false;
      st.confidence = std::min(st.confidence, 0.5);
      std::snprintf(line, sizeof line,
                    "outline under bark uncertain: the bark is barely lighter than the outer wood "
                    "(%.1f noise sigmas, %.0f %% of the wood-air span) on %s of the slices where "
                    "bark was seen (a dried log?), so the edge may lie anywhere in the bark",
                    d.outline_bark_step_sigmas, 100 * d.outline_bark_step_share,
                    pct(d.outline_weak_bark_share).c_str());
      warnings.push_back(line);
    } else if (measured > 0 && d.outline_suspect_share > o.outline_max_suspect_share) {
      st.ok = false;
      warnings.push_back("outline uncertain on " + pct(d.outline_suspect_share) +
                         " of the slices (surface not found, rough or jumping)");
    }
    v.stages.push_back(std::move(st));
  }

  // ---- heartwood ----
  {
    ScanQa::Stage st{"heartwood", true, 1.0, {}};
    int present = 0;
    for (const auto& r : scan.slices) present += r.measured && r.heartwood.present;
    char line[160];
    std::snprintf(line, sizeof line, "dry core seen on %d of %d slices", present, measured);
    st.notes.push_back(line);
    if (measured > 0 && present > 0 && present * 2 < measured) {
      st.confidence = 0.5;
      st.notes.push_back("dry core seen on fewer than half the slices");
    }
    v.stages.push_back(std::move(st));
  }

  // ---- knots ----
  if (knots) {
    ScanQa::Stage st{"knots", true, 1.0, {}};
    const double length_m = std::max(0.5, measured * dz * 1e-3);
    d.knots_per_m = knots->knots.size() / length_m;
    d.knot_candidates_rejected = static_cast<int>(knots->rejected.size());
    char line[256];
    std::snprintf(line, sizeof line, "%zu knots (%.1f per m); %zu candidates not fitted",
                  knots->knots.size(), knots->knots.size() / std::max(1e-3, measured * dz * 1e-3),
                  knots->rejected.size());
    st.notes.push_back(line);
    if (!knots->knots.empty()) {
      // Knot::confidence: the chance each is a real knot, from its fit.
      double expected_real = 0;
      int doubtful = 0;
      for (const Knot& k : knots->knots) {
        const double c = k.confidence();
        expected_real += c;
        doubtful += c < 0.5;
      }
      std::snprintf(line, sizeof line,
                    "knot confidence: %d of %zu below 50 %%; about %.0f of them real (the sum of "
                    "the confidences)",
                    doubtful, knots->knots.size(), expected_real);
      st.notes.push_back(line);
    }
    if (knots->rejected_as_rings > 0) {
      std::snprintf(line, sizeof line,
                    "%d knot candidates rejected as rings (sheets %d, arcs %d); ring signal %.0f "
                    "HU over noise %.0f HU",
                    knots->rejected_as_rings, knots->detect.rejected_sheet_blobs,
                    knots->detect.rejected_drift, knots->detect.ring_hu, knots->detect.noise_hu);
      st.notes.push_back(line);
    }
    d.knot_candidates_rejected_as_rings = knots->rejected_as_rings;
    if (d.knots_per_m > o.knots_max_per_m) {
      st.ok = false;
      st.confidence = 0.2;
      char w[160];
      std::snprintf(w, sizeof w, "%.0f knots per m: more than a log has (rings taken for knots?)",
                    d.knots_per_m);
      warnings.push_back(w);
    }
    // Knots are measured around the pith: an untrusted pith makes them untrusted too.
    if (!v.stages[1].ok) {
      st.confidence = std::min(st.confidence, 0.5);
      st.notes.push_back("measured around an uncertain pith");
    }
    v.stages.push_back(std::move(st));
  }

  v.trusted = true;
  for (const auto& st : v.stages) v.trusted = v.trusted && st.ok;
  v.warnings = std::move(warnings);
  return d;
}

std::string qa_headline(const ScanQa& qa) {
  if (qa.trusted && qa.warnings.empty()) return "QA: trusted";
  std::string s = qa.trusted ? "QA: trusted, with notes: " : "QA: NOT TRUSTED: ";
  for (size_t i = 0; i < qa.warnings.size(); ++i) s += (i ? "; " : "") + qa.warnings[i];
  return s;
}

}  // namespace sawyer::ct

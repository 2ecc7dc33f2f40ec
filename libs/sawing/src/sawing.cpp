#include "sawyer/sawing/sawing.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

#include "sawyer/sawing/placement.h"

namespace sawyer::sawing {

const char* side_name(Side s) {
  switch (s) {
    case Side::kFacePlus:
      return "face+";
    case Side::kFaceMinus:
      return "face-";
    case Side::kEdgePlus:
      return "edge+";
    case Side::kEdgeMinus:
      return "edge-";
  }
  return "?";
}

const char* knot_kind_name(KnotKind k) {
  switch (k) {
    case KnotKind::kFace:
      return "face";
    case KnotKind::kEdge:
      return "edge";
    case KnotKind::kArris:
      return "arris";
  }
  return "?";
}

namespace {

constexpr int kMaxRootSteps = 24;

// √(a² + b²) without std::hypot's care for overflow (lengths in mm and unit vectors here; hypot
// was 3 % of a through-and-through position's time).
inline double length2(double a, double b) { return std::sqrt(a * a + b * b); }

// Pattern frame <-> log frame for one position.
struct Placement {
  const SawLog* log;
  double c = 1, s = 0;  // rotation by φ: log → pattern
  double ox = 0, oy = 0;

  // Pattern point (u, v) at stem sample i: inside the log's outline?
  bool inside(int i, double u, double v) const {
    const double pu = u + ox, pv = v + oy;
    // q = Rot(−φ)·(pu, pv)
    const double qx = c * pu + s * pv, qy = -s * pu + c * pv;
    const Vec2 l = log->line_at_slice(i);
    return log->inside(i, l.x + qx, l.y + qy);
  }
  Vec2 to_log(int i, double u, double v) const {
    const double pu = u + ox, pv = v + oy;
    const double qx = c * pu + s * pv, qy = -s * pu + c * pv;
    const Vec2 l = log->line_at_slice(i);
    return {l.x + qx, l.y + qy};
  }
  // True when the rectangle [u0, u1] × [v0, v1] lies within the slice's smallest outline radius
  // about the pith (by a relative 1e-9): then inside() holds at its corners (the same answer,
  // without the look-up).
  bool rect_surely_inside(int i, double u0, double u1, double v0, double v1) const {
    const double pu = pith_uv[i].x, pv = pith_uv[i].y;
    const double du = std::max(std::abs(u0 - pu), std::abs(u1 - pu));
    const double dv = std::max(std::abs(v0 - pv), std::abs(v1 - pv));
    return du * du + dv * dv <= inner_r2[i];
  }
  // Per stem sample, filled by prepare(): the pith in the pattern frame and the squared
  // smallest outline radius less a relative 1e-9 (rect_surely_inside's numbers).
  const Vec2* pith_uv = nullptr;
  const double* inner_r2 = nullptr;
  void prepare(std::vector<Vec2>& uv, std::vector<double>& r2) {
    const int n = log->model().stem.slice_count();
    uv.resize(n);
    r2.resize(n);
    for (int i = 0; i < n; ++i) {
      const Vec2 l = log->line_at_slice(i);
      const Vec2 p = log->model().stem.pith[i];
      const double qx = p.x - l.x, qy = p.y - l.y;
      uv[i] = {c * qx - s * qy - ox, s * qx + c * qy - oy};
      r2[i] = log->min_radius2(i) * (1 - 1e-9);
    }
    pith_uv = uv.data();
    inner_r2 = r2.data();
  }
  double outside_by(int i, double u, double v) const {
    const double pu = u + ox, pv = v + oy;
    const double qx = c * pu + s * pv, qy = -s * pu + c * pv;
    const Vec2 l = log->line_at_slice(i);
    return log->outside_by(i, l.x + qx, l.y + qy);
  }
};

// One board's cross-section in the pattern frame: centre, half sizes along the thickness and
// width axes, and which pattern axis (0 = u, 1 = v) the thickness runs along.
struct Section {
  double cu, cv, ht, hw;
  int ta;
  void point(double a, double b, double* u, double* v) const {
    if (ta == 0) {
      *u = cu + a;
      *v = cv + b;
    } else {
      *u = cu + b;
      *v = cv + a;
    }
  }
};

// Fraction of the way from an outside end A to an inside point B at which the outline is
// crossed: regula falsi (Illinois) on g = pith distance − outline radius, to 0.01 mm.
// `decide(lo, hi)` is asked before every step with the bracket that holds the answer; when it
// returns non-zero the search stops and that decision is stored in *decided (the ok-only checks
// below: whether a wane passes a limit is often clear long before the crossing is found to
// 0.01 mm). With a decider that always answers 0 this is the plain search.
template <class Decide>
double cross(const Placement& pl, int i, double au, double av, double bu, double bv,
             Decide&& decide, int* decided) {
  double lo = 0, hi = 1;  // g(lo) > 0 outside, g(hi) ≤ 0 inside
  double glo = pl.outside_by(i, au, av), ghi = pl.outside_by(i, bu, bv);
  const double seg = length2(bu - au, bv - av);
  int side = 0;
  for (int k = 0; k < kMaxRootSteps && (hi - lo) * seg > 0.01; ++k) {
    if (const int d = decide(lo, hi)) {
      *decided = d;
      return 0.5 * (lo + hi);
    }
    double m = (glo - ghi) > 1e-12 ? lo + (hi - lo) * glo / (glo - ghi) : 0.5 * (lo + hi);
    m = std::clamp(m, lo + 1e-6 * (hi - lo), hi - 1e-6 * (hi - lo));
    const double gm = pl.outside_by(i, au + m * (bu - au), av + m * (bv - av));
    if (std::abs(gm) < 1e-4) return m;
    if (gm > 0) {
      lo = m;
      glo = gm;
      if (side == -1) ghi *= 0.5;
      side = -1;
    } else {
      hi = m;
      ghi = gm;
      if (side == 1) glo *= 0.5;
      side = 1;
    }
  }
  return 0.5 * (lo + hi);
}

constexpr auto kNoDecision = [](double, double) { return 0; };

// Fraction of the way from an outside end A to an inside point B at which the outline is
// crossed, by Newton's method from f0 (where the outline crossed the same side at the
// neighbouring stem sample, a fraction of a millimetre away as a rule): f in (0, 1) with
// |g| < 1e-4 mm, or the step after one shorter than 0.002 mm (quadratic convergence puts it
// within 1e-5 mm of the outline); −1 when neither happens within 4 steps (then cross()).
double newton_cross(const Placement& pl, int i, double au, double av, double bu, double bv,
                    double f0) {
  const double eu = bu - au, ev = bv - av;
  const double ex = pl.c * eu + pl.s * ev, ey = -pl.s * eu + pl.c * ev;  // e in the log frame
  const double len = length2(eu, ev);
  double f = f0;
  for (int k = 0; k < 4; ++k) {
    if (!(f > 0 && f < 1)) return -1;
    const Vec2 p = pl.to_log(i, au + f * eu, av + f * ev);
    double d;
    const double g = pl.log->outside_by(i, p.x, p.y, ex, ey, &d);
    if (std::abs(g) < 1e-4) return f;
    if (!(std::abs(d) > 1e-9)) return -1;
    const double step = g / d;
    f -= step;
    if (std::abs(step) * len < 0.002) return f > 0 && f < 1 ? f : -1;
  }
  return -1;
}

// Distance from outside end A (towards B, length len) to the crossing: from the neighbouring
// sample's crossing `*near` (mm from A, < 0: none) by Newton's method where it converges, else
// the bracketed search; *near is set to the answer.
double cross_near(const Placement& pl, int i, double au, double av, double bu, double bv,
                  double len, double* near) {
  double f = *near > 0 && *near < len ? newton_cross(pl, i, au, av, bu, bv, *near / len) : -1;
  if (f < 0) {
    int unused = 0;
    f = cross(pl, i, au, av, bu, bv, kNoDecision, &unused);
  }
  *near = len * f;
  return *near;
}

// Lengths of segment P→Q (length len) lying outside the log, measured from each end. `track`,
// when given, holds per end the crossing's distance from it at the neighbouring stem sample
// (< 0: none) for the search to start from, and is updated.
void outside_ends(const Placement& pl, int i, double pu, double pv, bool pin, double qu, double qv,
                  bool qin, double len, double* out_p, double* out_q, double* track = nullptr) {
  *out_p = *out_q = 0;
  double none[2] = {-1, -1};
  double* tr = track ? track : none;
  if (pin && qin) {
    tr[0] = tr[1] = -1;
    return;
  }
  if (!pin && !qin) {
    const double mu = 0.5 * (pu + qu), mv = 0.5 * (pv + qv);
    if (!pl.inside(i, mu, mv)) {
      *out_p = *out_q = 0.5 * len;
      tr[0] = tr[1] = -1;
      return;
    }
    *out_p = cross_near(pl, i, pu, pv, mu, mv, 0.5 * len, &tr[0]);
    *out_q = cross_near(pl, i, qu, qv, mu, mv, 0.5 * len, &tr[1]);
    return;
  }
  if (!pin) {
    *out_p = cross_near(pl, i, pu, pv, qu, qv, len, &tr[0]);
    tr[1] = -1;
  } else {
    *out_q = cross_near(pl, i, qu, qv, pu, pv, len, &tr[1]);
    tr[0] = -1;
  }
}

// Whether the wane x = out_p + out_q of segment P→Q (as outside_ends computes it) keeps
// x ≤ limit and x < len, deciding from the root brackets where it can: the same answer as
// computing x, for less work. Floating-point products and sums are monotone, so a bound on the
// fraction gives a bound on x.
//
// Before any root search, a certificate from the outline's radius bounds per sector
// (SawLog::segment_surely_inside / _outside, no atan2): the search's answer lies within 0.01 mm
// of a point where the outline is crossed or at a point within 1e-4 mm of the outline (it stops
// there), so when the part of the side beyond the limit (less 0.011 mm) lies surely inside by
// more than kSure, the wane is below the limit; when the part up to the limit (plus 0.011 mm)
// lies surely outside, it is above. Same answer as the search (which converges within its 24
// steps on every sample seen; equivalence test in tests/sawing_test.cpp).
constexpr double kSure = 1e-3;  // mm, ≫ the search's 1e-4 stop on |g|
constexpr double kTol = 0.011;  // mm, > the search's 0.01 mm bracket

// Distance from outside end A towards B (length L) where the crossing surely lies: -1 below
// `d` (the segment from d on surely inside), +1 beyond d (the segment up to d surely outside),
// 0 when not sure.
int crossing_vs(const Placement& pl, int i, Vec2 a, Vec2 b, double len, double d) {
  if (d - kTol > 0 && d - kTol < len) {
    const double f = (d - kTol) / len;
    const Vec2 x{a.x + f * (b.x - a.x), a.y + f * (b.y - a.y)};
    if (pl.log->segment_surely_inside(i, x, b, kSure)) return -1;
  }
  if (d + kTol < len) {
    const double f = (d + kTol) / len;
    const Vec2 y{a.x + f * (b.x - a.x), a.y + f * (b.y - a.y)};
    if (pl.log->segment_surely_outside(i, a, y, kSure)) return 1;
  }
  return 0;
}

bool side_ok(const Placement& pl, int i, double pu, double pv, bool pin, double qu, double qv,
             bool qin, double len, double limit) {
  auto ok = [&](double x) { return x <= limit && x < len; };
  if (pin && qin) return ok(0.0 + 0.0);
  int decided = 0;
  const bool sure_ok = limit < 0.999 * len;  // x ≤ limit then also gives x < len
  if (!pin && !qin) {
    const double mu = 0.5 * (pu + qu), mv = 0.5 * (pv + qv);
    if (!pl.inside(i, mu, mv)) return ok(0.5 * len + 0.5 * len);
    const double half = 0.5 * len;
    if (sure_ok && limit > 0) {
      const Vec2 p = pl.to_log(i, pu, pv), q = pl.to_log(i, qu, qv), m = pl.to_log(i, mu, mv);
      // Each end's wane below limit/2, or either end's above the limit, or both above limit/2.
      const int cp = crossing_vs(pl, i, p, m, half, 0.5 * limit);
      const int cq = crossing_vs(pl, i, q, m, half, 0.5 * limit);
      if (cp < 0 && cq < 0) return true;
      if (cp > 0 && cq > 0) return false;
      if (limit + kTol < half) {
        if (cp > 0 && crossing_vs(pl, i, p, m, half, limit) > 0) return false;
        if (cq > 0 && crossing_vs(pl, i, q, m, half, limit) > 0) return false;
      }
    }
    // P's part: x ≥ half·lo (Q's part ≥ 0) and x ≤ half·hi + half (Q's part ≤ half).
    const double fp = cross(
        pl, i, pu, pv, mu, mv,
        [&](double lo, double hi) {
          if (!ok(half * lo)) return -1;
          if (ok(half * hi + half)) return 1;
          return 0;
        },
        &decided);
    if (decided) return decided > 0;
    const double ep = half * fp;
    const double fq = cross(
        pl, i, qu, qv, mu, mv,
        [&](double lo, double hi) {
          if (!ok(ep + half * lo)) return -1;
          if (ok(ep + half * hi)) return 1;
          return 0;
        },
        &decided);
    if (decided) return decided > 0;
    return ok(ep + half * fq);
  }
  if (sure_ok && limit > 0) {
    const Vec2 p = pl.to_log(i, pu, pv), q = pl.to_log(i, qu, qv);
    const int c =
        !pin ? crossing_vs(pl, i, p, q, len, limit) : crossing_vs(pl, i, q, p, len, limit);
    if (c != 0) return c < 0;
  }
  auto dec = [&](double lo, double hi) {
    if (!ok(len * lo + 0.0)) return -1;
    if (ok(len * hi + 0.0)) return 1;
    return 0;
  };
  const double f = !pin ? cross(pl, i, pu, pv, qu, qv, dec, &decided)
                        : cross(pl, i, qu, qv, pu, pv, dec, &decided);
  if (decided) return decided > 0;
  return ok(len * f + 0.0);
}

struct SliceWane {
  double side[4];  // wane across each Side, mm
  double area;     // missing cross-section area, mm²
  bool ok;
};

// Wane of a section at stem sample i. `corners`, when ≥ 0, holds in its bits 0–3 what inside()
// answers at the four corners (slice_ok looked them up at this section and sample).
// `track` (8 numbers, per side and end as outside_ends takes them, all < 0 to begin with) carries
// the crossings from one stem sample to the next along a board.
void slice_wane(const Placement& pl, const Section& sec, const WaneRules& rules, int i,
                SliceWane* out, int corners = -1, double* track = nullptr) {
  const double hu = sec.ta == 0 ? sec.ht : sec.hw, hv = sec.ta == 0 ? sec.hw : sec.ht;
  if (pl.rect_surely_inside(i, sec.cu - hu, sec.cu + hu, sec.cv - hv, sec.cv + hv)) {
    *out = SliceWane{{0, 0, 0, 0}, 0, true};
    if (track) std::fill_n(track, 8, -1.0);
    return;
  }
  // Corners: 0 (+t, −w), 1 (+t, +w), 2 (−t, +w), 3 (−t, −w).
  const double ca[4] = {sec.ht, sec.ht, -sec.ht, -sec.ht};
  const double cb[4] = {-sec.hw, sec.hw, sec.hw, -sec.hw};
  double cu[4], cv[4];
  bool in[4];
  for (int k = 0; k < 4; ++k) {
    sec.point(ca[k], cb[k], &cu[k], &cv[k]);
    in[k] = corners >= 0 ? (corners >> k & 1) != 0 : pl.inside(i, cu[k], cv[k]);
  }
  const double w = 2 * sec.hw, t = 2 * sec.ht;
  SliceWane& sw = *out;
  if (in[0] && in[1] && in[2] && in[3]) {  // a convex outline holding every corner: no wane
    sw = SliceWane{{0, 0, 0, 0}, 0, true};
    if (track) std::fill_n(track, 8, -1.0);
    return;
  }
  // Sides as corner pairs: face+ 0→1, face− 3→2, edge+ 2→1, edge− 3→0 (P end first).
  double e[4][2];
  double* tr[4] = {nullptr, nullptr, nullptr, nullptr};
  if (track)
    for (int k = 0; k < 4; ++k) tr[k] = track + 2 * k;
  outside_ends(pl, i, cu[0], cv[0], in[0], cu[1], cv[1], in[1], w, &e[0][0], &e[0][1], tr[0]);
  outside_ends(pl, i, cu[3], cv[3], in[3], cu[2], cv[2], in[2], w, &e[1][0], &e[1][1], tr[1]);
  outside_ends(pl, i, cu[2], cv[2], in[2], cu[1], cv[1], in[1], t, &e[2][0], &e[2][1], tr[2]);
  outside_ends(pl, i, cu[3], cv[3], in[3], cu[0], cv[0], in[0], t, &e[3][0], &e[3][1], tr[3]);
  for (int k = 0; k < 4; ++k) sw.side[k] = e[k][0] + e[k][1];
  // Missing area: a right triangle at each corner, legs = the wane on its face and edge ends.
  sw.area = 0.5 * (e[0][1] * e[2][1] + e[0][0] * e[3][1] + e[1][1] * e[2][0] + e[1][0] * e[3][0]);
  sw.ok = sw.side[0] <= rules.max_face_fraction * w && sw.side[1] <= rules.max_face_fraction * w &&
          sw.side[2] <= rules.max_edge_fraction * t && sw.side[3] <= rules.max_edge_fraction * t &&
          sw.side[0] < w && sw.side[1] < w && sw.side[2] < t && sw.side[3] < t;
}

// slice_wane(...).ok without computing the wane where the limits decide earlier: the same corner
// tests, then each side in turn (side_ok), stopping at the first that fails. *no_wane is set
// when the answer came from the tests by which slice_wane returns no wane at all (the section
// surely inside, or all four corners inside), so that slice_wane need not run again there;
// *corners to the corners' inside() answers (bits 0–3) when it looked them up, else −1.
bool slice_ok(const Placement& pl, const Section& sec, const WaneRules& rules, int i, bool* no_wane,
              int* corners) {
  *no_wane = false;
  *corners = -1;
  const double hu = sec.ta == 0 ? sec.ht : sec.hw, hv = sec.ta == 0 ? sec.hw : sec.ht;
  if (pl.rect_surely_inside(i, sec.cu - hu, sec.cu + hu, sec.cv - hv, sec.cv + hv))
    return *no_wane = true;
  const double ca[4] = {sec.ht, sec.ht, -sec.ht, -sec.ht};
  const double cb[4] = {-sec.hw, sec.hw, sec.hw, -sec.hw};
  double cu[4], cv[4];
  bool in[4];
  for (int k = 0; k < 4; ++k) {
    sec.point(ca[k], cb[k], &cu[k], &cv[k]);
    in[k] = pl.inside(i, cu[k], cv[k]);
  }
  *corners = in[0] | in[1] << 1 | in[2] << 2 | in[3] << 3;
  if (in[0] && in[1] && in[2] && in[3]) return *no_wane = true;
  const double w = 2 * sec.hw, t = 2 * sec.ht;
  const double fl = rules.max_face_fraction * w, el = rules.max_edge_fraction * t;
  // Sides as corner pairs (face+ 0→1, face− 3→2, edge+ 2→1, edge− 3→0). Every side must pass,
  // so the order is free: first the cheap refusal of a side wholly outside the log (both ends
  // and the middle outside), then the edges (short: decided with fewer steps), then the faces.
  static constexpr int kEnds[4][2] = {{0, 1}, {3, 2}, {2, 1}, {3, 0}};
  for (const auto& e : kEnds) {
    const int a = e[0], b = e[1];
    if (!in[a] && !in[b] && !pl.inside(i, 0.5 * (cu[a] + cu[b]), 0.5 * (cv[a] + cv[b])))
      return false;
  }
  return side_ok(pl, i, cu[2], cv[2], in[2], cu[1], cv[1], in[1], t, el) &&
         side_ok(pl, i, cu[3], cv[3], in[3], cu[0], cv[0], in[0], t, el) &&
         side_ok(pl, i, cu[0], cv[0], in[0], cu[1], cv[1], in[1], w, fl) &&
         side_ok(pl, i, cu[3], cv[3], in[3], cu[2], cv[2], in[2], w, fl);
}

// Longest run of acceptable samples, trimmed to the length step and centred in the run.
// Returns false when nothing of at least the minimum length is left.
// `ok(i)` says whether sample i (of n) is acceptable. Runs shorter than min_run samples are of
// no use to the caller: they are not looked for, and when there is no longer one the answer may
// be any run or none. Otherwise it is the first longest run, as a scan from sample 0 finds it.
// Only a run longer than the best so far (and than min_run) can change the answer, and such a
// run holds the sample that many places on from where it could start: that sample is asked
// first, and only a run through it is followed out (ok() may be costly: edging's wane tests).
// The length a run of `run_mm` is trimmed to: whole length steps (none: as it is).
double trimmed_length(double run_mm, const WaneRules& rules) {
  return rules.length_step_mm > 0
             ? std::floor(run_mm / rules.length_step_mm + 1e-9) * rules.length_step_mm
             : run_mm;
}

template <class Ok>
bool trim(const Stem& stem, int n, Ok&& ok, const WaneRules& rules, int min_run, double* zb,
          double* ze) {
  int best0 = 0, best_n = 0;
  for (int i = 0; i < n;) {  // runs start at i or later (sample i − 1 is not acceptable)
    const int j = i + std::max(min_run, best_n + 1) - 1;
    if (j >= n) break;
    if (!ok(j)) {
      i = j + 1;
      continue;
    }
    int s = j;
    while (s > i && ok(s - 1)) --s;
    // The run from s must reach e to matter; if a sample between j and e is not acceptable
    // (looked for from e down), the run ends before it and no run that matters starts before
    // it either.
    const int need = std::max(min_run, best_n + 1);
    int e = s + need - 1;
    if (e >= n) break;
    int f = e;
    while (f > j && ok(f)) --f;
    if (f > j) {
      i = f + 1;
      continue;
    }
    while (e + 1 < n && ok(e + 1)) ++e;
    best_n = e - s + 1;
    best0 = s;
    i = e + 2;
  }
  if (best_n == 0) return false;
  const double run = best_n * stem.dz_mm;
  const double len = trimmed_length(run, rules);
  if (len <= 0 || len < rules.min_length_mm) return false;
  const double mid = stem.z_at(best0) - 0.5 * stem.dz_mm + 0.5 * run;
  *zb = mid - 0.5 * len;
  *ze = mid + 0.5 * len;
  return true;
}

// A knot polyline in the pattern frame, with its bounding box widened by half its diameter.
struct PlacedKnot {
  int first = 0, count = 0;  // into pts / r
  double lo[3], hi[3];
  bool monotone[2] = {false, false};  // u (v) never decreases or never increases along the axis
};

}  // namespace

SawResult saw(const SawLog& log, const Pattern& pattern, const LogPosition& pos) {
  SawResult res;
  const Stem& stem = log.model().stem;
  const double phi = pattern_rotation(log, pos);
  Placement pl{&log, std::cos(phi), std::sin(phi), pos.offset_x_mm, pos.offset_y_mm};
  thread_local std::vector<Vec2> pith_uv;
  thread_local std::vector<double> inner_r2;
  pl.prepare(pith_uv, inner_r2);

  // Knot axes in the pattern frame: (u, v) = Rot(φ)·q − offset.
  // pu / pv: the same coordinates by axis, for the plane-crossing scan.
  // Rot(φ)·q and its bounding box per knot depend on the rotation only: kept per thread for the
  // next position (the optimiser's next position is usually the same rotation at another
  // offset). Subtracting the offset afterwards gives the same numbers (the same operations in
  // the same order; the box's min and max commute with the subtraction, which is monotone).
  thread_local std::vector<Vec3> pts;
  thread_local std::vector<double> pu, pv;
  thread_local std::vector<PlacedKnot> placed;
  thread_local std::vector<int> crossings;
  thread_local std::uint64_t turned_log = 0;  // SawLog::serial()
  thread_local double turned_c = 0, turned_s = 0;
  thread_local std::vector<Vec3> turned;            // Rot(φ)·q, z kept, all knots in order
  thread_local std::vector<PlacedKnot> turned_box;  // their boxes (before offset and widening)
  if (turned_log != log.serial() || turned_c != pl.c || turned_s != pl.s ||
      turned_box.size() != log.knots().size()) {
    turned_log = log.serial();
    turned_c = pl.c;
    turned_s = pl.s;
    turned.clear();
    turned_box.assign(log.knots().size(), PlacedKnot{});
    for (size_t k = 0; k < log.knots().size(); ++k) {
      const SawLog::KnotPolyline& kp = log.knots()[k];
      PlacedKnot& tb = turned_box[k];
      tb.first = static_cast<int>(turned.size());
      tb.count = static_cast<int>(kp.q.size());
      for (int d = 0; d < 3; ++d) {
        tb.lo[d] = 1e300;
        tb.hi[d] = -1e300;
      }
      for (const Vec3& q : kp.q) {
        const Vec3 t{pl.c * q.x - pl.s * q.y, pl.s * q.x + pl.c * q.y, q.z};
        turned.push_back(t);
        const double c3[3] = {t.x, t.y, t.z};
        for (int d = 0; d < 3; ++d) {
          tb.lo[d] = std::min(tb.lo[d], c3[d]);
          tb.hi[d] = std::max(tb.hi[d], c3[d]);
        }
      }
      for (int d = 0; d < 2; ++d) {
        bool up = true, down = true;
        for (int j = tb.first; j + 1 < tb.first + tb.count; ++j) {
          const double a = d == 0 ? turned[j].x : turned[j].y;
          const double b = d == 0 ? turned[j + 1].x : turned[j + 1].y;
          up = up && a <= b;
          down = down && a >= b;
        }
        tb.monotone[d] = up || down;
      }
    }
  }
  pts.resize(turned.size());
  pu.resize(turned.size());
  pv.resize(turned.size());
  for (size_t j = 0; j < turned.size(); ++j) {
    const Vec3 p{turned[j].x - pl.ox, turned[j].y - pl.oy, turned[j].z};
    pts[j] = p;
    pu[j] = p.x;
    pv[j] = p.y;
  }
  placed = turned_box;
  for (size_t k = 0; k < log.knots().size(); ++k) {
    const SawLog::KnotPolyline& kp = log.knots()[k];
    PlacedKnot& pk = placed[k];
    const double off[3] = {pl.ox, pl.oy, 0.0};
    for (int d = 0; d < 2; ++d) {
      pk.lo[d] -= off[d];
      pk.hi[d] -= off[d];
    }
    for (int d = 0; d < 3; ++d) {
      pk.lo[d] -= kp.half_dmax;
      pk.hi[d] += kp.half_dmax;
    }
  }

  // Per-thread scratch, reused from call to call (no allocation per position once warm).
  thread_local std::vector<char> ok;
  thread_local std::vector<SliceWane> sw;
  thread_local std::vector<double> widths;
  thread_local std::vector<std::uint8_t> state;  // edging's tests per stem sample and width
  // Per stem sample, bit j: slice_ok at widths[j] found no wane at all (edged boards).
  thread_local std::vector<std::uint64_t> clear;
  // Per stem sample, 5 bits per width index j < 12: slice_ok at widths[j] looked up the corners
  // (bit 4) and what inside() answered there (bits 0–3), for the trimmed board's wane.
  thread_local std::vector<std::uint64_t> corner_bits;
  // Per board of the last pattern sawn on this thread, the width it got (0: none).
  thread_local std::vector<double> last_w;
  last_w.resize(std::max(last_w.size(), pattern.boards.size()), 0.0);
  std::vector<int> crossed(log.knots().size(), -1);
  const int n = stem.slice_count();
  for (size_t bi = 0; bi < pattern.boards.size(); ++bi) {
    const BoardSpec& spec = pattern.boards[bi];
    Section sec{spec.u_mm, spec.v_mm, 0.5 * spec.thickness_mm, 0.5 * spec.width_mm,
                spec.thickness_axis == ThicknessAxis::kU ? 0 : 1};
    // Candidate widths: the spec's own, or for edged boards every standard width ≤ it.
    widths.clear();
    if (spec.edged)
      for (double w : pattern.standard_widths_mm)
        if (w <= spec.width_mm + 1e-9) widths.push_back(w);
    if (widths.empty()) widths.push_back(spec.width_mm);
    std::sort(widths.begin(), widths.end());
    double best_value = 0, best_w = 0, best_zb = 0, best_ze = 0;
    int best_k = -1;  // edged boards: index of best_w in widths
    // Only whether each stem sample keeps to the wane rules is needed to trim and edge
    // (slice_ok); the wane itself is computed below for the samples of the trimmed board only.
    bool have_sw = false;
    if (widths.size() == 1) {
      // One width: the wane of every sample is needed for the trimmed board (nearly the whole
      // log), so compute it once here and keep it.
      best_w = widths[0];
      sec.hw = 0.5 * best_w;
      ok.resize(n);
      sw.resize(n);
      for (int i = 0; i < n; ++i) {
        slice_wane(pl, sec, pattern.wane, i, &sw[i]);
        ok[i] = sw[i].ok;
      }
      have_sw = true;
      const auto acceptable = [&](int i) { return ok[i] != 0; };
      if (trim(stem, n, acceptable, pattern.wane, 1, &best_zb, &best_ze))
        best_value = best_w * (best_ze - best_zb);
    } else {
      // Edging: the width whose trimmed board holds the most wood, where a stem sample counts
      // for width k when the section at that width keeps to the wane rules there (slice_ok).
      // Each (sample, width) is tested only when trim() asks for it, once: trim() asks few
      // samples, mostly at one width (the guess below). A section surely inside at the widest
      // width (rect_surely_inside, monotone in the width) passes at every width untested.
      // (Until 2026-12-07 a sample's widths were bisected, which assumes that acceptance
      // shrinks as the width grows, true on a convex outline; asking each width directly is
      // the definition itself, and on the through-and-through pattern a third fewer tests. The
      // boards were the same at every position of saw_bench --dump.)
      const int m = static_cast<int>(widths.size());
      state.assign(static_cast<size_t>(n) * m, 0);  // [sample × m + width]: 0 untested, 1 ok, 2 not
      clear.assign(n, 0);
      corner_bits.assign(n, 0);
      {
        const double hu = sec.ta == 0 ? sec.ht : 0.5 * widths[m - 1];
        const double hv = sec.ta == 0 ? 0.5 * widths[m - 1] : sec.ht;
        for (int i = 0; i < n; ++i)
          if (pl.rect_surely_inside(i, sec.cu - hu, sec.cu + hu, sec.cv - hv, sec.cv + hv)) {
            std::fill_n(state.begin() + static_cast<size_t>(i) * m, m, 1);
            clear[i] = ~std::uint64_t{0};
          }
      }
      const auto wide_enough_at = [&](int i, int k) {
        std::uint8_t& st = state[static_cast<size_t>(i) * m + k];
        if (st == 0) {
          sec.hw = 0.5 * widths[k];
          bool no_wane;
          int corners;
          st = slice_ok(pl, sec, pattern.wane, i, &no_wane, &corners) ? 1 : 2;
          if (no_wane && k < 64) clear[i] |= std::uint64_t{1} << k;
          if (corners >= 0 && k < 12)
            corner_bits[i] |= static_cast<std::uint64_t>(corners | 16) << 5 * k;
        }
        return st == 1;
      };
      // The width this board got at the thread's last position is tried first (the optimiser's
      // next position is usually the same rotation at the next offset): when it is the one
      // chosen again, the runs the other widths need to beat it are long, and they are refused
      // after a few tests. The choice is the one of trying the widths from the widest down and
      // keeping a strictly larger volume: the largest volume, the widest of equal ones.
      const int guess =
          static_cast<int>(std::find(widths.begin(), widths.end(), last_w[bi]) - widths.begin());
      const auto try_width = [&](int k) {
        const double w = widths[k];
        const bool wider = k > best_k;  // a wider width wins a tie
        // Runs too short to give as much wood as the best so far (or to reach the minimum
        // length) need not be found: the shortest that might (a little short of it, for
        // rounding), by bisection on the run length (the trimmed length grows with it).
        const auto might_do = [&](int run) {
          const double len = trimmed_length(run * stem.dz_mm, pattern.wane);
          const double v = w * len * (1 + 1e-9);
          return len > 0 && len >= pattern.wane.min_length_mm &&
                 (wider ? v >= best_value : v > best_value);
        };
        if (!might_do(n)) return;
        int lo = 0, hi = n;  // might_do(hi), not lo
        while (hi - lo > 1) {
          const int mid = (lo + hi) / 2;
          (might_do(mid) ? hi : lo) = mid;
        }
        double zb, ze;
        const auto wide_enough = [&](int i) { return wide_enough_at(i, k); };
        if (!trim(stem, n, wide_enough, pattern.wane, hi, &zb, &ze)) return;
        const double v = w * (ze - zb);
        if (v > best_value || (wider && v == best_value)) {
          best_value = v;
          best_w = w;
          best_k = k;
          best_zb = zb;
          best_ze = ze;
        }
      };
      if (guess < m) try_width(guess);
      for (int k = m - 1; k >= 0; --k) {
        if (k == guess) continue;
        if (k < best_k && widths[k] * stem.length_mm() <= best_value) break;
        try_width(k);
      }
    }
    last_w[bi] = best_value > 0 ? best_w : 0.0;
    if (best_value <= 0) {
      res.dropped.push_back(
          {static_cast<int>(bi), "no length of at least " +
                                     std::to_string(static_cast<int>(pattern.wane.min_length_mm)) +
                                     " mm within the wane rules"});
      continue;
    }
    sec.hw = 0.5 * best_w;
    Board b;
    b.spec = static_cast<int>(bi);
    b.name = spec.name;
    b.thickness_mm = spec.thickness_mm;
    b.width_mm = best_w;
    b.thickness_axis = spec.thickness_axis;
    b.u_mm = spec.u_mm;
    b.v_mm = spec.v_mm;
    b.z_begin = best_zb;
    b.z_end = best_ze;
    b.box_volume_m3 = spec.thickness_mm * best_w * (best_ze - best_zb) * 1e-9;
    b.sawn_begin = best_zb;
    b.sawn_end = best_ze;
    double missing = 0;
    // The crossings of the last sample computed, where the search at the next starts (edged
    // boards; a single width's wane decided its trimming above, with the plain search).
    double track[8] = {-1, -1, -1, -1, -1, -1, -1, -1};
    b.slabs.reserve(static_cast<size_t>((best_ze - best_zb) / stem.dz_mm) + 2);
    for (int i = 0; i < n; ++i) {
      const double z = stem.z_at(i);
      const double s0 = std::max(z - 0.5 * stem.dz_mm, best_zb);
      const double s1 = std::min(z + 0.5 * stem.dz_mm, best_ze);
      const double ov = s1 - s0;
      if (ov <= 0) continue;
      SliceWane here;
      if (have_sw)
        here = sw[i];
      else if (best_k >= 0 && best_k < 64 && (clear[i] >> best_k & 1))
        here = SliceWane{{0, 0, 0, 0}, 0, true};  // what slice_wane returns there
      else {
        const int cb =
            best_k >= 0 && best_k < 12 ? static_cast<int>(corner_bits[i] >> 5 * best_k & 31) : 0;
        slice_wane(pl, sec, pattern.wane, i, &here, cb & 16 ? cb & 15 : -1, track);
      }
      missing += here.area * ov;
      BoardSlab slab{s0, s1, {}, static_cast<float>(here.area)};
      for (int k = 0; k < 4; ++k) {
        b.wane[k].max_mm = std::max(b.wane[k].max_mm, here.side[k]);
        if (here.side[k] > 0) b.wane[k].length_mm += ov;
        slab.wane[k] = static_cast<float>(here.side[k]);
      }
      b.slabs.push_back(slab);
    }
    b.volume_m3 = b.box_volume_m3 - missing * 1e-9;

    // Knots on the four long sides: where each axis polyline crosses a side's plane.
    const int ta = sec.ta, wa = 1 - ta;
    const double centre[2] = {sec.cu, sec.cv};
    struct SidePlane {
      Side side;
      int axis;       // pattern axis of the plane normal
      double c;       // plane coordinate
      double e0, e1;  // extent across, along the other pattern axis
    };
    const SidePlane planes[4] = {
        {Side::kFacePlus, ta, centre[ta] + sec.ht, centre[wa] - sec.hw, centre[wa] + sec.hw},
        {Side::kFaceMinus, ta, centre[ta] - sec.ht, centre[wa] - sec.hw, centre[wa] + sec.hw},
        {Side::kEdgePlus, wa, centre[wa] + sec.hw, centre[ta] - sec.ht, centre[ta] + sec.ht},
        {Side::kEdgeMinus, wa, centre[wa] - sec.hw, centre[ta] - sec.ht, centre[ta] + sec.ht},
    };
    const double box_lo[2] = {sec.ta == 0 ? sec.cu - sec.ht : sec.cu - sec.hw,
                              sec.ta == 0 ? sec.cv - sec.hw : sec.cv - sec.ht};
    const double box_hi[2] = {2 * sec.cu - box_lo[0], 2 * sec.cv - box_lo[1]};
    const int board_no = static_cast<int>(res.boards.size());
    for (size_t k = 0; k < placed.size(); ++k) {
      const PlacedKnot& pk = placed[k];
      if (pk.hi[2] < best_zb || pk.lo[2] > best_ze) continue;
      if (pk.hi[0] < box_lo[0] || pk.lo[0] > box_hi[0] || pk.hi[1] < box_lo[1] ||
          pk.lo[1] > box_hi[1])
        continue;
      const SawLog::KnotPolyline& kp = log.knots()[k];
      const Knot& knot = log.model().knots[kp.index];
      for (const SidePlane& sp : planes) {
        const int oa = 1 - sp.axis;
        if (pk.hi[sp.axis] < sp.c || pk.lo[sp.axis] > sp.c) continue;
        if (pk.hi[oa] < sp.e0 || pk.lo[oa] > sp.e1) continue;
        // Segments j whose ends lie on either side of the plane ((f < 0) differs), in order:
        // a branch-free sign mask over the polyline, then its bit changes.
        const double* f = (sp.axis == 0 ? pu.data() : pv.data()) + pk.first;
        crossings.clear();
        if (pk.monotone[sp.axis] && pk.count >= 2) {
          // f − c is monotone too (subtracting a constant is monotone): at most one sign
          // change, found by bisection.
          const bool neg0 = f[0] - sp.c < 0;
          if ((f[pk.count - 1] - sp.c < 0) != neg0) {
            // The sign at lo is neg0, at lo + len not; written without a branch on the data
            // (the bisection's steps are unpredictable).
            int lo = 0, len = pk.count - 1;
            while (len > 1) {
              const int half = len / 2;
              lo = (f[lo + half] - sp.c < 0) == neg0 ? lo + half : lo;
              len -= half;
            }
            crossings.push_back(lo);
          }
        } else if (pk.count >= 2 && pk.count <= 64) {
          std::uint64_t neg = 0;
          for (int j = 0; j < pk.count; ++j)
            neg |= static_cast<std::uint64_t>(f[j] - sp.c < 0) << j;
          std::uint64_t x = (neg ^ (neg >> 1)) & ((std::uint64_t{1} << (pk.count - 1)) - 1);
          for (; x; x &= x - 1) crossings.push_back(std::countr_zero(x));
        } else {
          for (int j = 0; j + 1 < pk.count; ++j)
            if ((f[j] - sp.c < 0) != (f[j + 1] - sp.c < 0)) crossings.push_back(j);
        }
        for (const int j : crossings) {
          const double fa = f[j] - sp.c, f1 = f[j + 1] - sp.c;
          const double t = fa / (fa - f1);
          const Vec3& p0 = pts[pk.first + j];
          const Vec3& p1 = pts[pk.first + j + 1];
          const Vec3 x = p0 + t * (p1 - p0);
          const double r = kp.r[j] + t * (kp.r[j + 1] - kp.r[j]);
          const Vec3 d = (p1 - p0).normalized();
          const double dn = std::abs(sp.axis == 0 ? d.x : d.y);  // cos(axis, normal)
          const double dox = oa == 0 ? d.x : d.y;
          const double D = knot.diameter_at(r);
          const double minor = D, major = D / std::max(dn, 0.05);
          // Ellipse in the side plane, coordinates (across, z): major axis along the axis's
          // projection M, minor along m ⟂ M.
          double Mo = dox, Mz = d.z;
          const double mn = length2(Mo, Mz);
          if (mn < 1e-12) {
            Mo = 1;
            Mz = 0;
          } else {
            Mo /= mn;
            Mz /= mn;
          }
          const double a = 0.5 * minor, bb = 0.5 * major;
          const double ho = length2(a * Mz, bb * Mo);  // m = (−Mz, Mo)
          const double hz = length2(a * Mo, bb * Mz);
          const double xo = oa == 0 ? x.x : x.y;
          if (xo + ho < sp.e0 || xo - ho > sp.e1) continue;
          if (x.z + hz < best_zb || x.z - hz > best_ze) continue;
          KnotOnSide ks;
          ks.knot = kp.index;
          ks.knot_id = knot.id;
          ks.side = sp.side;
          const bool arris = xo - ho < sp.e0 || xo + ho > sp.e1;
          ks.kind =
              arris ? KnotKind::kArris
                    : (sp.side == Side::kFacePlus || sp.side == Side::kFaceMinus ? KnotKind::kFace
                                                                                 : KnotKind::kEdge);
          ks.z_mm = x.z;
          ks.along_mm = x.z - best_zb;
          ks.across_mm = xo - 0.5 * (sp.e0 + sp.e1);
          ks.r_mm = r;
          ks.diameter_mm = D;
          ks.minor_mm = minor;
          ks.major_mm = major;
          ks.width_mm = std::min(xo + ho, sp.e1) - std::max(xo - ho, sp.e0);
          ks.length_mm = 2 * hz;
          ks.angle_deg = std::asin(std::min(dn, 1.0)) * 180.0 / kPi;
          ks.dead = knot.dead_at(r);
          b.knots.push_back(ks);
          crossed[k] = board_no;
        }
      }
      if (crossed[k] != board_no) {
        // Not on any side: hidden when part of its axis lies inside the board.
        for (int j = 0; j < pk.count; ++j) {
          const Vec3& p = pts[pk.first + j];
          if (p.x >= box_lo[0] && p.x <= box_hi[0] && p.y >= box_lo[1] && p.y <= box_hi[1] &&
              p.z >= best_zb && p.z <= best_ze) {
            b.hidden_knots.push_back(kp.index);
            break;
          }
        }
      }
    }
    std::sort(b.knots.begin(), b.knots.end(), [](const KnotOnSide& l, const KnotOnSide& r) {
      return l.side != r.side ? l.side < r.side : l.z_mm < r.z_mm;
    });
    res.volume_m3 += b.volume_m3;
    res.boards.push_back(std::move(b));
  }
  return res;
}

}  // namespace sawyer::sawing

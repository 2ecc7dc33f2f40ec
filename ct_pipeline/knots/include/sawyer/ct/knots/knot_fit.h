// The knot-formula fit with Ceres (issue 5): a KnotTrace's shells → a Knot of the log model
// (docs/architecture.md 4): axis z(r) = z0 + a·√r + b·r and ω(r) = ω0 + twist·ln r, the diameter
// profile d(r) = d_dead·(r/r_dead)^p up to r_dead and d_dead beyond, r_dead and r_end.
//
// Robust loss on the axis residuals (knot flanks, neighbours in the whorl), bounds on the
// parameters, and r_dead as a breakpoint profiled over candidate values (each candidate's
// diameter fit is a smooth problem; the best total cost wins) rather than a kink left to the
// optimiser.
//
//   KnotFitOptions o;
//   Result<KnotFitReport> fit = fit_knot(trace, o);
//   if (fit) log.knots.push_back(fit.value().knot);   // id left 0: the caller numbers knots
//
// Units: mm and rad, the frame of knot_detect.h. Thread-safe (pure, no shared state); one
// knot costs well under a millisecond on one core.
#pragma once

#include <cmath>

#include "sawyer/core/result.h"
#include "sawyer/ct/knots/knot_detect.h"
#include "sawyer/model/log_model.h"

namespace sawyer::ct {

// The robust loss of the axis and diameter fits (Ceres' HuberLoss / CauchyLoss). Cauchy
// redescends: a neighbour's blob 8–15 mm off pulls it much less than it pulls Huber.
enum class RobustLoss { kHuber, kCauchy };

struct KnotFitOptions {
  double huber_mm = 1.5;  // robust-loss scale of the axis residuals (mm); 0: plain least
                          // squares (the name predates the Cauchy choice)
  RobustLoss loss = RobustLoss::kCauchy;
  int min_shells = 4;         // fewer shells: not fitted (an error); at least 3
  double r_dead_step_mm = 2;  // spacing of the r_dead candidates (> 0)

  double diameter_huber_mm = 1.5;  // robust-loss scale of the diameter residuals (mm); 0: plain
  double predicted_weight = 0.3;   // weight of shells followed by prediction (weak evidence)
  int full_weight_voxels = 20;     // shells with fewer voxels weigh voxels/this (≥ 0.2);
                                   // voxels ≤ 0 means "not counted": full weight
  double dark_ring_hu = -50;       // ring_hu below this: a dark (encased-bark) ring, dead sign
  // A dead part must lower the robust diameter cost by dead_penalty·ln(n)·σ̂² (n shells with a
  // diameter, σ̂ their robust residual scale) before it is preferred over a sound knot: r_dead
  // is an extra, change-point parameter (a BIC-like penalty).
  double dead_penalty = 1.5;
  // Each dark-ring shell that a candidate calls sound costs this many σ̂² (dead evidence); once
  // the trace has a few dark shells, each segmented shell without a ring that a candidate calls
  // dead costs half as much.
  double dark_ring_cost = 2;
  int max_iterations = 50;  // per Ceres solve
  // r_dead from the knot's core density (shells' core_hu: a dead knot is lighter than the sound
  // knot it grew from) where the trace has enough of it; the diameter's kink and the dark rings
  // decide only where it does not. false: always from the diameters.
  bool use_density = true;
  // Thickness (mm) of the bark encased around a dead knot, part of its outline but not of the
  // dense core the detector measures: added on both sides to the diameters beyond an r_dead
  // found from the density. 0: diameters as measured.
  double encased_bark_mm = 1.0;
};

struct KnotFitReport {
  Knot knot;               // fit_rms_mm and support filled; id left 0
  double axis_rms_mm = 0;  // axis residual RMS over the height and arc-length components, mm
  double diameter_rms_mm = 0;
  int iterations = 0;        // Ceres iterations, all solves
  int dark_ring_shells = 0;  // shells whose ring_hu says "encased bark"
  bool dead = false;         // a dead part was found (knot.r_dead < knot.r_end)
  // The density test for a dead part (knot_fit.cpp r_dead_from_density): the drop of the core
  // HU level from its highest inside to the outer part, and the core HU's own scatter about its
  // level (robust σ); NaN when too few shells had a core HU.
  double density_step_hu = NAN, density_noise_hu = NAN;
};

// Errors: too few shells, non-finite shell values, or a solve that did not give a usable
// solution (the message says which, with the shell count).
Result<KnotFitReport> fit_knot(const KnotTrace& trace, const KnotFitOptions& options = {});

}  // namespace sawyer::ct

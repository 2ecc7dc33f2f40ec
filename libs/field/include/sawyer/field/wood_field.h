// The wood time field t(P) of a log model (Larsson et al. 2022, sections 4.1-4.2): 0 at the
// pith, 1 at the bark, annual rings as its iso-surfaces, knots merged with the stem by the
// power smooth minimum, dead knots that stop thickening and bend the rings back.
//
// The formulas live in shaders/wood_field.glsl, shared word for word with the GLSL renderer;
// this class only gathers their inputs from the LogModel (pith, outer radius, knot axes and
// diameters) and keeps a per-height index of knots so each point visits only the knots near it.
//
//   WoodField field(log);                       // log must outlive field
//   FieldSample s = field.sample({x, y, z});    // anywhere, mm
//   WoodField::Slice sl = field.slice(z);       // many points at one height: faster
//   for (...) FieldSample s = sl.sample(x, y);
//
// The knot material agrees with the model: a point is in knot i exactly where
// LogModel::material_at says so (pith distance <= r_end, within half the diameter of the axis
// point at the same pith distance), up to the optional outline noise (params.knot_noise).
//
// Thread safety: a WoodField and its Slices are immutable after construction; sample() may be
// called from many threads.
#pragma once

#include <cstdint>
#include <vector>

#include "sawyer/core/vec.h"
#include "sawyer/model/log_model.h"

namespace sawyer {

struct WoodFieldParams {
  // Relative noise on the knots' outlines (0.05 = +-5 %); 0 gives the model's exact diameters.
  double knot_noise = 0.05;
  // Reference radius for the knots' range of influence (mm); 0 = the stem's mean radius.
  double reference_radius_mm = 0.0;
};

struct FieldSample {
  float t = 0;           // the merged time field (rings are its iso-surfaces)
  float t_stem = 0;      // the stem's own time r / R(omega, z)
  float t_knot = 1e30f;  // the smallest knot time at this point (1e30 when no knot is near)
  float r = 0;           // pith distance, mm
  float omega = 0;       // azimuth around the pith, rad
  float radius = 0;      // outer radius R(omega, z) at this height, mm
  int knot = -1;         // index of the knot whose wood this is, -1 outside knots
  bool dead = false;     // inside the dead part of that knot
  float knot_depth = 0;  // inside a knot: distance from its axis / its local radius (0..1)
  bool inside() const { return r <= radius; }
};

class WoodField {
 public:
  explicit WoodField(const LogModel& log, const WoodFieldParams& params = {});

  // The field at point p (scanner frame, mm). Outside the stem t_stem > 1.
  FieldSample sample(const Vec3& p) const;

  // Everything that depends only on the height, computed once for many samples at that height.
  class Slice {
   public:
    FieldSample sample(double x, double y) const;
    double z() const { return z_; }
    Vec2 pith() const { return pith_; }
    // Largest outer radius at this height (mm): nothing of the log lies beyond it.
    double max_radius() const { return max_radius_; }

   private:
    friend class WoodField;
    const WoodField* field_ = nullptr;
    double z_ = 0;
    Vec2 pith_;
    double max_radius_ = 0;
    std::vector<float> radius_;  // outer radius at n equally spaced azimuths
    std::vector<int> knots_;     // candidate knots at this height
    std::vector<float> tracks_;  // per candidate: axis x, y, z, azimuth every 0.5 mm of r
    std::vector<int> track_offset_;
  };
  Slice slice(double z) const;

  const LogModel& log() const { return *log_; }
  const WoodFieldParams& params() const { return params_; }
  double reference_radius() const { return r_ref_; }
  // Knots whose range of influence reaches height z (indices into log().knots).
  const std::vector<int>& knots_near(double z) const;

 private:
  struct KnotInfo {
    double zmin = 0, zmax = 0;  // heights the knot's influence can reach
    std::uint32_t seed = 0;
  };
  // One knot's contribution at a point: shared by sample() and Slice::sample().
  struct KnotEval {
    float t_b;    // knot time, or 1e30 beyond r_end
    float delta;  // modified amount of smoothing
    float depth;  // dist / rho
    bool inside;  // in the knot's wood
    bool dead;
  };
  KnotEval eval_knot(int i, float r, float t_s, float R, const Vec3& p, const Vec3& axis,
                     float axis_omega) const;
  FieldSample combine(FieldSample s, const KnotEval* evals, const int* ids, int n) const;

  const LogModel* log_;
  WoodFieldParams params_;
  double r_ref_ = 0;
  std::vector<KnotInfo> info_;
  double bucket_mm_ = 10.0;
  double bucket_z0_ = 0.0;
  std::vector<std::vector<int>> buckets_;
};

}  // namespace sawyer

// The log model on the GPU at float precision, and the wood time field evaluated from it: the
// GLSL twin of libs/field's WoodField::sample (same inputs, same formulas from wood_field.glsl,
// same order of operations; tests/render_field_test.cpp proves they agree).
//
// Data (filled by libs/render/src/gpu_log_data.cpp):
//   pith[]      pith (x, y) every u_pith_step mm of height from u_pith_z0 (Catmull-Rom of the
//               model's samples, linear between these);
//   u_stem      RG16 texture: outer radius and heartwood radius (0 = none) as fractions of
//               u_stem_scale mm, columns = azimuth (wraps), rows every u_stem_step mm from
//               u_stem_z0;
//   knots[]     per knot: diameter profile, r_dead, r_end, noise seed, where its track starts;
//   tracks[]    per knot: the axis (x, y, z, unwrapped azimuth) every u_track_step mm of pith
//               distance from 0 to the end of its influence;
//   bark[]      bark thickness (mm) at the model's stem samples, when it is drawn and known;
//   cell_start[], cell_knots[]   the knot index: for each cell of (height, pith distance,
//               azimuth) the knots whose range of influence can reach it. Without WOOD_INDEX a
//               fragment visits every knot (the straightforward port of the published loop).

#include "wood_field.glsl"

struct WoodKnot {
  float r_dead;
  float r_end;
  float d_dead;
  float d_exp;
  float half_dmax;
  float pad0;
  int track_offset;
  int track_count;
  uint seed;
  uint pad1;
  uint pad2;
  uint pad3;
};

layout(std430, binding = 0) readonly buffer WoodPith { vec2 pith[]; };
layout(std430, binding = 1) readonly buffer WoodTracks { vec4 tracks[]; };
layout(std430, binding = 2) readonly buffer WoodKnots { WoodKnot knots[]; };
layout(std430, binding = 3) readonly buffer WoodCellStart { int cell_start[]; };
layout(std430, binding = 4) readonly buffer WoodCellKnots { int cell_knots[]; };
layout(std430, binding = 5) readonly buffer WoodBark { float bark[]; };

layout(binding = 0) uniform sampler2D u_stem;

uniform float u_pith_z0;
uniform float u_pith_step;
uniform int u_pith_count;
uniform float u_stem_z0;
uniform float u_stem_step;
uniform float u_stem_rows;
uniform float u_stem_scale;
uniform float u_r_ref;
uniform float u_knot_noise;
uniform float u_track_step;
uniform int u_knot_count;
uniform float u_cell_z0;
uniform float u_cell_dz;
uniform int u_cell_nz;
uniform float u_cell_dr;
uniform int u_cell_nr;
uniform int u_cell_ns;
uniform int u_bark_count;      // bark samples every u_bark_step mm from u_stem_z0 (0: none)
uniform float u_bark_step;
uniform float u_bark_default;  // bark thickness (mm) where the model has none (0: no bark)

const float WOOD_TWO_PI = 6.28318530718;
const float WOOD_FAR = 1e30;

// What the field says at a point (the GLSL twin of sawyer::FieldSample, plus what the colouring
// needs about the nearest dead knot).
struct WoodSample {
  float t;         // merged time field
  float t_stem;    // r / R
  float t_knot;    // smallest knot time (WOOD_FAR when none)
  float r;         // pith distance, mm
  float omega;     // azimuth, rad
  float radius;    // outer radius R(omega, z), mm
  float heartwood; // heartwood radius, mm (0: none)
  float bark;      // bark thickness outside R, mm (0: none or not drawn)
  vec2 radial;     // unit horizontal direction from the pith
  int knot;        // knot whose wood this is, -1 outside knots
  bool dead;       // in the dead part of that knot
  float knot_depth;
  float knot_rate;   // that knot's time per mm across its axis (t_c / rho), for filtering
  float near_depth;  // nearest knot (r <= r_end): distance from its axis / its radius
  float near_rho;    // that knot's radius here, mm
  float dead_depth;  // nearest dead knot: distance from its axis / its radius (WOOD_FAR: none)
  float dead_rho;    // that knot's radius, mm
  float dead_beta;   // angle around that knot's axis
  uint dead_seed;
};

vec2 wood_pith_at(float z) {
  float u = clamp((z - u_pith_z0) / u_pith_step, 0.0, float(u_pith_count - 1));
  int i = min(int(u), u_pith_count - 2);
  return mix(pith[i], pith[i + 1], u - float(i));
}

// Bark thickness at height z (mm): the model's per-sample values (linear between; 0 when the
// model has none and the look gives no default, or bark is not drawn).
float wood_bark_at(float z) {
  if (u_bark_count < 1) return u_bark_default;
  float u = clamp((z - u_stem_z0) / u_bark_step, 0.0, float(u_bark_count - 1));
  int i = min(int(u), max(u_bark_count - 2, 0));
  if (u_bark_count == 1) return bark[0];
  return mix(bark[i], bark[i + 1], u - float(i));
}

// Diameter at pith distance r (sawyer::Knot::diameter_at).
float wood_knot_diameter(WoodKnot k, float r) {
  if (r <= 0.0) return 0.0;
  if (k.r_dead <= 0.0) return k.d_dead;
  float rr = min(r, k.r_dead);
  return k.d_dead * pow(rr / k.r_dead, k.d_exp);
}

// One knot's share at point p (WoodField::eval_knot); accumulates into the running sums.
void wood_visit_knot(int i, vec3 p, float r, float t_s, float R, float reach, inout float t_min,
                     inout float delta_sum, inout float best_depth, inout WoodSample s) {
  WoodKnot k = knots[i];
  float jf = r / u_track_step;
  if (jf >= float(k.track_count - 1)) return;  // beyond the knot's influence
  int j = int(jf);
  float a = jf - float(j);
  vec4 p0 = tracks[k.track_offset + j];
  vec4 p1 = tracks[k.track_offset + j + 1];
  float az = p0.z + (p1.z - p0.z) * a;
  if (abs(p.z - az) > reach) return;
  vec3 axis = vec3(p0.x + (p1.x - p0.x) * a, p0.y + (p1.y - p0.y) * a, az);
  float axis_omega = p0.w + (p1.w - p0.w) * a;
  vec3 v = p - axis;
  float dist = length(v);
  float fade_range = wf_range_fade(dist, r, u_r_ref);
  if (fade_range <= 0.0) return;
  // Angle around the axis: 0 at the knot's horizontal side, +-pi/2 above and below it.
  float side = -sin(axis_omega) * v.x + cos(axis_omega) * v.y;
  float beta = (side == 0.0 && v.z == 0.0) ? 0.0 : atan(v.z, side);
  float r_live = min(r, k.r_dead);
  float rho0 = 0.5 * wood_knot_diameter(k, r_live);
  float rho = wf_knot_rho(rho0, dist, beta, r, k.seed, u_knot_noise);
  float t_c = r_live / R;
  float t_since_death = max(r - k.r_dead, 0.0) / R;
  float t_b = wf_knot_time(dist, rho, t_c, t_since_death);
  float fade = fade_range * wf_end_fade(r, k.r_end, k.half_dmax);
  delta_sum += wf_knot_delta(t_s, t_b, t_since_death, beta, fade);
  if (r <= k.r_end) {
    t_min = min(t_min, t_b);
    float depth = dist / max(rho, 1e-3);
    bool dead = t_since_death > 0.0;
    if (dist < rho && depth < best_depth) {
      best_depth = depth;
      s.knot = i;
      s.dead = dead;
      s.knot_depth = depth;
      s.knot_rate = t_c / max(rho, 1e-3);
    }
    if (depth < s.near_depth) {
      s.near_depth = depth;
      s.near_rho = rho;
    }
    if (dead && depth < s.dead_depth) {
      s.dead_depth = depth;
      s.dead_rho = rho;
      s.dead_beta = beta;
      s.dead_seed = k.seed;
    }
  }
}

// The stem's part of a sample (pith, radii, t_stem), cheap: enough to tell whether p lies in
// the log before the knots are visited.
WoodSample wood_stem(vec3 p) {
  WoodSample s;
  vec2 c = wood_pith_at(p.z);
  vec2 d = p.xy - c;
  float r = length(d);
  float w = atan(d.y, d.x);
  if (w < 0.0) w += WOOD_TWO_PI;
  if (w >= WOOD_TWO_PI) w -= WOOD_TWO_PI;
  s.r = r;
  s.omega = w;
  s.radial = r > 0.0 ? d / r : vec2(1.0, 0.0);
  vec2 tc = vec2(w / WOOD_TWO_PI, ((p.z - u_stem_z0) / u_stem_step + 0.5) / u_stem_rows);
  vec2 rh = texture(u_stem, tc).xy * u_stem_scale;
  s.radius = rh.x;
  s.heartwood = rh.y;
  s.bark = wood_bark_at(p.z);
  s.t_stem = r / s.radius;
  s.knot = -1;
  s.dead = false;
  s.knot_depth = 0.0;
  s.knot_rate = 0.0;
  s.near_depth = WOOD_FAR;
  s.near_rho = 0.0;
  s.dead_depth = WOOD_FAR;
  s.dead_rho = 0.0;
  s.dead_beta = 0.0;
  s.dead_seed = 0u;
  s.t_knot = WOOD_FAR;
  s.t = s.t_stem;
  return s;
}

// Adds the knots to a sample from wood_stem (paper Eq. 6 and the knot index).
void wood_knots(vec3 p, inout WoodSample s) {
  float r = s.r;
  float w = s.omega;
  float t_min = WOOD_FAR;
  float delta_sum = 0.0;
  float best_depth = WOOD_FAR;
  float reach = wf_range_outer(r, u_r_ref);
#ifdef WOOD_INDEX
  int zc = clamp(int(floor((p.z - u_cell_z0) / u_cell_dz)), 0, u_cell_nz - 1);
  int rc = min(int(r / u_cell_dr), u_cell_nr - 1);
  int sc = min(int(w / WOOD_TWO_PI * float(u_cell_ns)), u_cell_ns - 1);
  int cell = (zc * u_cell_nr + rc) * u_cell_ns + sc;
  int end = cell_start[cell + 1];
  for (int n = cell_start[cell]; n < end; ++n)
    wood_visit_knot(cell_knots[n], p, r, s.t_stem, s.radius, reach, t_min, delta_sum, best_depth, s);
#else
  for (int i = 0; i < u_knot_count; ++i)
    wood_visit_knot(i, p, r, s.t_stem, s.radius, reach, t_min, delta_sum, best_depth, s);
#endif
  s.t_knot = t_min;
  s.t = wf_union(s.t_stem, t_min, delta_sum);
}

// The whole field at p.
WoodSample wood_sample(vec3 p) {
  WoodSample s = wood_stem(p);
  wood_knots(p, s);
  return s;
}

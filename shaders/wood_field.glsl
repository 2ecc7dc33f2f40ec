// The wood time field of Larsson et al. 2022 (sections 4.1-4.2), the one source of truth for
// both the GLSL renderer and the C++ code (phantom CT density, tests). This file is written in
// the common subset of GLSL 4.50 and C++20: the C++ side includes it after
// libs/field/src/glsl_shim.h, which supplies vec2/vec3 and the GLSL built-ins it uses. Rules
// for editing: no swizzles, no inout/out parameters, no arrays, no struct constructors, float
// literals with a decimal point, and only the built-ins the shim provides.
//
// Units: times are fractions of the stem's growth (0 at the pith, 1 at the bark); lengths are
// millimetres; angles are radians.
//
// One knot against the stem (the caller finds the knot's axis point at the point's pith
// distance, the paper's pseudo-nearest point, and passes what it measured):
//   wf_knot_time()   the knot's own time t_b, with the stop in thickening after death;
//   wf_knot_delta()  the knot's modified amount of smoothing delta' (paper Eq. 5);
// and the union of the stem with all knots (paper Eq. 6): t = min(t_s, t_b...) + sum(delta'),
// with each delta' faded out inside other knots by wf_interior_fade().

// ---- parameters (defaults follow the published shader where it has one) ---------------------

// Power smooth minimum: soft outside a knot (strong distortion of the stem's rings), sharp
// inside it (a defined knot edge); k moves between them with the time difference t_s - t_b.
const float WF_K_STEM = 1.5;
const float WF_K_KNOT = 5.0;
const float WF_K_SPREAD = 0.3;
// Dead knots: k grows with time since death (the fillet tightens) ...
const float WF_DEAD_K_RATE = 5.0;
// ... and the smoothing is scaled by a factor that goes from 1 at death to WF_DEAD_F_END
// (negative: the rings dip towards the knot) at rate WF_DEAD_F_RATE per unit of time.
const float WF_DEAD_F_END = -0.5;
const float WF_DEAD_F_RATE = 8.0;
// Butterfly: the distortion around a dead knot is stronger above and below the knot than at
// its sides (the paper's CT observation; its published code leaves it out). 0 = even.
const float WF_BUTTERFLY = 0.6;

// ---- the power smooth minimum ---------------------------------------------------------------

// ((a^k b^k) / (a^k + b^k))^(1/k) for a, b >= 0 (paper Eq. 2). Written as
// min * (1 + (min/max)^k)^(-1/k), which is the same value without overflow for large k.
float wf_power_smin(float a, float b, float k) {
  float lo = min(a, b);
  float hi = max(a, b);
  if (hi <= 0.0) return 0.0;
  float q = pow(lo / hi, k);
  return lo * pow(1.0 + q, -1.0 / k);
}

// Adaptive k (paper section 4.2.1): near WF_K_KNOT inside the knot (t_b < t_s), near WF_K_STEM
// outside it.
float wf_adaptive_k(float t_s, float t_b) {
  float d = t_s - t_b;
  return 0.5 * (WF_K_KNOT - WF_K_STEM) * d / (WF_K_SPREAD + abs(d)) +
         0.5 * (WF_K_KNOT + WF_K_STEM);
}

// The dead-knot factor f(time since death, beta): 1 at death, easing to WF_DEAD_F_END, with
// the butterfly making it stronger above/below the knot (beta = +-pi/2) than at its sides
// (beta = 0, pi).
float wf_dead_factor(float t_since_death, float beta) {
  float s = WF_DEAD_F_RATE * max(t_since_death, 0.0);
  float ease = s / (1.0 + s);
  float wing = 1.0 - WF_BUTTERFLY * cos(2.0 * beta);
  return mix(1.0, WF_DEAD_F_END * wing, ease);
}

// ---- one knot --------------------------------------------------------------------------------

// The knot's time at a point `dist` mm from its axis, where the knot's radius is `rho` mm and
// the stem's time at the axis is `t_c` (both taken at min(r, r_dead): the knot stops
// thickening when it dies). After death (t_since_death > 0) the knot's time runs on with the
// stem's, so its edge stays where it was (paper section 4.2.2). The knot's edge is exactly
// where wf_knot_time = t_s, i.e. at dist = rho.
float wf_knot_time(float dist, float rho, float t_c, float t_since_death) {
  float t_b = dist * t_c / max(rho, 1e-3);
  return t_b + max(t_since_death, 0.0);
}

// The modified amount of smoothing delta' of one knot against the stem (paper Eq. 3-5), times
// `fade` (1 near the knot, 0 outside its range of influence).
float wf_knot_delta(float t_s, float t_b, float t_since_death, float beta, float fade) {
  float k = wf_adaptive_k(t_s, t_b);
  bool dead = t_since_death > 0.0;
  if (dead) k = k + WF_DEAD_K_RATE * t_since_death;
  float delta = wf_power_smin(t_s, t_b, k) - min(t_s, t_b);
  if (dead) delta = delta * wf_dead_factor(t_since_death, beta);
  return delta * fade;
}

// Range of influence of a knot around its axis, in mm, at pith distance r (the published
// shader's rule, in millimetres with r_ref the stem's reference radius): full effect within
// wf_range_inner, fading to none at wf_range_outer.
float wf_range_inner(float r, float r_ref) { return 0.1 * r_ref + 0.8 * r; }
float wf_range_outer(float r, float r_ref) { return 0.2 * r_ref + r; }

// 1 inside the inner range, 0 beyond the outer one, linear between.
float wf_range_fade(float dist, float r, float r_ref) {
  float a = wf_range_inner(r, r_ref);
  float b = wf_range_outer(r, r_ref);
  return 1.0 - clamp((dist - a) / max(b - a, 1e-3), 0.0, 1.0);
}

// After a knot's end (an overgrown stub) its distortion closes over smoothly within
// 2 * rho + 5 mm instead of stopping at a wall.
float wf_end_fade(float r, float r_end, float rho) {
  return 1.0 - smoothstep(r_end, r_end + 2.0 * rho + 5.0, r);
}

// A knot must not distort the inside of another knot: each delta' is faded by how deep the
// point lies inside the nearest knot (t_b_min well below t_s).
float wf_interior_fade(float t_s, float t_b_min) {
  float depth = max(t_s - t_b_min, 0.0) / max(t_s, 1e-6);
  return 1.0 - smoothstep(0.0, 1.0, depth);
}

// The union of the stem with all knots (paper Eq. 6), from its three running sums.
float wf_union(float t_s, float t_b_min, float delta_sum) {
  return min(t_s, t_b_min) + delta_sum * wf_interior_fade(t_s, t_b_min);
}

// ---- periodic noise for knot outlines --------------------------------------------------------

// Integer hash (a variant of the "lowbias32" mixer); same bits in GLSL and C++.
uint wf_hash(uint x) {
  x = x ^ (x >> 16u);
  x = x * 0x7feb352du;
  x = x ^ (x >> 15u);
  x = x * 0x846ca68bu;
  x = x ^ (x >> 16u);
  return x;
}

// Value at integer lattice point (i, j) in [-1, 1], periodic in i with period `pi`.
float wf_lattice(int i, int j, int pi, uint seed) {
  int ii = i - pi * int(floor(float(i) / float(pi)));
  uint h = wf_hash(uint(ii) * 0x9e3779b1u ^ wf_hash(uint(j) + seed * 0x85ebca77u));
  return float(h & 0xffffu) / 32767.5 - 1.0;
}

// Smooth value noise in [-1, 1], periodic in u with integer period `pu` (u wraps at pu).
float wf_noise(float u, float v, int pu, uint seed) {
  float fu = floor(u);
  float fv = floor(v);
  int i = int(fu);
  int j = int(fv);
  float su = smoothstep(0.0, 1.0, u - fu);
  float sv = smoothstep(0.0, 1.0, v - fv);
  float a = mix(wf_lattice(i, j, pu, seed), wf_lattice(i + 1, j, pu, seed), su);
  float b = mix(wf_lattice(i, j + 1, pu, seed), wf_lattice(i + 1, j + 1, pu, seed), su);
  return mix(a, b, sv);
}

// Relative variation of a knot's radius around its axis (beta) and along it (r, mm): the
// published shader's periodic noise, two octaves, amplitude `amp` (e.g. 0.08 = +-8 %).
float wf_knot_radius_noise(float beta, float r, uint knot_seed, float amp) {
  float b01 = beta / 6.28318530718 + 0.5;
  float n = 0.65 * wf_noise(b01 * 3.0, r / 12.0, 3, knot_seed) +
            0.35 * wf_noise(b01 * 7.0, r / 5.0, 7, knot_seed + 101u);
  return amp * n;
}

// A knot's local radius (mm) at a point `dist` mm from its axis: the model's radius rho0 with
// the outline noise, which only matters near the outline and is faded out beyond 2-3 radii so
// that far points see the knot's plain radius.
float wf_knot_rho(float rho0, float dist, float beta, float r, uint knot_seed, float amp) {
  float near_outline = 1.0 - smoothstep(2.0 * rho0, 3.0 * rho0, dist);
  // The noise costs more than the rest of a knot's evaluation: skip it where it has no effect.
  if (near_outline <= 0.0 || amp <= 0.0) return rho0;
  return rho0 * (1.0 + near_outline * wf_knot_radius_noise(beta, r, knot_seed, amp));
}

// ---- annual rings ----------------------------------------------------------------------------

// Latewood fraction at time t for `rings` annual rings from pith to bark: 0 in earlywood, rising
// to 1 in the latewood at the end of each year, with a sharp drop at the ring border.
float wf_latewood(float t, float rings) {
  float phase = fract(max(t, 0.0) * rings);
  return smoothstep(0.55, 0.92, phase) * (1.0 - smoothstep(0.97, 1.0, phase));
}

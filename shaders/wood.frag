// Fragment stage of the knotted-wood renderer (Larsson et al. 2022, sections 4.1-4.3): the wood
// time field at the fragment's 3D point (wood_log_data.glsl), coloured from the wood colour
// strip; knots in their own colour with their own rings, dead knots ringed by encased bark,
// heartwood tinted and bark outside the stem where the look asks for them (the species look,
// WoodLook in wood_renderer.h); Phong lighting with the normal and specular strips. u_mode 1
// writes the raw field instead, to a float target.
//
// Anti-aliasing is adaptive: every pixel takes one sample at its centre, and only pixels where
// the field changes within the pixel (a knot's edge or bark ring, the log's outline, rings
// crowded by a knot, a knot's fine rings) take u_supersample x u_supersample samples. Elsewhere
// the strips' mipmaps, sampled at the field's rate across the screen, already filter the rings.

#include "wood_log_data.glsl"

in vec3 v_pos;
in vec3 v_normal;

layout(binding = 1) uniform sampler2D u_color_map;
layout(binding = 2) uniform sampler2D u_normal_map;
layout(binding = 3) uniform sampler2D u_specular_map;

uniform int u_mode;            // 0: wood colour, 1: raw field (t, t_stem, t_knot, knot code)
uniform float u_z_begin;       // the log's extent along z
uniform float u_z_end;
uniform float u_surface_tol;   // fragments up to R * (1 + tol) from the pith count as inside
uniform vec3 u_eye;            // perspective: the eye; orthographic: unused
uniform vec3 u_view_dir;       // orthographic: the direction the camera looks along
uniform int u_ortho;
uniform vec3 u_light_dir;      // towards the light, unit
uniform float u_ambient;
uniform float u_diffuse;
uniform float u_specular;
uniform int u_lighting;
uniform float u_knot_darkening;
uniform float u_dead_outline;
uniform int u_heartwood_tint;
uniform int u_supersample;     // samples per pixel side where the field changes within a pixel
uniform int u_outline_samples; // 1: the outline of wood and bark cuts this surface (planes), so
                               // pixels on it take samples; 0: the log's own surface
uniform float u_strip_rings;   // annual rings in the colour strip, pith to bark
uniform float u_strip_luma;    // the colour strip's mean luminance
// The look (WoodLook): colours in display RGB, 0-1.
uniform vec3 u_knot_sound;     // sound knot wood, mid-ring
uniform vec3 u_knot_dead;      // dead knot wood, mid-ring
uniform vec3 u_bark_ring;      // the encased bark around a dead knot
uniform float u_knot_rings;    // contrast of a knot's own rings (exponent on the strip's)
uniform vec3 u_heart_tint;     // heartwood: multiplies the ring colour
uniform vec3 u_bark_inner;     // inner bark (phloem), next to the wood
uniform vec3 u_bark_outer;     // outer bark

out vec4 out_color;

float wood_luma(vec3 c) { return dot(c, vec3(0.299, 0.587, 0.114)); }

// How a sample is seen: its point, the screen-space rates the strips are filtered at, and what
// is lit.
struct WoodShading {
  vec3 N;  // the surface's normal, facing the viewer
  vec3 V;  // towards the viewer
  vec3 dpdx;
  vec3 dpdy;
};

// Outer bark: grey-brown plates with darker furrows along the stem (periodic value noise around
// the log, slower along it); inner bark: a thin reddish-brown layer next to the wood.
vec3 wood_bark_color(WoodSample s, vec3 p) {
  float depth = (s.r - s.radius) / max(s.bark, 1e-3);  // 0 at the wood, 1 at the outside
  float plates = wf_noise(s.omega / WOOD_TWO_PI * 90.0, p.z / 60.0, 90, 17u);
  float fine = wf_noise(s.omega / WOOD_TWO_PI * 360.0, p.z / 9.0, 360, 29u);
  float furrow = smoothstep(-0.2, -0.6, plates);
  vec3 outer = u_bark_outer * (1.0 + 0.12 * fine) * (1.0 - 0.45 * furrow);
  return mix(u_bark_inner, outer, smoothstep(0.06, 0.14, depth));
}

// The colour and light of one sample.
vec3 wood_shade(WoodSample s, vec3 p, WoodShading sh) {
  if (s.bark > 0.0 && s.r > s.radius) {
    vec3 c = wood_bark_color(s, p);
    if (u_lighting == 0) return c;
    float diff = max(dot(sh.N, u_light_dir), 0.0);
    return (u_ambient + u_diffuse * diff) * vec3(1.0, 1.0, 0.95) * c;
  }
  // The strips are sampled with the field's rate of change across the screen, so where rings
  // are finer than a pixel their mipmaps blend them (no moire on a whole log in a small image):
  // the stem's rate from the analytic gradient of t_stem (radial / R), a knot's from its own
  // (t_c / rho across its axis). Only derivatives of the interpolated position are taken:
  // derivatives of the field would mix in the helper pixels of a 2x2 quad, for which some
  // drivers (llvmpipe) skip buffer loads.
  vec3 grad_ts = vec3(s.radial, 0.0) / max(s.radius, 1.0);
  float dtdx = abs(dot(grad_ts, sh.dpdx));
  float dtdy = abs(dot(grad_ts, sh.dpdy));
  bool in_knot = s.near_depth < 1.1;
  if (in_knot) {
    dtdx = max(dtdx, s.knot_rate * length(sh.dpdx));
    dtdy = max(dtdy, s.knot_rate * length(sh.dpdy));
  }
  float t = clamp(s.t, 0.0, 1.0);
  vec2 gx = vec2(dtdx, 0.0);
  vec2 gy = vec2(dtdy, 0.0);
  vec3 ring = textureGrad(u_color_map, vec2(t, 0.5), gx, gy).rgb;
  vec3 color = ring;

  // Heartwood (when the model has it and the species shows it): a soft border 3 mm wide.
  if (u_heartwood_tint != 0 && s.heartwood > 0.0) {
    float hw = 1.0 - smoothstep(s.heartwood - 1.5, s.heartwood + 1.5, s.r);
    color = mix(color, color * u_heart_tint, hw);
  }

  // Knots (section 4.3, beyond the published subtraction of a grey): the knot's own wood colour,
  // its own growth rings from the knot's time field (the strip's ring pattern at the knot's
  // time, its contrast raised: knot wood has narrow rings of dark latewood), a soft edge where a
  // sound knot is intergrown with the stem. A dead knot has its own, greyer colour up to a ring
  // of encased bark whose thickness varies around the knot (periodic noise); no lighter band
  // inside the ring.
  float rings = pow(clamp(wood_luma(ring) / max(u_strip_luma, 1e-3), 0.3, 1.05), u_knot_rings);
  bool dead = s.dead_depth < 1.5;
  float width = 0.0;
  if (dead) {
    float b01 = s.dead_beta / WOOD_TWO_PI + 0.5;
    width = 0.10 * (1.0 + 0.7 * wf_noise(b01 * 5.0, s.r / 6.0, 5, s.dead_seed + 7u)) *
            u_dead_outline;
  }
  vec3 knot_color = (s.knot >= 0 && s.dead) || (s.knot < 0 && dead) ? u_knot_dead : u_knot_sound;
  float knot_weight = dead ? 1.0 - smoothstep(0.985, 1.0, s.dead_depth)
                           : 1.0 - smoothstep(0.92, 1.02, s.near_depth);
  color = mix(color, knot_color * rings, u_knot_darkening * knot_weight);
  if (!dead && s.near_rho > 0.0) {
    // A sound knot's rim: its last rings, darker where the knot meets the stem's wood.
    float rim = smoothstep(0.84, 0.95, s.near_depth) * (1.0 - smoothstep(0.99, 1.02, s.near_depth));
    color *= 1.0 - 0.2 * u_knot_darkening * rim;
  }
  if (dead && width > 0.0) {
    // The ring lies just inside the knot's outline, its inner side softer than its outer one.
    float inner = smoothstep(1.0 - width - 0.03, 1.0 - width, s.dead_depth);
    float outer = 1.0 - smoothstep(1.0, 1.02, s.dead_depth);
    color = mix(color, u_bark_ring, u_knot_darkening * inner * outer);
  }
  color = max(color, vec3(0.0));

  if (u_lighting == 0) return color;
  // Phong lighting; the normal strip tilts the normal across the rings: along the direction the
  // stem's rings advance on this surface (the radial direction projected onto it, not
  // normalised, so the tilt fades out where a face looks straight at the pith instead of
  // flipping sign there: the published shader normalises it and leaves a seam), less in knots.
  vec3 N = sh.N;
  vec3 nm = textureGrad(u_normal_map, vec2(t, 0.5), gx, gy).rgb;
  vec3 radial = vec3(s.radial, 0.0);
  vec3 T = radial - dot(radial, N) * N;
  float tilt = (1.0 - knot_weight) * (2.0 * nm.x - 1.0);
  N = normalize(tilt * T + abs(2.0 * nm.z - 1.0) * N);
  vec3 L = u_light_dir;
  float diff = max(dot(N, L), 0.0);
  vec3 Rf = reflect(-L, N);
  float shine = textureGrad(u_specular_map, vec2(t, 0.5), gx, gy).r;
  float spec = pow(max(dot(sh.V, Rf), 0.0), 32.0);
  vec3 light = vec3(1.0, 1.0, 0.95);
  return (u_ambient + u_diffuse * diff) * light * color + u_specular * shine * spec * light;
}

// Whether p lies outside what is drawn: beyond the wood (and its bark when drawn), or beyond
// the log's ends. `margin` widens the wood by that many mm.
bool wood_outside(WoodSample s, vec3 p, float margin) {
  float reach = (s.bark > 0.0 ? s.radius + s.bark : s.radius) * (1.0 + u_surface_tol);
  return s.r > reach + margin || p.z < u_z_begin || p.z > u_z_end;
}

// Whether the field changes within this pixel so that one sample would alias: within ~1.5
// pixels of a knot's edge, a dead knot's bark ring, or the outline of the wood and bark; or
// where the rings are closer than ~4 pixels and the filter's rate (the stem's) is well below the
// field's actual one (rings crowded around a knot).
bool wood_needs_samples(WoodSample s, float px_mm, float t_rate_px, float filter_rate_px) {
  float near = 1.5 * px_mm;
  if (s.near_rho > 0.0 && abs(s.near_depth - 1.0) * s.near_rho < near + 0.08 * s.near_rho)
    return true;
  if (s.dead_rho > 0.0 && abs(s.dead_depth - 0.93) * s.dead_rho < near + 0.12 * s.dead_rho)
    return true;
  if (u_outline_samples != 0) {
    if (abs(s.r - s.radius) < near) return true;
    if (s.bark > 0.0 && abs(s.r - s.radius - s.bark) < near) return true;
  }
  float ring_px = t_rate_px * u_strip_rings;
  return ring_px > 0.25 && t_rate_px > 1.5 * filter_rate_px;
}

void main() {
  // Fragments outside the log skip the knots (they are discarded below, after the derivatives,
  // which need every fragment of a 2x2 quad to get here).
  WoodSample s = wood_stem(v_pos);
  vec3 dpdx = dFdx(v_pos);
  vec3 dpdy = dFdy(v_pos);
  float px_mm = max(length(dpdx), length(dpdy));
  int n = u_mode == 0 ? clamp(u_supersample, 1, 4) : 1;
  // A pixel whose centre is outside may still be partly inside: those within a pixel of the
  // outline are sampled below.
  bool outside = u_mode == 0 && wood_outside(s, v_pos, 0.0);
  bool far_outside = u_mode == 0 && wood_outside(s, v_pos, n > 1 ? 0.75 * px_mm : 0.0);
  if (!outside) wood_knots(v_pos, s);
  // The field's rate across the screen (derivatives of the field: used only to decide where to
  // take more samples, where a helper pixel's wrong value costs samples, not colour).
  float t_rate_px = abs(dFdx(s.t)) + abs(dFdy(s.t));
  vec3 grad_ts = vec3(s.radial, 0.0) / max(s.radius, 1.0);
  float filter_rate_px = abs(dot(grad_ts, dpdx)) + abs(dot(grad_ts, dpdy));
  if (u_mode == 1) {
    float code = s.knot < 0 ? -1.0 : float(s.knot) + (s.dead ? 0.5 : 0.0);
    out_color = vec4(s.t, s.t_stem, s.t_knot, code);
    return;
  }
  if (far_outside) discard;

  WoodShading sh;
  sh.V = u_ortho != 0 ? -u_view_dir : normalize(u_eye - v_pos);
  sh.N = normalize(v_normal);
  if (dot(sh.N, sh.V) < 0.0) sh.N = -sh.N;  // sections are seen from either side
  sh.dpdx = dpdx;
  sh.dpdy = dpdy;
#ifdef WOOD_ONE_SAMPLE
  // The program for one sample a pixel (WoodRenderer picks it when supersample is 1).
  if (outside) discard;
  out_color = vec4(wood_shade(s, v_pos, sh), 1.0);
#else
  if (n == 1 || !wood_needs_samples(s, px_mm, t_rate_px, filter_rate_px)) {
    if (outside) discard;
    out_color = vec4(wood_shade(s, v_pos, sh), 1.0);
    return;
  }
  // n x n samples on a regular grid inside the pixel; each filters its strips at 1/n of the
  // pixel's rate. Samples outside the wood are left out and the pixel's coverage goes to alpha
  // (blended over what is behind).
  sh.dpdx = dpdx / float(n);
  sh.dpdy = dpdy / float(n);
  vec3 sum = vec3(0.0);
  int inside = 0;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      vec3 p = v_pos + dpdx * ((float(i) + 0.5) / float(n) - 0.5) +
               dpdy * ((float(j) + 0.5) / float(n) - 0.5);
      WoodSample q = wood_stem(p);
      if (wood_outside(q, p, 0.0)) continue;
      wood_knots(p, q);
      sum += wood_shade(q, p, sh);
      inside += 1;
    }
  }
  if (inside == 0) discard;
  out_color = vec4(sum / float(inside), float(inside) / float(n * n));
#endif
}

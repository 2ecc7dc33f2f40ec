// Fragment stage of the knotted-wood renderer (Larsson et al. 2022, sections 4.1-4.3): the wood
// time field at the fragment's 3D point (wood_log_data.glsl), coloured from the wood colour
// strip, knots darkened, dead knots outlined, heartwood tinted, Phong lighting with the normal
// and specular strips. u_mode 1 writes the raw field instead, to a float target.

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

out vec4 out_color;

// Knots: the ring colour times a warm brown (sound knots are reddish brown in pine and spruce);
// dead knots darker and greyer still. (The published renderer subtracts a grey.)
const vec3 WOOD_KNOT_TINT = vec3(0.74, 0.56, 0.42);
const vec3 WOOD_DEAD_TINT = vec3(0.80, 0.76, 0.74);
// Heartwood: a slightly darker, warmer shade of the same rings.
const vec3 WOOD_HEART_TINT = vec3(0.88, 0.80, 0.70);

void main() {
  // Fragments outside the log skip the knots (they are discarded below, after the derivatives,
  // which need every fragment of a 2x2 quad to get here).
  WoodSample s = wood_stem(v_pos);
  bool outside = u_mode == 0 &&
                 (s.t_stem > 1.0 + u_surface_tol || v_pos.z < u_z_begin || v_pos.z > u_z_end);
  if (!outside) wood_knots(v_pos, s);
  // How fast the stem's rings advance across the screen, from the analytic gradient of t_stem
  // (radial / R) and the screen-space derivatives of the position. Only derivatives of the
  // interpolated position are taken: derivatives of the field itself would mix in the helper
  // pixels of a 2x2 quad, for which some drivers (llvmpipe) skip buffer loads.
  vec3 dpdx = dFdx(v_pos);
  vec3 dpdy = dFdy(v_pos);
  vec3 grad_ts = vec3(s.radial, 0.0) / max(s.radius, 1.0);
  float dtdx = dot(grad_ts, dpdx);
  float dtdy = dot(grad_ts, dpdy);
  if (u_mode == 1) {
    float code = s.knot < 0 ? -1.0 : float(s.knot) + (s.dead ? 0.5 : 0.0);
    out_color = vec4(s.t, s.t_stem, s.t_knot, code);
    return;
  }
  if (outside) discard;

  // The strips are sampled with the field's screen-space rate of change, so where rings are
  // finer than a pixel their mipmaps blend them (no moire on a whole log in a small image).
  float t = clamp(s.t, 0.0, 1.0);
  vec2 gx = vec2(dtdx, 0.0);
  vec2 gy = vec2(dtdy, 0.0);
  vec3 color = textureGrad(u_color_map, vec2(t, 0.5), gx, gy).rgb;

  // Heartwood (when the model has it): a soft border 3 mm wide.
  if (u_heartwood_tint != 0 && s.heartwood > 0.0) {
    float hw = 1.0 - smoothstep(s.heartwood - 1.5, s.heartwood + 1.5, s.r);
    color = mix(color, color * WOOD_HEART_TINT, hw);
  }

  // Knots (section 4.3): the knot's wood darker, with a soft edge a few percent of its radius
  // wide; dead knots darker still, with an outline whose thickness varies around the knot with
  // periodic noise.
  float knot_weight = 1.0 - smoothstep(0.9, 1.06, s.near_depth);
  color = mix(color, color * WOOD_KNOT_TINT, u_knot_darkening * knot_weight);
  if (s.knot >= 0 && s.dead) color = mix(color, color * WOOD_DEAD_TINT, u_knot_darkening);
  if (s.dead_depth < 2.0 && u_dead_outline > 0.0) {
    float b01 = s.dead_beta / WOOD_TWO_PI + 0.5;
    float width = 0.09 * (1.0 + 0.7 * wf_noise(b01 * 5.0, s.r / 6.0, 5, s.dead_seed + 7u));
    float edge = abs(s.dead_depth - 1.0);
    float outline = 1.0 - smoothstep(0.5 * width, width, edge);
    color *= 1.0 - 0.55 * u_dead_outline * outline;
  }
  color = max(color, vec3(0.0));

  if (u_lighting == 0) {
    out_color = vec4(color, 1.0);
    return;
  }
  // Phong lighting; the normal strip tilts the normal across the rings: along the direction the
  // stem's rings advance on this surface (the radial direction projected onto it, not
  // normalised, so the tilt fades out where a face looks straight at the pith instead of
  // flipping sign there: the published shader normalises it and leaves a seam), less in knots.
  vec3 V = u_ortho != 0 ? -u_view_dir : normalize(u_eye - v_pos);
  vec3 N = normalize(v_normal);
  if (dot(N, V) < 0.0) N = -N;  // sections are seen from either side
  vec3 nm = textureGrad(u_normal_map, vec2(t, 0.5), gx, gy).rgb;
  vec3 radial = vec3(s.radial, 0.0);
  vec3 T = radial - dot(radial, N) * N;
  float tilt = (1.0 - knot_weight) * (2.0 * nm.x - 1.0);
  N = normalize(tilt * T + abs(2.0 * nm.z - 1.0) * N);
  vec3 L = u_light_dir;
  float diff = max(dot(N, L), 0.0);
  vec3 Rf = reflect(-L, N);
  float shine = textureGrad(u_specular_map, vec2(t, 0.5), gx, gy).r;
  float spec = pow(max(dot(V, Rf), 0.0), 32.0);
  vec3 light = vec3(1.0, 1.0, 0.95);
  vec3 result = (u_ambient + u_diffuse * diff) * light * color + u_specular * shine * spec * light;
  out_color = vec4(result, 1.0);
}

// Sawyer's knotted-wood time field (Larsson et al. 2022, sections 4.1-4.2) in the subset of
// code that OSL and C++ share, evaluated from the tables `sawyer export --osl-data` writes
// (render::FieldTables as float EXR files; docs/export.md "OSL"). A port of
// shaders/wood_field.glsl and shaders/wood_log_data.glsl (the renderer's field, same formulas,
// same order of operations), without the knot index (every knot is visited) and without bark.
// tests/osl_field_test.cpp compiles this file as C++ through tests/osl_shim.h and checks it
// against the GLSL renderer's field on board faces.
//
// The includer defines, before including this file:
//   SW_UINT            an unsigned 32-bit integer type (OSL: int, with SW_SHR and the SW_K
//                      constants giving unsigned results in two's complement)
//   SW_SHR(x, n)       logical right shift
//   SW_K(hex, signed)  a 32-bit constant: C++ takes the hex, OSL the same bits as a signed int
//   SW_TO_UINT(x)      an int's bits as SW_UINT
//   SW_OUT(type)       an output parameter: "output type" (OSL), "type&" (C++)
//   string             a string type (OSL's own; C++: std::string)
//   sw_fetch(file, x, y, w, h, a, b, c, d)   texel (x, y) of a w × h float RGBA table (row 0
//                      the file's first), exact (no filtering), coordinates clamped
// and the math built-ins used below (OSL's own; tests/osl_shim.h for C++).
//
// Rules for editing: no names of OSL's shader globals (P, I, N, Ng, u, v, time, Ci, ...) for
// variables, no arrays, no swizzles, no methods, no templates, no "const", no "unsigned"
// or "u" suffixes; float literals with a decimal point; functions return one value and give
// more through SW_OUT parameters; struct members are set one by one.

// ---- parameters (wood_field.glsl's) -----------------------------------------------------------
#define SW_K_STEM 1.5
#define SW_K_KNOT 5.0
#define SW_K_SPREAD 0.3
#define SW_DEAD_K_RATE 5.0
#define SW_DEAD_F_END -0.5
#define SW_DEAD_F_RATE 8.0
#define SW_BUTTERFLY 0.6
#define SW_TWO_PI 6.28318530718
#define SW_FAR 1e30
#define SW_TRACK_ROW 1024

// The tables and scalars of one log (sawyer_osl.json; render::FieldTables).
struct SwLog {
  string pith_file;   // pith_count × 1: (x, y, 0, 0) mm
  string stem_file;   // stem_cols × stem_rows: (R, H, 0, 0) mm
  string knot_file;   // 3 × knot_count
  string track_file;  // SW_TRACK_ROW × track_rows: (x, y, z, azimuth)
  float pith_z0;
  float pith_step;
  int pith_count;
  float stem_z0;
  float stem_step;
  int stem_cols;
  int stem_rows;
  int knot_count;
  int track_rows;
  float track_step;
  float r_ref;
  float knot_noise;
};

// ---- the power smooth minimum and its friends (wood_field.glsl) -------------------------------

float sw_power_smin(float a, float b, float k) {
  float lo = min(a, b);
  float hi = max(a, b);
  if (hi <= 0.0) return 0.0;
  float q = pow(lo / hi, k);
  return lo * pow(1.0 + q, -1.0 / k);
}

float sw_adaptive_k(float t_s, float t_b) {
  float d = t_s - t_b;
  return 0.5 * (SW_K_KNOT - SW_K_STEM) * d / (SW_K_SPREAD + abs(d)) + 0.5 * (SW_K_KNOT + SW_K_STEM);
}

float sw_dead_factor(float t_since_death, float beta) {
  float s = SW_DEAD_F_RATE * max(t_since_death, 0.0);
  float ease = s / (1.0 + s);
  float wing = 1.0 - SW_BUTTERFLY * cos(2.0 * beta);
  return mix(1.0, SW_DEAD_F_END * wing, ease);
}

float sw_knot_time(float dist, float rho, float t_c, float t_since_death) {
  float t_b = dist * t_c / max(rho, 1e-3);
  return t_b + max(t_since_death, 0.0);
}

float sw_knot_delta(float t_s, float t_b, float t_since_death, float beta, float fade) {
  float k = sw_adaptive_k(t_s, t_b);
  int dead = t_since_death > 0.0;
  if (dead) k = k + SW_DEAD_K_RATE * t_since_death;
  float delta = sw_power_smin(t_s, t_b, k) - min(t_s, t_b);
  if (dead) delta = delta * sw_dead_factor(t_since_death, beta);
  return delta * fade;
}

float sw_range_inner(float r, float r_ref) { return 0.1 * r_ref + 0.8 * r; }
float sw_range_outer(float r, float r_ref) { return 0.2 * r_ref + r; }

float sw_range_fade(float dist, float r, float r_ref) {
  float a = sw_range_inner(r, r_ref);
  float b = sw_range_outer(r, r_ref);
  return 1.0 - clamp((dist - a) / max(b - a, 1e-3), 0.0, 1.0);
}

float sw_end_fade(float r, float r_end, float rho) {
  return 1.0 - smoothstep(r_end, r_end + 2.0 * rho + 5.0, r);
}

float sw_interior_fade(float t_s, float t_b_min) {
  float depth = max(t_s - t_b_min, 0.0) / max(t_s, 1e-6);
  return 1.0 - smoothstep(0.0, 1.0, depth);
}

float sw_union(float t_s, float t_b_min, float delta_sum) {
  return min(t_s, t_b_min) + delta_sum * sw_interior_fade(t_s, t_b_min);
}

// ---- periodic noise for knot outlines (same bits as wood_field.glsl's wf_hash) ----------------

SW_UINT sw_hash(SW_UINT x0) {
  SW_UINT x = x0;
  x = x ^ SW_SHR(x, 16);
  x = x * SW_K(0x7feb352d, 2146121005);
  x = x ^ SW_SHR(x, 15);
  x = x * SW_K(0x846ca68b, -2073254261);
  x = x ^ SW_SHR(x, 16);
  return x;
}

float sw_lattice(int i, int j, int pi, SW_UINT seed) {
  int ii = i - pi * int(floor(float(i) / float(pi)));
  SW_UINT h = sw_hash(SW_TO_UINT(ii) * SW_K(0x9e3779b1, -1640531535) ^
                      sw_hash(SW_TO_UINT(j) + seed * SW_K(0x85ebca77, -2048144777)));
  return float(h & 65535) / 32767.5 - 1.0;
}

float sw_noise(float nu, float nv, int pu, SW_UINT seed) {
  float fu = floor(nu);
  float fv = floor(nv);
  int i = int(fu);
  int j = int(fv);
  float su = smoothstep(0.0, 1.0, nu - fu);
  float sv = smoothstep(0.0, 1.0, nv - fv);
  float a = mix(sw_lattice(i, j, pu, seed), sw_lattice(i + 1, j, pu, seed), su);
  float b = mix(sw_lattice(i, j + 1, pu, seed), sw_lattice(i + 1, j + 1, pu, seed), su);
  return mix(a, b, sv);
}

float sw_knot_radius_noise(float beta, float r, SW_UINT knot_seed, float amp) {
  float b01 = beta / SW_TWO_PI + 0.5;
  float n = 0.65 * sw_noise(b01 * 3.0, r / 12.0, 3, knot_seed) +
            0.35 * sw_noise(b01 * 7.0, r / 5.0, 7, knot_seed + 101);
  return amp * n;
}

float sw_knot_rho(float rho0, float dist, float beta, float r, SW_UINT knot_seed, float amp) {
  float near_outline = 1.0 - smoothstep(2.0 * rho0, 3.0 * rho0, dist);
  if (near_outline <= 0.0 || amp <= 0.0) return rho0;
  return rho0 * (1.0 + near_outline * sw_knot_radius_noise(beta, r, knot_seed, amp));
}

// ---- the log's tables (wood_log_data.glsl) ----------------------------------------------------

void sw_pith_at(SwLog lg, float z, SW_OUT(float) x, SW_OUT(float) y) {
  float fz = clamp((z - lg.pith_z0) / lg.pith_step, 0.0, float(lg.pith_count - 1));
  int i = min(int(fz), lg.pith_count - 2);
  float a = fz - float(i);
  float x0 = 0.0;
  float y0 = 0.0;
  float x1 = 0.0;
  float y1 = 0.0;
  float unused0 = 0.0;
  float unused1 = 0.0;
  sw_fetch(lg.pith_file, i, 0, lg.pith_count, 1, x0, y0, unused0, unused1);
  sw_fetch(lg.pith_file, i + 1, 0, lg.pith_count, 1, x1, y1, unused0, unused1);
  x = mix(x0, x1, a);
  y = mix(y0, y1, a);
}

// The outer radius at azimuth w and height z: bilinear, periodic in w, clamped in z (the
// renderer's RG32F texture with GL_LINEAR, GL_REPEAT in s, GL_CLAMP_TO_EDGE in t).
float sw_outer_radius(SwLog lg, float w, float z) {
  float fx = w / SW_TWO_PI * float(lg.stem_cols) - 0.5;
  float fy = clamp((z - lg.stem_z0) / lg.stem_step, 0.0, float(lg.stem_rows - 1));
  float x0f = floor(fx);
  float y0f = floor(fy);
  float ax = fx - x0f;
  float ay = fy - y0f;
  int x0 = int(x0f);
  int y0 = int(y0f);
  x0 = x0 - lg.stem_cols * int(floor(float(x0) / float(lg.stem_cols)));
  int x1 = x0 + 1;
  if (x1 >= lg.stem_cols) x1 = 0;
  int y1 = min(y0 + 1, lg.stem_rows - 1);
  float r00 = 0.0;
  float r10 = 0.0;
  float r01 = 0.0;
  float r11 = 0.0;
  float unused0 = 0.0;
  float unused1 = 0.0;
  float unused2 = 0.0;
  sw_fetch(lg.stem_file, x0, y0, lg.stem_cols, lg.stem_rows, r00, unused0, unused1, unused2);
  sw_fetch(lg.stem_file, x1, y0, lg.stem_cols, lg.stem_rows, r10, unused0, unused1, unused2);
  sw_fetch(lg.stem_file, x0, y1, lg.stem_cols, lg.stem_rows, r01, unused0, unused1, unused2);
  sw_fetch(lg.stem_file, x1, y1, lg.stem_cols, lg.stem_rows, r11, unused0, unused1, unused2);
  return mix(mix(r00, r10, ax), mix(r01, r11, ax), ay);
}

void sw_track(SwLog lg, int i, SW_OUT(float) x, SW_OUT(float) y, SW_OUT(float) z, SW_OUT(float) w) {
  int row = i / SW_TRACK_ROW;
  sw_fetch(lg.track_file, i - row * SW_TRACK_ROW, row, SW_TRACK_ROW, lg.track_rows, x, y, z, w);
}

float sw_knot_diameter(float r_dead, float d_dead, float d_exp, float r) {
  if (r <= 0.0) return 0.0;
  if (r_dead <= 0.0) return d_dead;
  float rr = min(r, r_dead);
  return d_dead * pow(rr / r_dead, d_exp);
}

// ---- the field --------------------------------------------------------------------------------

// The merged time field t at p (scanner frame, mm) and what the colouring needs: t_stem
// (r / R; > 1 outside the wood), the knot whose wood p is in (-1: none) and whether p lies in
// its dead part (wood_sample in wood_log_data.glsl, every knot visited).
float sw_wood_field(SwLog lg, float px, float py, float pz, SW_OUT(float) t_stem, SW_OUT(int) knot,
                    SW_OUT(int) dead) {
  float cx = 0.0;
  float cy = 0.0;
  sw_pith_at(lg, pz, cx, cy);
  float dx = px - cx;
  float dy = py - cy;
  float r = sqrt(dx * dx + dy * dy);
  float w = atan2(dy, dx);
  if (w < 0.0) w += SW_TWO_PI;
  if (w >= SW_TWO_PI) w -= SW_TWO_PI;
  float R = sw_outer_radius(lg, w, pz);
  float t_s = r / R;
  t_stem = t_s;
  knot = -1;
  dead = 0;
  float t_min = SW_FAR;
  float delta_sum = 0.0;
  float best_depth = SW_FAR;
  float reach = sw_range_outer(r, lg.r_ref);
  for (int i = 0; i < lg.knot_count; i += 1) {
    float r_dead = 0.0;
    float r_end = 0.0;
    float d_dead = 0.0;
    float d_exp = 0.0;
    float half_dmax = 0.0;
    float offset_f = 0.0;
    float count_f = 0.0;
    float seed_lo = 0.0;
    float seed_hi = 0.0;
    float unused0 = 0.0;
    float unused1 = 0.0;
    float unused2 = 0.0;
    sw_fetch(lg.knot_file, 0, i, 3, lg.knot_count, r_dead, r_end, d_dead, d_exp);
    sw_fetch(lg.knot_file, 1, i, 3, lg.knot_count, half_dmax, offset_f, count_f, seed_lo);
    sw_fetch(lg.knot_file, 2, i, 3, lg.knot_count, seed_hi, unused0, unused1, unused2);
    int track_offset = int(offset_f);
    int track_count = int(count_f);
    SW_UINT seed = SW_TO_UINT(int(seed_lo)) + SW_TO_UINT(int(seed_hi)) * 65536;
    float jf = r / lg.track_step;
    if (jf >= float(track_count - 1)) continue;
    int j = int(jf);
    float a = jf - float(j);
    float x0 = 0.0;
    float y0 = 0.0;
    float z0 = 0.0;
    float w0 = 0.0;
    float x1 = 0.0;
    float y1 = 0.0;
    float z1 = 0.0;
    float w1 = 0.0;
    sw_track(lg, track_offset + j, x0, y0, z0, w0);
    sw_track(lg, track_offset + j + 1, x1, y1, z1, w1);
    float az = z0 + (z1 - z0) * a;
    if (abs(pz - az) > reach) continue;
    float ax = x0 + (x1 - x0) * a;
    float ay = y0 + (y1 - y0) * a;
    float axis_omega = w0 + (w1 - w0) * a;
    float vx = px - ax;
    float vy = py - ay;
    float vz = pz - az;
    float dist = sqrt(vx * vx + vy * vy + vz * vz);
    float fade_range = sw_range_fade(dist, r, lg.r_ref);
    if (fade_range <= 0.0) continue;
    float side = -sin(axis_omega) * vx + cos(axis_omega) * vy;
    float beta = (side == 0.0 && vz == 0.0) ? 0.0 : atan2(vz, side);
    float r_live = min(r, r_dead);
    float rho0 = 0.5 * sw_knot_diameter(r_dead, d_dead, d_exp, r_live);
    float rho = sw_knot_rho(rho0, dist, beta, r, seed, lg.knot_noise);
    float t_c = r_live / R;
    float t_since_death = max(r - r_dead, 0.0) / R;
    float t_b = sw_knot_time(dist, rho, t_c, t_since_death);
    float fade = fade_range * sw_end_fade(r, r_end, half_dmax);
    delta_sum += sw_knot_delta(t_s, t_b, t_since_death, beta, fade);
    if (r <= r_end) {
      t_min = min(t_min, t_b);
      float depth = dist / max(rho, 1e-3);
      if (dist < rho && depth < best_depth) {
        best_depth = depth;
        knot = i;
        dead = t_since_death > 0.0;
      }
    }
  }
  return sw_union(t_s, t_min, delta_sum);
}

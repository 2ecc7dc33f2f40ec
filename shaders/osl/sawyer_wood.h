// Sawyer's knotted-wood time field (Larsson et al. 2022, sections 4.1-4.2) in the subset of
// code that OSL and C++ share, evaluated from the tables `sawyer export --osl-data` writes
// (render::FieldTables as float EXR files; docs/export.md "OSL"). A port of
// shaders/wood_field.glsl and shaders/wood_log_data.glsl (the renderer's field, same formulas,
// same order of operations) with the renderer's knot index (a point visits only the knots
// listed for its cell of height, pith distance and azimuth), and of shaders/wood.frag's colour
// of wood and knots (the species look, without light, bark or the strips' filtering, which the
// renderer that calls it does). tests/osl_field_test.cpp compiles this file as C++ through
// tests/osl_shim.h and checks it against the GLSL renderer's field and colour on board faces,
// and the indexed field against the one that visits every knot.
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
  // The knot index (wood_log_data.glsl's cell_start[], cell_knots[]): one integer a texel (R),
  // SW_TRACK_ROW to a row. Cell (zc, rc, sc) = (zc × cell_nr + rc) × cell_ns + sc lists the
  // knots cell_knots[cell_start[cell] .. cell_start[cell + 1]). cell_nz 0: no index (every
  // knot is visited).
  string cell_start_file;
  string cell_knot_file;
  int cell_start_rows;
  int cell_knot_rows;
  float cell_z0;
  float cell_dz;
  int cell_nz;
  float cell_dr;
  int cell_nr;
  int cell_ns;
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

// The outer and heartwood radius at azimuth w and height z: bilinear, periodic in w, clamped in
// z (the renderer's stem texture with GL_LINEAR, GL_REPEAT in s, GL_CLAMP_TO_EDGE in t).
void sw_stem_radii(SwLog lg, float w, float z, SW_OUT(float) outer, SW_OUT(float) heart) {
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
  float h00 = 0.0;
  float h10 = 0.0;
  float h01 = 0.0;
  float h11 = 0.0;
  float unused0 = 0.0;
  float unused1 = 0.0;
  sw_fetch(lg.stem_file, x0, y0, lg.stem_cols, lg.stem_rows, r00, h00, unused0, unused1);
  sw_fetch(lg.stem_file, x1, y0, lg.stem_cols, lg.stem_rows, r10, h10, unused0, unused1);
  sw_fetch(lg.stem_file, x0, y1, lg.stem_cols, lg.stem_rows, r01, h01, unused0, unused1);
  sw_fetch(lg.stem_file, x1, y1, lg.stem_cols, lg.stem_rows, r11, h11, unused0, unused1);
  outer = mix(mix(r00, r10, ax), mix(r01, r11, ax), ay);
  heart = mix(mix(h00, h10, ax), mix(h01, h11, ax), ay);
}

// Integer i of a table of one integer a texel (R), SW_TRACK_ROW texels to a row.
int sw_int_at(string file, int i, int rows) {
  int row = i / SW_TRACK_ROW;
  float a = 0.0;
  float unused0 = 0.0;
  float unused1 = 0.0;
  float unused2 = 0.0;
  sw_fetch(file, i - row * SW_TRACK_ROW, row, SW_TRACK_ROW, rows, a, unused0, unused1, unused2);
  return int(a);
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

// What the field says at a point besides t: what the colouring needs (wood_log_data.glsl's
// WoodSample), and how many knots were visited (the work a point costs).
struct SwSample {
  float t_stem;      // r / R; > 1 outside the wood
  float r;           // pith distance, mm
  float heartwood;   // heartwood radius there, mm (0: none)
  int knot;          // the knot whose wood this is, -1: none
  int dead;          // 1: in that knot's dead part
  float knot_rate;   // that knot's time per mm across its axis (t_c / rho)
  float near_depth;  // nearest knot (r <= r_end): distance from its axis / its radius
  float near_rho;    // that knot's radius here, mm
  float dead_depth;  // nearest dead knot: distance from its axis / its radius (SW_FAR: none)
  float dead_rho;
  float dead_beta;  // angle around that knot's axis
  SW_UINT dead_seed;
  int visits;  // knots visited
};

// Knot i's share at p (wood_visit_knot): adds to the running sums and to the sample.
void sw_visit_knot(SwLog lg, int i, float px, float py, float pz, float r, float t_s, float R,
                   float reach, SW_OUT(float) t_min, SW_OUT(float) delta_sum,
                   SW_OUT(float) best_depth, SW_OUT(SwSample) s) {
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
  s.visits = s.visits + 1;
  sw_fetch(lg.knot_file, 0, i, 3, lg.knot_count, r_dead, r_end, d_dead, d_exp);
  sw_fetch(lg.knot_file, 1, i, 3, lg.knot_count, half_dmax, offset_f, count_f, seed_lo);
  sw_fetch(lg.knot_file, 2, i, 3, lg.knot_count, seed_hi, unused0, unused1, unused2);
  int track_offset = int(offset_f);
  int track_count = int(count_f);
  SW_UINT seed = SW_TO_UINT(int(seed_lo)) + SW_TO_UINT(int(seed_hi)) * 65536;
  float jf = r / lg.track_step;
  if (jf >= float(track_count - 1)) return;
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
  if (abs(pz - az) > reach) return;
  float ax = x0 + (x1 - x0) * a;
  float ay = y0 + (y1 - y0) * a;
  float axis_omega = w0 + (w1 - w0) * a;
  float vx = px - ax;
  float vy = py - ay;
  float vz = pz - az;
  float dist = sqrt(vx * vx + vy * vy + vz * vz);
  float fade_range = sw_range_fade(dist, r, lg.r_ref);
  if (fade_range <= 0.0) return;
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
    int is_dead = t_since_death > 0.0;
    if (dist < rho && depth < best_depth) {
      best_depth = depth;
      s.knot = i;
      s.dead = is_dead;
      s.knot_rate = t_c / max(rho, 1e-3);
    }
    if (depth < s.near_depth) {
      s.near_depth = depth;
      s.near_rho = rho;
    }
    if (is_dead && depth < s.dead_depth) {
      s.dead_depth = depth;
      s.dead_rho = rho;
      s.dead_beta = beta;
      s.dead_seed = seed;
    }
  }
}

// The merged time field t at p (scanner frame, mm) and the sample (wood_sample in
// wood_log_data.glsl). `use_index` 1: the knots of p's cell of the knot index (when the log has
// one); 0: every knot. Both give the same field: a knot left out of a cell cannot reach it.
float sw_wood_sample(SwLog lg, float px, float py, float pz, int use_index, SW_OUT(SwSample) s) {
  float cx = 0.0;
  float cy = 0.0;
  sw_pith_at(lg, pz, cx, cy);
  float dx = px - cx;
  float dy = py - cy;
  float r = sqrt(dx * dx + dy * dy);
  float w = atan2(dy, dx);
  if (w < 0.0) w += SW_TWO_PI;
  if (w >= SW_TWO_PI) w -= SW_TWO_PI;
  float R = 0.0;
  float H = 0.0;
  sw_stem_radii(lg, w, pz, R, H);
  float t_s = r / R;
  s.t_stem = t_s;
  s.r = r;
  s.heartwood = H;
  s.knot = -1;
  s.dead = 0;
  s.knot_rate = 0.0;
  s.near_depth = SW_FAR;
  s.near_rho = 0.0;
  s.dead_depth = SW_FAR;
  s.dead_rho = 0.0;
  s.dead_beta = 0.0;
  s.dead_seed = SW_TO_UINT(0);
  s.visits = 0;
  float t_min = SW_FAR;
  float delta_sum = 0.0;
  float best_depth = SW_FAR;
  float reach = sw_range_outer(r, lg.r_ref);
  if (use_index != 0 && lg.cell_nz > 0) {
    int zc = clamp(int(floor((pz - lg.cell_z0) / lg.cell_dz)), 0, lg.cell_nz - 1);
    int rc = min(int(r / lg.cell_dr), lg.cell_nr - 1);
    int sc = min(int(w / SW_TWO_PI * float(lg.cell_ns)), lg.cell_ns - 1);
    int cell = (zc * lg.cell_nr + rc) * lg.cell_ns + sc;
    int list_begin = sw_int_at(lg.cell_start_file, cell, lg.cell_start_rows);
    int list_end = sw_int_at(lg.cell_start_file, cell + 1, lg.cell_start_rows);
    for (int n = list_begin; n < list_end; n += 1) {
      int i = sw_int_at(lg.cell_knot_file, n, lg.cell_knot_rows);
      sw_visit_knot(lg, i, px, py, pz, r, t_s, R, reach, t_min, delta_sum, best_depth, s);
    }
  } else {
    for (int i = 0; i < lg.knot_count; i += 1)
      sw_visit_knot(lg, i, px, py, pz, r, t_s, R, reach, t_min, delta_sum, best_depth, s);
  }
  return sw_union(t_s, t_min, delta_sum);
}

// The field at p through the knot index: t, and t_stem, the knot whose wood p is in (-1: none)
// and whether p lies in its dead part.
float sw_wood_field(SwLog lg, float px, float py, float pz, SW_OUT(float) t_stem, SW_OUT(int) knot,
                    SW_OUT(int) dead) {
  SwSample s;
  float t = sw_wood_sample(lg, px, py, pz, 1, s);
  t_stem = s.t_stem;
  knot = s.knot;
  dead = s.dead;
  return t;
}

// ---- the colour (wood.frag's wood_shade, without light and bark) ------------------------------

// The species look and the shading options the renderer gives wood.frag (WoodLook,
// ShadeOptions; display RGB 0-1).
struct SwLook {
  float knot_sound_r;
  float knot_sound_g;
  float knot_sound_b;
  float knot_dead_r;
  float knot_dead_g;
  float knot_dead_b;
  float bark_ring_r;
  float bark_ring_g;
  float bark_ring_b;
  float heart_tint_r;
  float heart_tint_g;
  float heart_tint_b;
  float knot_rings;      // exponent on the strip's ring contrast inside knots
  float strip_luma;      // the colour strip's mean luminance
  int heartwood_tint;    // 1: tint the heartwood (the species shows it and the log has it)
  float knot_darkening;  // 1
  float dead_outline;    // 1
};

float sw_luma(float r, float g, float b) { return 0.299 * r + 0.587 * g + 0.114 * b; }

// The colour of the wood at a sample whose colour strip (pith to bark) gives (ring_r, ring_g,
// ring_b) at its time t: heartwood tinted, knots in the look's own colour with their own rings,
// a sound knot's darker rim, a dead knot's ring of encased bark.
void sw_wood_color(SwLook lk, SwSample s, float ring_r, float ring_g, float ring_b,
                   SW_OUT(float) out_r, SW_OUT(float) out_g, SW_OUT(float) out_b) {
  float cr = ring_r;
  float cg = ring_g;
  float cb = ring_b;
  if (lk.heartwood_tint != 0 && s.heartwood > 0.0) {
    float hw = 1.0 - smoothstep(s.heartwood - 1.5, s.heartwood + 1.5, s.r);
    cr = mix(cr, cr * lk.heart_tint_r, hw);
    cg = mix(cg, cg * lk.heart_tint_g, hw);
    cb = mix(cb, cb * lk.heart_tint_b, hw);
  }
  float rings = pow(clamp(sw_luma(ring_r, ring_g, ring_b) / max(lk.strip_luma, 1e-3), 0.3, 1.05),
                    lk.knot_rings);
  int near_dead = s.dead_depth < 1.5;
  float width = 0.0;
  if (near_dead != 0) {
    float b01 = s.dead_beta / SW_TWO_PI + 0.5;
    width =
        0.10 * (1.0 + 0.7 * sw_noise(b01 * 5.0, s.r / 6.0, 5, s.dead_seed + 7)) * lk.dead_outline;
  }
  int dead_colour = (s.knot >= 0 && s.dead != 0) || (s.knot < 0 && near_dead != 0);
  float kr = dead_colour != 0 ? lk.knot_dead_r : lk.knot_sound_r;
  float kg = dead_colour != 0 ? lk.knot_dead_g : lk.knot_sound_g;
  float kb = dead_colour != 0 ? lk.knot_dead_b : lk.knot_sound_b;
  float knot_weight = near_dead != 0 ? 1.0 - smoothstep(0.985, 1.0, s.dead_depth)
                                     : 1.0 - smoothstep(0.92, 1.02, s.near_depth);
  float kw = lk.knot_darkening * knot_weight;
  cr = mix(cr, kr * rings, kw);
  cg = mix(cg, kg * rings, kw);
  cb = mix(cb, kb * rings, kw);
  if (near_dead == 0 && s.near_rho > 0.0) {
    float rim = smoothstep(0.84, 0.95, s.near_depth) * (1.0 - smoothstep(0.99, 1.02, s.near_depth));
    float dim = 1.0 - 0.2 * lk.knot_darkening * rim;
    cr = cr * dim;
    cg = cg * dim;
    cb = cb * dim;
  }
  if (near_dead != 0 && width > 0.0) {
    float inner = smoothstep(1.0 - width - 0.03, 1.0 - width, s.dead_depth);
    float outer = 1.0 - smoothstep(1.0, 1.02, s.dead_depth);
    float bw = lk.knot_darkening * inner * outer;
    cr = mix(cr, lk.bark_ring_r, bw);
    cg = mix(cg, lk.bark_ring_g, bw);
    cb = mix(cb, lk.bark_ring_b, bw);
  }
  out_r = max(cr, 0.0);
  out_g = max(cg, 0.0);
  out_b = max(cb, 0.0);
}

#include "sawyer/render/wood_renderer.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <vector>

#include "gl.h"
#include "gpu_log_data.h"
#include "sawyer/render/image.h"
#include "sawyer/render/shader_program.h"

namespace sawyer::render {
namespace fs = std::filesystem;

namespace {

constexpr const char* kColorStrip = "wood_bar_color.bmp";
constexpr const char* kNormalStrip = "wood_bar_normal.bmp";
constexpr const char* kSpecularStrip = "wood_bar_specular.bmp";

// One strip (pith → bark) as RGBA8: the middle row of the image.
struct Strip {
  int width = 0;
  std::vector<std::uint8_t> rgba;
};

Result<Strip> load_strip(const fs::path& path) {
  Result<Image> img = read_image(path);
  if (!img) return img.error();
  const Image& im = img.value();
  Strip s;
  s.width = im.width;
  const int y = im.height / 2;
  s.rgba.assign(im.u8.begin() + static_cast<std::ptrdiff_t>(y) * im.width * 4,
                im.u8.begin() + static_cast<std::ptrdiff_t>(y + 1) * im.width * 4);
  return s;
}

// A plain strip when no colour maps are at hand: pale earlywood, darker latewood, 40 rings.
Strip builtin_strip(int which) {
  Strip s;
  s.width = 1024;
  s.rgba.resize(4 * s.width);
  for (int i = 0; i < s.width; ++i) {
    const double t = (i + 0.5) / s.width;
    const double phase = std::fmod(t * 40.0, 1.0);
    const double late = phase > 0.6 ? std::min(1.0, (phase - 0.6) / 0.3) : 0.0;
    double rgb[3];
    if (which == 0) {
      rgb[0] = 0.93 - 0.25 * late;
      rgb[1] = 0.80 - 0.25 * late;
      rgb[2] = 0.62 - 0.22 * late;
    } else if (which == 1) {
      rgb[0] = 0.5 + 0.15 * (late > 0 && late < 1 ? 1.0 : 0.0);
      rgb[1] = 0.5;
      rgb[2] = 1.0;
    } else {
      rgb[0] = rgb[1] = rgb[2] = 0.3 + 0.4 * late;
    }
    for (int c = 0; c < 3; ++c) s.rgba[4 * i + c] = static_cast<std::uint8_t>(rgb[c] * 255.0 + 0.5);
    s.rgba[4 * i + 3] = 255;
  }
  return s;
}

fs::path default_color_maps() {
  if (const char* env = std::getenv("SAWYER_COLOR_MAPS")) return env;
  return SAWYER_RENDER_DATA_DIR;
}

// The number of annual rings in a colour strip (its dark latewood bands: local luminance minima
// at least 12/255 below the brightest pixel within ±15 px) and its mean luminance, 0-1.
using StripStats = ColorStripStats;

StripStats strip_stats(const Strip& s) {
  std::vector<double> l(s.width);
  double sum = 0;
  for (int i = 0; i < s.width; ++i) {
    const std::uint8_t* p = &s.rgba[4 * static_cast<size_t>(i)];
    l[i] = (0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2]) / 255.0;
    sum += l[i];
  }
  int minima = 0;
  for (int i = 3; i + 3 < s.width; ++i) {
    double lo = l[i], hi = l[i];
    for (int j = i - 3; j <= i + 3; ++j) lo = std::min(lo, l[j]);
    for (int j = std::max(0, i - 15); j < std::min(s.width, i + 15); ++j) hi = std::max(hi, l[j]);
    if (l[i] == lo && hi - l[i] > 12.0 / 255.0 && (i == 3 || l[i - 1] != l[i])) ++minima;
  }
  StripStats st;
  st.rings = static_cast<float>(std::max(minima, 10));
  st.luma = static_cast<float>(sum / std::max(s.width, 1));
  return st;
}

// Strip `which` (0 colour, 1 normal, 2 specular) of RenderOptions::color_maps, else of the
// bundled folder, else the built-in one.
Result<Strip> strip_of(const RenderOptions& options, int which) {
  const bool given = !options.color_maps.empty();
  const fs::path dir = given ? options.color_maps : default_color_maps();
  const char* names[3] = {kColorStrip, kNormalStrip, kSpecularStrip};
  std::error_code ec;
  const bool have_dir = fs::is_directory(dir, ec);
  if (given && !have_dir)
    return Error(dir.string(), "no such folder (expected the wood colour strips)");
  if (!have_dir) return builtin_strip(which);
  return load_strip(dir / names[which]);
}

struct Vertex {
  float p[3];
  float n[3];
};

void push_quad(std::vector<Vertex>& v, const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
               const Vec3& n) {
  auto mk = [&](const Vec3& p) {
    return Vertex{{static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)},
                  {static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z)}};
  };
  v.push_back(mk(a));
  v.push_back(mk(b));
  v.push_back(mk(c));
  v.push_back(mk(a));
  v.push_back(mk(c));
  v.push_back(mk(d));
}

void push_rect(std::vector<Vertex>& v, const PlaneRect& r) {
  push_quad(v, r.at(0, 0), r.at(1, 0), r.at(1, 1), r.at(0, 1), r.normal());
}

}  // namespace

WoodLook wood_look(const std::string& species, bool* known) {
  std::string sp;
  for (char c : species) sp += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  WoodLook l;
  if (known) *known = sp == "spruce" || sp == "pine";
  if (sp == "pine") {
    // Scots pine: reddish-brown heartwood (darker and redder than the sapwood once exposed),
    // resinous red-brown knots, thick grey-brown plated bark with reddish inner bark.
    l.name = "pine";
    l.knot_sound = {0.66f, 0.40f, 0.24f};
    l.knot_dead = {0.46f, 0.31f, 0.21f};
    l.bark_ring = {0.15f, 0.10f, 0.07f};
    l.heart_tint = {0.91f, 0.82f, 0.72f};
    l.bark_inner = {0.58f, 0.38f, 0.27f};
    l.bark_outer = {0.42f, 0.33f, 0.27f};
    l.knot_rings = 3.5f;
    l.heartwood_visible = true;
    l.bark_default_mm = 10;
    return l;
  }
  // Norway spruce: no heartwood colour; yellow- to reddish-brown sound knots a shade darker
  // than clear wood, darker grey-brown dead knots, thin scaly reddish-grey bark.
  l.name = "spruce";
  l.knot_sound = {0.66f, 0.47f, 0.33f};
  l.knot_dead = {0.49f, 0.38f, 0.29f};
  l.bark_ring = {0.17f, 0.12f, 0.09f};
  l.heart_tint = {1.0f, 1.0f, 1.0f};
  l.bark_inner = {0.62f, 0.40f, 0.28f};
  l.bark_outer = {0.46f, 0.35f, 0.29f};
  l.knot_rings = 3.5f;
  l.heartwood_visible = false;
  l.bark_default_mm = 6;
  return l;
}

Result<ColorStripStats> color_strip_stats(const RenderOptions& options) {
  Result<Strip> s = strip_of(options, 0);
  if (!s) return s.error();
  return strip_stats(s.value());
}

Status RenderOptions::validate() const {
  if (!(field.knot_noise >= 0 && field.knot_noise <= 0.5))
    return Error("knot noise", "must be in [0, 0.5]");
  if (!(index_dz_mm >= 1 && index_dz_mm <= 1000))
    return Error("index_dz_mm", "must be in [1, 1000]");
  if (!(index_dr_mm >= 1 && index_dr_mm <= 1000))
    return Error("index_dr_mm", "must be in [1, 1000]");
  if (index_sectors < 1 || index_sectors > 360)
    return Error("index_sectors", "must be in [1, 360]");
  bool known = true;
  if (!species.empty()) wood_look(species, &known);
  if (!known)
    return Error("RenderOptions::species", "'" + species + "' is not a known look: spruce or pine");
  return Status::Ok();
}

struct WoodRenderer::Impl {
  const LogModel* log = nullptr;
  RenderOptions options;
  std::unique_ptr<WoodField> field;
  GpuLogData data;       // its arrays emptied once uploaded (release_uploaded_arrays)
  int pith_count = 0;    // data.pith.size() / 2 before that
  KnotIndexStats stats;  // of the knot index, taken before that
  void release_uploaded_arrays();
  // The wood program, and the same compiled without the extra samples (WOOD_ONE_SAMPLE) for
  // draws that take one sample a pixel: the viewer's moving frames, --supersample 1, the raw
  // field. llvmpipe runs the smaller program faster even where the samples' branch is not taken.
  ShaderProgram program, program_one;
  GLuint current = 0;  // the one set_uniforms chose
  GLuint ssbo[6] = {};
  WoodLook look;
  StripStats strip;
  std::vector<float> bark;  // bark thickness at the stem samples (empty: the model has none)
  GLuint stem_tex = 0, strip_tex[3] = {};
  float stem_scale = 1;  // the stem texture's radii are fractions of this (mm)
  GLuint vao = 0, vbo = 0, surface_vbo = 0;
  GLsizei surface_count = 0;

  ~Impl() {
    glDeleteBuffers(6, ssbo);
    glDeleteTextures(1, &stem_tex);
    glDeleteTextures(3, strip_tex);
    glDeleteBuffers(1, &vbo);
    glDeleteBuffers(1, &surface_vbo);
    glDeleteVertexArrays(1, &vao);
  }

  template <typename T>
  void upload_ssbo(int binding, const std::vector<T>& v) {
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, ssbo[binding]);
    glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(v.size() * sizeof(T)), v.data(),
                 GL_STATIC_DRAW);
  }

  void build_surface(bool with_bark);
  // Bark thickness at height z, as the shader reads it (wood_bark_at).
  double bark_at(double z) const {
    if (bark.empty()) return look.bark_default_mm;
    const double u =
        std::clamp((z - data.stem_z0) / log->stem.dz_mm, 0.0, static_cast<double>(bark.size() - 1));
    const size_t i = std::min(static_cast<size_t>(u), bark.size() > 1 ? bark.size() - 2 : 0);
    if (bark.size() == 1) return bark[0];
    return bark[i] + (bark[i + 1] - bark[i]) * (u - static_cast<double>(i));
  }
  bool surface_bark = false;
  void set_uniforms(const Camera& cam, const Viewport& vp, const ShadeOptions& s);
  void draw_vertices(const std::vector<Vertex>& v, float surface_tol);
};

void WoodRenderer::Impl::build_surface(bool with_bark) {
  surface_bark = with_bark;
  glDeleteBuffers(1, &surface_vbo);
  surface_vbo = 0;
  const Stem& st = log->stem;
  const int na = st.n_angles;
  std::vector<double> zs;
  zs.push_back(st.z_begin());
  for (int i = 0; i < st.slice_count(); ++i) zs.push_back(st.z_at(i));
  zs.push_back(st.z_end());
  auto point = [&](int row, int k) {
    const double z = zs[row];
    const Vec2 c = st.pith_at(z);
    const double w = kTwoPi * k / na;
    const double R = st.radius_at(w, z) + (with_bark ? bark_at(z) : 0.0);
    return Vec3{c.x + R * std::cos(w), c.y + R * std::sin(w), z};
  };
  const int rows = static_cast<int>(zs.size());
  std::vector<Vec3> grid(static_cast<size_t>(rows) * na);
  for (int row = 0; row < rows; ++row)
    for (int k = 0; k < na; ++k) grid[static_cast<size_t>(row) * na + k] = point(row, k);
  auto at = [&](int row, int k) -> const Vec3& {
    row = std::clamp(row, 0, rows - 1);
    k = ((k % na) + na) % na;
    return grid[static_cast<size_t>(row) * na + k];
  };
  auto normal = [&](int row, int k) {
    const Vec3 dw = at(row, k + 1) - at(row, k - 1);
    const Vec3 dz = at(row + 1, k) - at(row - 1, k);
    return cross(dw, dz).normalized();
  };
  std::vector<Vertex> v;
  v.reserve(static_cast<size_t>(rows) * na * 6);
  auto mk = [&](int row, int k) {
    const Vec3 p = at(row, k), n = normal(row, k);
    return Vertex{{static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)},
                  {static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z)}};
  };
  for (int row = 0; row + 1 < rows; ++row)
    for (int k = 0; k < na; ++k) {
      const Vertex a = mk(row, k), b = mk(row, k + 1), c = mk(row + 1, k + 1), d = mk(row + 1, k);
      v.insert(v.end(), {a, b, c, a, c, d});
    }
  glGenBuffers(1, &surface_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, surface_vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(v.size() * sizeof(Vertex)), v.data(),
               GL_STATIC_DRAW);
  surface_count = static_cast<GLsizei>(v.size());
}

void WoodRenderer::Impl::set_uniforms(const Camera& cam, const Viewport& vp,
                                      const ShadeOptions& s) {
  const bool one = s.supersample <= 1 || s.mode == ShadeMode::kTimeField;
  const GLuint p = one ? program_one.id() : program.id();
  current = p;
  glUseProgram(p);
  auto loc = [&](const char* n) { return glGetUniformLocation(p, n); };
  const Mat4 vpm = cam.view_projection(vp.aspect());
  glUniformMatrix4fv(loc("u_view_proj"), 1, GL_FALSE, vpm.m.data());
  const GpuLogData& d = data;
  glUniform1f(loc("u_pith_z0"), d.pith_z0);
  glUniform1f(loc("u_pith_step"), d.pith_step);
  glUniform1i(loc("u_pith_count"), static_cast<GLint>(pith_count));
  glUniform1f(loc("u_stem_z0"), d.stem_z0);
  glUniform1f(loc("u_stem_step"), d.stem_step);
  glUniform1f(loc("u_stem_rows"), static_cast<float>(d.stem_rows));
  glUniform1f(loc("u_stem_scale"), stem_scale);
  glUniform1f(loc("u_r_ref"), d.r_ref);
  glUniform1f(loc("u_knot_noise"), d.knot_noise);
  glUniform1f(loc("u_track_step"), d.track_step);
  glUniform1i(loc("u_knot_count"), static_cast<GLint>(log->knots.size()));
  glUniform1f(loc("u_cell_z0"), d.index.z0);
  glUniform1f(loc("u_cell_dz"), d.index.dz);
  glUniform1i(loc("u_cell_nz"), d.index.nz);
  glUniform1f(loc("u_cell_dr"), d.index.dr);
  glUniform1i(loc("u_cell_nr"), d.index.nr);
  glUniform1i(loc("u_cell_ns"), d.index.ns);
  glUniform1i(loc("u_mode"), s.mode == ShadeMode::kTimeField ? 1 : 0);
  glUniform1f(loc("u_z_begin"), d.z_begin);
  glUniform1f(loc("u_z_end"), d.z_end);
  const Vec3 eye = cam.eye(), fwd = cam.forward();
  glUniform3f(loc("u_eye"), static_cast<float>(eye.x), static_cast<float>(eye.y),
              static_cast<float>(eye.z));
  glUniform3f(loc("u_view_dir"), static_cast<float>(fwd.x), static_cast<float>(fwd.y),
              static_cast<float>(fwd.z));
  glUniform1i(loc("u_ortho"), cam.projection_type == Camera::Projection::kOrthographic ? 1 : 0);
  Vec3 right, up, back;
  cam.axes(&right, &up, &back);
  const Vec3 ld = s.light_dir.normalized();
  const Vec3 l = (ld.x * right + ld.y * up + ld.z * back).normalized();
  glUniform3f(loc("u_light_dir"), static_cast<float>(l.x), static_cast<float>(l.y),
              static_cast<float>(l.z));
  glUniform1f(loc("u_ambient"), s.ambient);
  glUniform1f(loc("u_diffuse"), s.diffuse);
  glUniform1f(loc("u_specular"), s.specular);
  glUniform1i(loc("u_lighting"), s.lighting ? 1 : 0);
  glUniform1f(loc("u_knot_darkening"), s.knot_darkening);
  glUniform1f(loc("u_dead_outline"), s.dead_outline);
  glUniform1i(loc("u_heartwood_tint"),
              s.heartwood_tint && d.has_heartwood && look.heartwood_visible ? 1 : 0);
  glUniform1i(loc("u_supersample"), std::clamp(s.supersample, 1, 4));
  glUniform1i(loc("u_outline_samples"), 1);
  glUniform1f(loc("u_strip_rings"), strip.rings);
  glUniform1f(loc("u_strip_luma"), strip.luma);
  auto rgb = [&](const char* n, const std::array<float, 3>& c) {
    glUniform3f(loc(n), c[0], c[1], c[2]);
  };
  rgb("u_knot_sound", look.knot_sound);
  rgb("u_knot_dead", look.knot_dead);
  rgb("u_bark_ring", look.bark_ring);
  rgb("u_heart_tint", look.heart_tint);
  rgb("u_bark_inner", look.bark_inner);
  rgb("u_bark_outer", look.bark_outer);
  glUniform1f(loc("u_knot_rings"), look.knot_rings);
  const bool bark_on = s.bark && s.mode == ShadeMode::kWood;
  glUniform1i(loc("u_bark_count"), bark_on ? static_cast<GLint>(bark.size()) : 0);
  glUniform1f(loc("u_bark_step"), static_cast<float>(log->stem.dz_mm));
  glUniform1f(loc("u_bark_default"),
              bark_on && bark.empty() ? static_cast<float>(look.bark_default_mm) : 0.0f);
  for (int b = 0; b < 6; ++b) glBindBufferBase(GL_SHADER_STORAGE_BUFFER, b, ssbo[b]);
  // Pixels that take several samples write their coverage of the wood to alpha (wood.frag).
  if (s.mode == ShadeMode::kWood && s.supersample > 1) {
    glEnable(GL_BLEND);
    glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  } else {
    glDisable(GL_BLEND);
  }
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, stem_tex);
  for (int i = 0; i < 3; ++i) {
    glActiveTexture(GL_TEXTURE1 + i);
    glBindTexture(GL_TEXTURE_2D, strip_tex[i]);
  }
  glActiveTexture(GL_TEXTURE0);
  glViewport(vp.x, vp.y, vp.width, vp.height);
  glBindVertexArray(vao);
}

void WoodRenderer::Impl::draw_vertices(const std::vector<Vertex>& v, float surface_tol) {
  if (v.empty()) return;
  glUniform1f(glGetUniformLocation(current, "u_surface_tol"), surface_tol);
  glBindBuffer(GL_ARRAY_BUFFER, vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(v.size() * sizeof(Vertex)), v.data(),
               GL_STREAM_DRAW);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex), nullptr);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex),
                        reinterpret_cast<const void*>(3 * sizeof(float)));
  glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(v.size()));
}

WoodRenderer::WoodRenderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
WoodRenderer::~WoodRenderer() = default;

Result<std::unique_ptr<WoodRenderer>> WoodRenderer::create(const LogModel& log,
                                                           const RenderOptions& options) {
  if (Status st = options.validate(); !st) return st.error();
  if (log.stem.slice_count() < 1) return Error("log model", "the stem has no slices");
  auto impl = std::make_unique<Impl>();
  impl->log = &log;
  impl->options = options;

  // Colour strips first: a missing file is the likeliest user error.
  Strip strips[3];
  for (int i = 0; i < 3; ++i) {
    Result<Strip> s = strip_of(options, i);
    if (!s) return s.error();
    strips[i] = std::move(s).value();
  }

  std::vector<std::string> defines;
  if (options.knot_index) defines.push_back("WOOD_INDEX 1");
  Result<ShaderProgram> prog = ShaderProgram::build("wood.vert", "wood.frag", defines);
  if (!prog) return prog.error();
  impl->program = std::move(prog).value();
  defines.push_back("WOOD_ONE_SAMPLE 1");
  Result<ShaderProgram> one = ShaderProgram::build("wood.vert", "wood.frag", defines);
  if (!one) return one.error();
  impl->program_one = std::move(one).value();

  impl->field = std::make_unique<WoodField>(log, options.field);
  GpuLayoutOptions lo;
  lo.index_dz_mm = options.index_dz_mm;
  lo.index_dr_mm = options.index_dr_mm;
  lo.index_sectors = options.index_sectors;
  lo.stem_table = false;  // uploaded below in blocks of rows
  impl->data = build_gpu_log_data(*impl->field, lo);
  GpuLogData& d = impl->data;

  impl->look = wood_look(options.species.empty() ? log.species : options.species);
  impl->strip = strip_stats(strips[0]);
  for (double b : log.stem.bark_mm) impl->bark.push_back(static_cast<float>(b));
  glGenBuffers(6, impl->ssbo);
  impl->upload_ssbo(0, d.pith);
  impl->upload_ssbo(1, d.tracks);
  impl->upload_ssbo(2, d.knots);
  impl->upload_ssbo(3, d.cell_start);
  impl->upload_ssbo(4, d.cell_knots);
  // An empty buffer cannot be bound: one zero when the model has no bark (u_bark_count is 0).
  impl->upload_ssbo(5, impl->bark.empty() ? std::vector<float>{0.0f} : impl->bark);

  glGenTextures(1, &impl->stem_tex);
  glBindTexture(GL_TEXTURE_2D, impl->stem_tex);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  // The radii as 16-bit fractions of stem_scale (GL_RG16, half the memory of RG32F: the texture
  // grows with the log's length, 2.3 MB a metre at a 4 mm stem step; issue 24). stem_scale is
  // well above any radius the bicubic surface reaches between its samples, and its steps
  // (stem_scale / 65535, ~3 µm for a 130 mm radius) are far below a pixel of any view.
  {
    double most = 1.0;
    for (const std::vector<double>& row : log.stem.radius)
      for (double v : row) most = std::max(most, v);
    for (const std::vector<double>& row : log.stem.heartwood)
      for (double v : row) most = std::max(most, v);
    impl->stem_scale = static_cast<float>(1.5 * most);
  }
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RG16, d.stem_cols, d.stem_rows, 0, GL_RG, GL_UNSIGNED_SHORT,
               nullptr);
  {
    constexpr int kRowsPerBlock = 64;
    std::vector<float> block(static_cast<size_t>(kRowsPerBlock) * d.stem_cols * 2);
    std::vector<std::uint16_t> texels(block.size());
    const float to_unit = 65535.0f / impl->stem_scale;
    for (int row0 = 0; row0 < d.stem_rows; row0 += kRowsPerBlock) {
      const int rows = std::min(kRowsPerBlock, d.stem_rows - row0);
      d.max_radius = std::max(d.max_radius, fill_stem_rows(log.stem, d, row0, rows, block.data()));
      const size_t count = static_cast<size_t>(rows) * d.stem_cols * 2;
      for (size_t i = 0; i < count; ++i)
        texels[i] =
            static_cast<std::uint16_t>(std::lround(std::clamp(block[i] * to_unit, 0.0f, 65535.0f)));
      glTexSubImage2D(GL_TEXTURE_2D, 0, 0, row0, d.stem_cols, rows, GL_RG, GL_UNSIGNED_SHORT,
                      texels.data());
    }
  }
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);

  glGenTextures(3, impl->strip_tex);
  for (int i = 0; i < 3; ++i) {
    glBindTexture(GL_TEXTURE_2D, impl->strip_tex[i]);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, strips[i].width, 1, 0, GL_RGBA, GL_UNSIGNED_BYTE,
                 strips[i].rgba.data());
    glGenerateMipmap(GL_TEXTURE_2D);  // rings finer than a pixel blend (wood.frag)
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  }
  glBindTexture(GL_TEXTURE_2D, 0);

  glGenVertexArrays(1, &impl->vao);
  glBindVertexArray(impl->vao);
  glGenBuffers(1, &impl->vbo);
  glBindBuffer(GL_ARRAY_BUFFER, impl->vbo);
  glEnableVertexAttribArray(0);
  glEnableVertexAttribArray(1);
  glBindVertexArray(0);
  if (glGetError() != GL_NO_ERROR) return Error("OpenGL", "uploading the log's data failed");
  impl->release_uploaded_arrays();
  return std::unique_ptr<WoodRenderer>(new WoodRenderer(std::move(impl)));
}

void WoodRenderer::draw(const Scene& scene, const Camera& camera, const Viewport& viewport,
                        const ShadeOptions& shade) {
  Impl& m = *impl_;
  m.set_uniforms(camera, viewport, shade);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);
  // Boards: closed boxes are drawn without their far sides.
  std::vector<Vertex> v;
  for (const BoardBox& b : scene.boards)
    for (unsigned bit = 1; bit <= 32; bit <<= 1)
      if (scene.board_faces & bit) push_rect(v, board_face(b, static_cast<Face>(bit)));
  const bool cull_boards = scene.cull_hidden && (scene.board_faces & kAllFaces) == kAllFaces;
  if (cull_boards) glEnable(GL_CULL_FACE);
  glCullFace(GL_BACK);
  glFrontFace(GL_CCW);
  m.draw_vertices(v, 5e-4f);
  glDisable(GL_CULL_FACE);
  v.clear();
  const double R = m.data.max_radius * 1.02;
  for (double z : scene.cross_sections) {
    const Vec2 c = m.log->stem.pith_at(z);
    PlaneRect r;
    r.origin = {c.x - R, c.y - R, z};
    r.u = {1, 0, 0};
    r.v = {0, 1, 0};
    r.width = r.height = 2 * R;
    push_rect(v, r);
  }
  for (const LongitudinalSection& s : scene.longitudinal_sections) {
    const double len = m.data.z_end - m.data.z_begin;
    const Vec3 dir{std::cos(s.angle), std::sin(s.angle), 0},
        nrm{-std::sin(s.angle), std::cos(s.angle), 0};
    PlaneRect r;
    const Vec2 c = m.data.mean_pith;
    r.origin = Vec3{c.x, c.y, m.data.z_begin} + s.offset * nrm - R * dir;
    r.u = {0, 0, 1};
    r.v = dir;
    r.width = len;
    r.height = 2 * R;
    push_rect(v, r);
  }
  for (const PlaneRect& p : scene.planes) push_rect(v, p);
  m.draw_vertices(v, 5e-4f);
  if (scene.log_surface) {
    const bool with_bark = shade.bark && shade.mode == ShadeMode::kWood;
    if (!m.surface_vbo || m.surface_bark != with_bark) {
      m.build_surface(with_bark);
      glBindVertexArray(m.vao);
    }
    glUniform1f(glGetUniformLocation(m.current, "u_surface_tol"), 0.03f);
    glUniform1i(glGetUniformLocation(m.current, "u_outline_samples"), 0);
    glUniform1f(glGetUniformLocation(m.current, "u_z_begin"),
                static_cast<float>(std::max<double>(m.data.z_begin, scene.surface_z0)));
    glUniform1f(glGetUniformLocation(m.current, "u_z_end"),
                static_cast<float>(std::min<double>(m.data.z_end, scene.surface_z1)));
    glBindBuffer(GL_ARRAY_BUFFER, m.surface_vbo);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex), nullptr);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex),
                          reinterpret_cast<const void*>(3 * sizeof(float)));
    // Pull the surface slightly back so sections and boards drawn on it win the depth test.
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1.0f, 1.0f);
    if (scene.cull_hidden) glEnable(GL_CULL_FACE);
    glDrawArrays(GL_TRIANGLES, 0, m.surface_count);
    glDisable(GL_CULL_FACE);
    glDisable(GL_POLYGON_OFFSET_FILL);
  }
  glDisable(GL_BLEND);
  glBindVertexArray(0);
}

void WoodRenderer::draw_plane(const PlaneRect& rect, const Viewport& viewport,
                              const ShadeOptions& shade) {
  Impl& m = *impl_;
  m.set_uniforms(Camera::plane_view(rect), viewport, shade);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  // One triangle twice the rect's size, clipped by the viewport to exactly the rect.
  std::vector<Vertex> v;
  const Vec3 n = rect.normal();
  for (const Vec3& p : {rect.at(0, 0), rect.at(2, 0), rect.at(0, 2)})
    v.push_back(
        Vertex{{static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)},
               {static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z)}});
  m.draw_vertices(v, 5e-4f);
  glDisable(GL_BLEND);
  glBindVertexArray(0);
}

const LogModel& WoodRenderer::log() const { return *impl_->log; }
const RenderOptions& WoodRenderer::options() const { return impl_->options; }

// The GL buffers and textures hold the log's data once uploaded: the CPU copies go (megabytes
// for a log with a few hundred knots), keeping the scalars the uniforms and queries read.
void WoodRenderer::Impl::release_uploaded_arrays() {
  const GpuLogData& d = data;
  pith_count = static_cast<int>(d.pith.size() / 2);
  KnotIndexStats& s = stats;
  s.cells = d.index.cells();
  s.entries = static_cast<long long>(d.cell_start.back());
  s.mean_per_cell = s.cells ? static_cast<double>(s.entries) / s.cells : 0;
  for (int c = 0; c < s.cells; ++c)
    s.max_per_cell = std::max(s.max_per_cell, d.cell_start[c + 1] - d.cell_start[c]);
  s.gpu_bytes = d.bytes(4);  // the stem texture in RG16
  data.pith = {};
  data.stem = {};
  data.knots = {};
  data.tracks = {};
  data.cell_start = {};
  data.cell_knots = {};
}

KnotIndexStats WoodRenderer::index_stats() const { return impl_->stats; }

Vec3 WoodRenderer::pith_point(double z) const {
  const Vec2 c = impl_->data.mean_pith;
  return {c.x, c.y, z};
}

double WoodRenderer::max_radius() const { return impl_->data.max_radius; }

const WoodLook& WoodRenderer::look() const { return impl_->look; }

}  // namespace sawyer::render

// Runs the reference paper's published fragment shader (Larsson et al. 2022,
// github.com/marialarsson/procedural_knots, setup/main.vert and main.frag), unchanged, on one
// face of a board of a log given by its published maps, headless (EGL, OpenGL compatibility
// profile, as the published program's PyOpenGL window gives it), and writes the image and the
// time per frame. The shader files are not part of Sawyer: pass a checkout's setup/ folder.
// Used by bench/render_gallery.sh for the side-by-side crops in docs/render.md.
//
//   published_shader SETUP_DIR MAPS_DIR COLOR_MAPS_DIR x,y,w,t,rot,z0,z1 WIDTHxHEIGHT OUT.png
//                    [frames]
//
// The board is in the maps' frame (mm, x and y from the origin the pith offsets are measured
// from, z from the butt), as `sawyer render --scanner-frame` takes it for a log converted from
// the same maps; the image is its top face (+thickness side), z from left to right, +width at
// the top, one sample per pixel (the published program's). The published program's own view,
// light and viewer positions are kept; the view matrix here only maps the face onto the image.
#define GL_GLEXT_PROTOTYPES 1
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/gl.h>
#include <GL/glext.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {

struct Rgb8 {
  int w = 0, h = 0;
  std::vector<unsigned char> px;  // rows from the file's top, 3 channels
};

bool read_text(const std::string& path, std::string* out) {
  std::ifstream f(path);
  if (!f) return false;
  std::stringstream s;
  s << f.rdbuf();
  *out = s.str();
  return true;
}

bool read_rgb(const std::string& path, Rgb8* im) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) return false;
  const OIIO::ImageSpec& s = in->spec();
  std::vector<unsigned char> all(static_cast<size_t>(s.width) * s.height * s.nchannels);
  if (!in->read_image(0, 0, 0, s.nchannels, OIIO::TypeDesc::UINT8, all.data())) return false;
  im->w = s.width;
  im->h = s.height;
  im->px.resize(static_cast<size_t>(s.width) * s.height * 3);
  for (size_t i = 0; i < static_cast<size_t>(s.width) * s.height; ++i)
    for (int c = 0; c < 3; ++c)
      im->px[i * 3 + c] = all[i * s.nchannels + std::min(c, s.nchannels - 1)];
  return true;
}

GLuint compile(GLenum type, const std::string& file, const std::string& src) {
  GLuint s = glCreateShader(type);
  const char* c = src.c_str();
  glShaderSource(s, 1, &c, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    std::fprintf(stderr, "%s: does not compile: %s\n", file.c_str(), log);
    std::exit(1);
  }
  return s;
}

// A texture as the published program loads it: the file's top row first, no mipmaps.
void load_texture(int unit, const std::string& path, bool nearest, bool repeat_x) {
  Rgb8 im;
  if (!read_rgb(path, &im)) {
    std::fprintf(stderr, "%s: cannot read the image\n", path.c_str());
    std::exit(1);
  }
  GLuint t = 0;
  glActiveTexture(GL_TEXTURE0 + unit);
  glGenTextures(1, &t);
  glBindTexture(GL_TEXTURE_2D, t);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB, im.w, im.h, 0, GL_RGB, GL_UNSIGNED_BYTE, im.px.data());
  const GLint f = nearest ? GL_NEAREST : GL_LINEAR;
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, f);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, f);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, repeat_x ? GL_REPEAT : GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
}

int usage() {
  std::fprintf(stderr,
               "usage: published_shader SETUP_DIR MAPS_DIR COLOR_MAPS_DIR x,y,w,t,rot,z0,z1 "
               "WIDTHxHEIGHT OUT.png [frames]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 7) return usage();
  const std::string setup = argv[1], maps = argv[2], colors = argv[3], out = argv[6];
  double cx, cy, bw, bt, rot_deg, z0, z1;
  int W = 0, H = 0;
  if (std::sscanf(argv[4], "%lf,%lf,%lf,%lf,%lf,%lf,%lf", &cx, &cy, &bw, &bt, &rot_deg, &z0, &z1) !=
          7 ||
      std::sscanf(argv[5], "%dx%d", &W, &H) != 2 || W < 1 || H < 1 || W > 8192 || H > 8192 ||
      !(z1 > z0) || !(bw > 0))
    return usage();
  const int frames = argc > 7 ? std::max(1, std::atoi(argv[7])) : 1;

  std::string vs, fs, params;
  if (!read_text(setup + "/main.vert", &vs) || !read_text(setup + "/main.frag", &fs)) {
    std::fprintf(stderr, "%s: no main.vert / main.frag (a checkout's setup/ folder)\n",
                 setup.c_str());
    return 1;
  }
  float rmin = 0, rmax = 0, hmax = 0;
  int n_knots = 0;
  if (!read_text(maps + "/map_params.json", &params) ||
      std::sscanf(params.c_str(), " [%f , %f , %f , %d", &rmin, &rmax, &hmax, &n_knots) != 4) {
    std::fprintf(stderr, "%s/map_params.json: not [rmin, rmax, hmax, knots]\n", maps.c_str());
    return 1;
  }

  auto platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  EGLDisplay d = platform_display
                     ? platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr)
                     : eglGetDisplay(EGL_DEFAULT_DISPLAY);
  if (d == EGL_NO_DISPLAY || !eglInitialize(d, nullptr, nullptr) || !eglBindAPI(EGL_OPENGL_API)) {
    std::fprintf(stderr, "no EGL display\n");
    return 1;
  }
  const EGLint cfg_attr[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                             EGL_NONE};
  EGLConfig cfg = nullptr;
  EGLint n_cfg = 0;
  eglChooseConfig(d, cfg_attr, &cfg, 1, &n_cfg);
  const EGLint ctx_attr[] = {EGL_CONTEXT_MAJOR_VERSION,
                             3,
                             EGL_CONTEXT_MINOR_VERSION,
                             3,
                             EGL_CONTEXT_OPENGL_PROFILE_MASK,
                             EGL_CONTEXT_OPENGL_COMPATIBILITY_PROFILE_BIT,
                             EGL_NONE};
  EGLContext ctx = eglCreateContext(d, n_cfg ? cfg : EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, ctx_attr);
  if (ctx == EGL_NO_CONTEXT || !eglMakeCurrent(d, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) {
    std::fprintf(stderr, "no OpenGL 3.3 compatibility context\n");
    return 1;
  }
  std::printf("context: %s, %s\n", glGetString(GL_VERSION), glGetString(GL_RENDERER));

  GLuint prog = glCreateProgram();
  glAttachShader(prog, compile(GL_VERTEX_SHADER, setup + "/main.vert", vs));
  glAttachShader(prog, compile(GL_FRAGMENT_SHADER, setup + "/main.frag", fs));
  glLinkProgram(prog);
  GLint linked = 0;
  glGetProgramiv(prog, GL_LINK_STATUS, &linked);
  if (!linked) {
    std::fprintf(stderr, "%s: the shaders do not link\n", setup.c_str());
    return 1;
  }
  glUseProgram(prog);
  // Texture units and filters as the published main.py sets them.
  load_texture(0, colors + "/wood_bar_color.bmp", false, false);
  load_texture(1, colors + "/wood_bar_specular.bmp", false, false);
  load_texture(2, colors + "/wood_bar_normal.bmp", false, false);
  load_texture(3, maps + "/pith_and_radius_map.bmp", false, true);
  load_texture(4, maps + "/knot_height_map.bmp", false, false);
  load_texture(5, maps + "/knot_orientation_map.bmp", false, false);
  load_texture(6, maps + "/knot_state_map.bmp", true, false);
  const char* samplers[] = {"ColorMap",      "SpecularMap",   "NormalMap",   "PithRadiusMap",
                            "KnotHeightMap", "KnotOrientMap", "KnotStateMap"};
  for (int i = 0; i < 7; ++i) glUniform1i(glGetUniformLocation(prog, samplers[i]), i);
  glUniform1f(glGetUniformLocation(prog, "rmin"), rmin);
  glUniform1f(glGetUniformLocation(prog, "rmax"), rmax);
  glUniform1f(glGetUniformLocation(prog, "hmax"), hmax);
  glUniform1i(glGetUniformLocation(prog, "N"), n_knots);
  glUniform1f(glGetUniformLocation(prog, "time"), 0.0f);  // the animation stopped at its start
  glUniform3f(glGetUniformLocation(prog, "viewPos"), -1.5f, 2.0f, -1.0f);
  glUniform3f(glGetUniformLocation(prog, "lightPos"), std::cos(5.2f), std::sin(5.2f), 1.2f);

  // The face in the shader's model units: mm / rmin, y less the 0.18 the shader adds back.
  const double rot = rot_deg * M_PI / 180, ax = std::cos(rot), ay = std::sin(rot);
  const double nx = -ay, ny = ax;  // the thickness direction
  const double fx = cx + 0.5 * bt * nx, fy = cy + 0.5 * bt * ny;
  struct Vertex {
    float p[3], n[3];
  };
  auto vertex = [&](double s, double z) {
    return Vertex{{static_cast<float>((fx + s * ax) / rmin),
                   static_cast<float>((fy + s * ay) / rmin - 0.18), static_cast<float>(z / rmin)},
                  {static_cast<float>(nx), static_cast<float>(ny), 0.0f}};
  };
  const Vertex a = vertex(0.5 * bw, z0), b = vertex(0.5 * bw, z1), c = vertex(-0.5 * bw, z1),
               e = vertex(-0.5 * bw, z0);
  const Vertex tri[6] = {a, b, c, a, c, e};
  // view (column-major): model point -> clip; x along z, y along the width, depth 0.
  const double sz = 2 / ((z1 - z0) / rmin), sw = 2 / (bw / rmin);
  const double ox = fx / rmin, oy = fy / rmin - 0.18, oz = 0.5 * (z0 + z1) / rmin;
  float view[16] = {0};
  view[8] = static_cast<float>(sz);
  view[12] = static_cast<float>(-sz * oz);
  view[1] = static_cast<float>(sw * ax);
  view[5] = static_cast<float>(sw * ay);
  view[13] = static_cast<float>(-sw * (ax * ox + ay * oy));
  view[15] = 1;
  const float model[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  glUniformMatrix4fv(glGetUniformLocation(prog, "view"), 1, GL_FALSE, view);
  glUniformMatrix4fv(glGetUniformLocation(prog, "model"), 1, GL_FALSE, model);

  GLuint vao = 0, vbo = 0, fbo = 0, rb = 0;
  glGenVertexArrays(1, &vao);
  glBindVertexArray(vao);
  glGenBuffers(1, &vbo);
  glBindBuffer(GL_ARRAY_BUFFER, vbo);
  glBufferData(GL_ARRAY_BUFFER, sizeof tri, tri, GL_STATIC_DRAW);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex), nullptr);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex),
                        reinterpret_cast<void*>(offsetof(Vertex, n)));
  glEnableVertexAttribArray(1);
  glGenFramebuffers(1, &fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glGenRenderbuffers(1, &rb);
  glBindRenderbuffer(GL_RENDERBUFFER, rb);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, W, H);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, rb);
  glViewport(0, 0, W, H);
  glClearColor(1, 1, 1, 1);

  std::vector<double> times;
  for (int f = 0; f < frames; ++f) {
    const auto t0 = std::chrono::steady_clock::now();
    glClear(GL_COLOR_BUFFER_BIT);
    glDrawArrays(GL_TRIANGLES, 0, 6);
    glFinish();
    times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(times.begin(), times.end());
  std::printf("published shader, %d x %d, one sample per pixel: median %.3f s of %d frames\n", W, H,
              times[times.size() / 2], frames);

  std::vector<unsigned char> rgba(static_cast<size_t>(W) * H * 4),
      rgb(static_cast<size_t>(W) * H * 3);
  glReadPixels(0, 0, W, H, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      for (int ch = 0; ch < 3; ++ch)
        rgb[(static_cast<size_t>(y) * W + x) * 3 + ch] =
            rgba[(static_cast<size_t>(H - 1 - y) * W + x) * 4 + ch];
  auto o = OIIO::ImageOutput::create(out);
  if (!o || !o->open(out, OIIO::ImageSpec(W, H, 3, OIIO::TypeDesc::UINT8)) ||
      !o->write_image(OIIO::TypeDesc::UINT8, rgb.data()) || !o->close()) {
    std::fprintf(stderr, "%s: cannot write the image\n", out.c_str());
    return 1;
  }
  return 0;
}

// Speed of the knotted-wood renderer, headless (EGL; Mesa's llvmpipe on a machine with no GPU):
// a 1200 x 1200 image of a board face over the whole 4 m spruce log (108 knots) with the knot
// index against the straightforward port of the published per-pixel loop (every knot visited per
// pixel), the same face on a 0.5 m stretch and on a 0.5 m log cut out of it, and a typical viewer
// frame. Medians of several frames, each ended with glFinish. Optionally writes the docs gallery.
//
//   LP_NUM_THREADS=2 build-rd/bench/render_bench [--frames 5] [--gallery docs/images]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <functional>
#include <iostream>
#include <string>
#include <vector>

#include "sawyer/core/stats.h"
#include "sawyer/model/log_generator.h"
#include "sawyer/model/log_json.h"
#include "sawyer/render/gl_context.h"
#include "sawyer/render/views.h"
#include "sawyer/render/wood_renderer.h"

using namespace sawyer;
using namespace sawyer::render;
namespace fs = std::filesystem;

namespace {

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// CPU time of the whole process (every llvmpipe thread), s.
double cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

struct Timing {
  double wall = 0;  // median wall time per frame, s
  double cpu = 0;   // median CPU time per frame over all threads, s (not inflated by other
                    // programs on a shared machine: wall ≈ cpu / cores when alone)
};

// Times `frames` runs of `draw` (after one warm-up), each ended by glFinish.
Timing time_frames(int frames, const std::function<void()>& draw) {
  draw();
  finish_rendering();
  std::vector<double> wall, cpu;
  for (int i = 0; i < frames; ++i) {
    const double t0 = now_s(), c0 = cpu_s();
    draw();
    finish_rendering();
    wall.push_back(now_s() - t0);
    cpu.push_back(cpu_s() - c0);
  }
  return {median(wall), median(cpu)};
}

// The log between z0 and z1 as a log of its own (stem samples and the knots starting there).
LogModel crop(const LogModel& log, double z0, double z1) {
  LogModel out = log;
  out.id = log.id + "_crop";
  out.stem.pith.clear();
  out.stem.radius.clear();
  out.stem.heartwood.clear();
  out.stem.bark_mm.clear();
  bool first = true;
  for (int i = 0; i < log.stem.slice_count(); ++i) {
    const double z = log.stem.z_at(i);
    if (z < z0 || z > z1) continue;
    if (first) out.stem.z0_mm = z;
    first = false;
    out.stem.pith.push_back(log.stem.pith[i]);
    out.stem.radius.push_back(log.stem.radius[i]);
    if (log.stem.has_heartwood()) out.stem.heartwood.push_back(log.stem.heartwood[i]);
    if (!log.stem.bark_mm.empty()) out.stem.bark_mm.push_back(log.stem.bark_mm[i]);
  }
  out.knots.clear();
  for (const Knot& k : log.knots)
    if (k.z0 >= z0 - 150 && k.z0 <= z1 + 150) out.knots.push_back(k);
  return out;
}

// The machine's load average (1 min), for reading the timings on a shared machine; -1 if unknown.
double load_average() {
  std::FILE* f = std::fopen("/proc/loadavg", "r");
  if (!f) return -1;
  double l = -1;
  if (std::fscanf(f, "%lf", &l) != 1) l = -1;
  std::fclose(f);
  return l;
}

int fail(const std::string& m) {
  std::cerr << "render_bench: " << m << "\n";
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  std::string log_path = std::string(SAWYER_SOURCE_DIR) + "/sample_logs/gran1_spruce/log.json";
  std::string gallery;
  int frames = 5, size = 1200;
  RenderOptions indexed_opts, all_opts;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--frames" && i + 1 < argc)
      frames = std::max(1, std::atoi(argv[++i]));
    else if (a == "--size" && i + 1 < argc)
      size = std::max(16, std::atoi(argv[++i]));
    else if (a == "--log" && i + 1 < argc)
      log_path = argv[++i];
    else if (a == "--gallery" && i + 1 < argc)
      gallery = argv[++i];
    else if (a == "--index" && i + 3 < argc) {  // cell height, pith distance (mm), sectors
      indexed_opts.index_dz_mm = std::atof(argv[++i]);
      indexed_opts.index_dr_mm = std::atof(argv[++i]);
      indexed_opts.index_sectors = std::atoi(argv[++i]);
    } else {
      std::cout << "usage: render_bench [--frames N] [--size PX] [--log log.json] [--gallery DIR] "
                   "[--index DZ_MM DR_MM SECTORS]\n";
      return a == "--help" || a == "-h" ? 0 : 1;
    }
  }
  Result<LogModel> loaded = read_log_json(log_path);
  if (!loaded) return fail(loaded.error().message());
  const LogModel& log = loaded.value();
  auto ctx = create_headless_context();
  if (!ctx) return fail(ctx.error().message());
  const char* lp = std::getenv("LP_NUM_THREADS");
  std::cout << "context: " << ctx.value()->description()
            << "; LP_NUM_THREADS=" << (lp ? lp : "(unset)") << "; load average " << load_average()
            << "\n";

  all_opts.knot_index = false;
  auto indexed = WoodRenderer::create(log, indexed_opts);
  auto every = WoodRenderer::create(log, all_opts);
  if (!indexed) return fail(indexed.error().message());
  if (!every) return fail(every.error().message());
  const KnotIndexStats st = indexed.value()->index_stats();
  std::printf(
      "log %s: %.2f m, %zu knots; knot index %d cells, %.1f knots per cell (max %d), "
      "GPU data %.1f MB\n",
      log.id.c_str(), log.stem.length_mm() / 1000, log.knots.size(), st.cells, st.mean_per_cell,
      st.max_per_cell, st.gpu_bytes / 1e6);

  // A 180 mm x 40 mm board 15 mm above the pith over the whole log: its top face fills the image.
  const Vec3 c = indexed.value()->pith_point(0);
  BoardBox full;
  full.cx = c.x;
  full.cy = c.y + 15;
  full.width = 180;
  full.thickness = 40;
  full.z0 = log.stem.z_begin();
  full.z1 = log.stem.z_end();
  BoardBox part = full;
  part.z0 = 1750;
  part.z1 = 2250;
  const LogModel short_log = crop(log, part.z0 - 5, part.z1 + 5);
  RenderOptions so = indexed_opts;
  auto short_indexed = WoodRenderer::create(short_log, so);
  auto short_every = WoodRenderer::create(short_log, all_opts);
  if (!short_indexed || !short_every) return fail("cannot set up the short log");

  auto fb = Framebuffer::create(size, size, Framebuffer::Format::kRgba8);
  if (!fb) return fail(fb.error().message());
  const float bg[4] = {0, 0, 0, 1};
  auto face_frame = [&](WoodRenderer& r, const BoardBox& b) {
    return [&r, &fb, b, &bg]() {
      fb.value().bind(bg);
      r.draw_plane(board_face(b, Face::kTop), fb.value().viewport());
    };
  };
  struct Row {
    std::string what;
    size_t knots;
    Timing indexed, every;
  };
  std::vector<Row> rows;
  rows.push_back({"board face, whole 4 m log", log.knots.size(),
                  time_frames(frames, face_frame(*indexed.value(), full)),
                  time_frames(std::max(1, frames / 2), face_frame(*every.value(), full))});
  rows.push_back({"board face, 0.5 m of the 4 m log", log.knots.size(),
                  time_frames(frames, face_frame(*indexed.value(), part)),
                  time_frames(std::max(1, frames / 2), face_frame(*every.value(), part))});
  rows.push_back({"board face, a 0.5 m log (cut out)", short_log.knots.size(),
                  time_frames(frames, face_frame(*short_indexed.value(), part)),
                  time_frames(std::max(1, frames / 2), face_frame(*short_every.value(), part))});

  std::printf("\n%d x %d image, median of %d frames (all-knots loop: %d), glFinish each:\n", size,
              size, frames, std::max(1, frames / 2));
  std::printf(
      "| image | knots in log | knot index: wall (CPU) | every knot per pixel: wall (CPU) | "
      "speed-up: wall (CPU) |\n");
  std::printf("|---|---:|---:|---:|---:|\n");
  for (const Row& r : rows)
    std::printf("| %s | %zu | %.3f s (%.3f s) | %.3f s (%.3f s) | %.1fx (%.1fx) |\n",
                r.what.c_str(), r.knots, r.indexed.wall, r.indexed.cpu, r.every.wall, r.every.cpu,
                r.every.wall / r.indexed.wall, r.every.cpu / r.indexed.cpu);
  std::printf(
      "(CPU: all llvmpipe threads together; with %s threads and the cores to itself, "
      "wall time is about CPU / threads)\n",
      lp ? lp : "N");

  // The report's quality: the same whole-log face as a finished image (framebuffer, shading,
  // read-back), with 2 x 2 samples taken everywhere (before issue 23) and only where the field
  // changes within a pixel (the default now).
  struct QualityRow {
    std::string what;
    Timing t;
  };
  std::vector<QualityRow> quality;
  auto image_frame = [&](int n, bool adaptive) {
    return [&, n, adaptive]() {
      FaceLayout layout;
      layout.supersample = n;
      layout.adaptive = adaptive;
      layout.stretch = true;  // the face fills the square image, as in the rows above
      Result<Image> img = render_board_faces(
          *indexed.value(), full, static_cast<unsigned>(Face::kTop), {size, size}, {}, layout);
      if (!img) std::cerr << img.error().message() << "\n";
    };
  };
  quality.push_back({"1 sample per pixel", time_frames(frames, image_frame(1, true))});
  quality.push_back({"2 x 2 samples where the wood changes within a pixel (default)",
                     time_frames(frames, image_frame(2, true))});
  quality.push_back(
      {"2 x 2 samples in every pixel (before)", time_frames(frames, image_frame(2, false))});
  quality.push_back(
      {"3 x 3 samples where the wood changes", time_frames(frames, image_frame(3, true))});
  std::printf(
      "\n%d x %d board face image of the whole log (render_board_faces: shading, read-back, "
      "averaging), median of %d:\n",
      size, size, frames);
  std::printf("| samples | wall | CPU |\n|---|---:|---:|\n");
  for (const QualityRow& q : quality)
    std::printf("| %s | %.3f s | %.3f s |\n", q.what.c_str(), q.t.wall, q.t.cpu);

  // A typical viewer frame: the log's surface up to where three boards are sawn out of its top
  // end, the butt end and that cut as cross-sections.
  Scene scene;
  scene.log_surface = true;
  scene.surface_z1 = 2600;
  scene.cross_sections = {log.stem.z_begin() + 0.01, 2600 - 0.01};
  for (int i = -1; i <= 1; ++i) {
    BoardBox b = full;
    b.cy = c.y + i * 46.0;
    b.z0 = 2600;
    b.z1 = 4000;
    b.width = 150;
    scene.boards.push_back(b);
  }
  // Close enough that wood fills most of the frame: the cut, the boards and 2 m of the log.
  Camera cam = Camera::orbit(indexed.value()->pith_point(2600), 1400, -0.6, 0.4);
  cam.near_mm = 20;
  cam.far_mm = 10000;
  auto vfb = Framebuffer::create(1280, 720, Framebuffer::Format::kRgba8);
  if (!vfb) return fail(vfb.error().message());
  const float vbg[4] = {0.12f, 0.12f, 0.13f, 1};
  const Timing view = time_frames(frames, [&]() {
    vfb.value().bind(vbg);
    indexed.value()->draw(scene, cam, vfb.value().viewport());
  });
  const Timing view_every = time_frames(std::max(1, frames / 2), [&]() {
    vfb.value().bind(vbg);
    every.value()->draw(scene, cam, vfb.value().viewport());
  });
  std::printf(
      "\nviewer frame 1280 x 720 (log surface, 3 boards sawn out of its top end): "
      "%.3f s = %.1f fps, CPU %.3f s (every knot per pixel: %.3f s = %.1f fps, CPU %.3f s)\n",
      view.wall, 1.0 / view.wall, view.cpu, view_every.wall, 1.0 / view_every.wall, view_every.cpu);

  std::printf("load average at the end: %.2f\n", load_average());

  if (!gallery.empty()) {
    fs::create_directories(gallery);
    auto save = [&](const std::string& name, Result<Image> img) {
      if (!img) {
        std::cerr << name << ": " << img.error().message() << "\n";
        return;
      }
      Status s = write_image(fs::path(gallery) / name, img.value());
      if (!s)
        std::cerr << s.error().message() << "\n";
      else
        std::cout << "wrote " << (fs::path(gallery) / name).string() << "\n";
    };
    // The viewer frame as timed (one sample per pixel), at half size for the docs.
    save("viewer_frame_gran1.png", render_view(*indexed.value(), scene, cam, {640, 360}));
  }
  return 0;
}

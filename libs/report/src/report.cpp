// write_report: renders the figures with one headless context and one WoodRenderer, draws the
// plots, then writes the documents into a temporary folder that replaces the report folder.
#include "sawyer/report/report.h"

#include <chrono>
#include <fstream>

#include "documents.h"
#include "figures.h"
#include "sawyer/core/file_util.h"
#include "sawyer/render/gl_context.h"

namespace sawyer::report {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

Status write_bytes(const fs::path& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  f.close();
  if (!f) return Error(path.string(), "cannot write");
  return Status::Ok();
}

// Times the steps and reports progress.
class Steps {
 public:
  Steps(int total, const ReportProgress& progress, ReportFiles* files)
      : total_(total), progress_(progress), files_(files) {}
  void begin(const std::string& name) {
    end();
    name_ = name;
    t0_ = Clock::now();
    if (progress_) progress_(done_, total_, name);
  }
  void end() {
    if (name_.empty()) return;
    files_->steps.push_back({name_, std::chrono::duration<double>(Clock::now() - t0_).count()});
    name_.clear();
    ++done_;
  }
  void finish() {
    end();
    if (progress_) progress_(total_, total_, "done");
  }

 private:
  int total_, done_ = 0;
  const ReportProgress& progress_;
  ReportFiles* files_;
  std::string name_;
  Clock::time_point t0_;
};

// The height of the end view: the top end of the boards (the small end, where wane shows),
// 5 mm inside the cut.
double end_view_height(const RunFolder& run) {
  double z = -1e300;
  for (const BoardRecord& b : run.sawing.boards) z = std::max(z, b.z_end_mm - 5.0);
  if (z < -1e299) z = run.log.stem.z_end() - 50.0;
  return z;
}

}  // namespace

Status ReportOptions::validate() const {
  for (int v : {end_view_px, view_width_px, view_height_px, plot_width_px})
    if (v < 64 || v > 4096) return Error("report options", "image sizes must be 64..4096 px");
  if (!(board_px_per_cm >= 0.5 && board_px_per_cm <= 20))
    return Error("report options", "board resolution must be 0.5..20 px/cm");
  if (supersample < 1 || supersample > 4)
    return Error("report options", "supersample must be 1..4");
  return Status::Ok();
}

Result<ReportFiles> write_report(const RunFolder& run, const fs::path& report_dir,
                                 const ReportOptions& options, const ReportProgress& progress) {
  if (Status st = options.validate(); !st) return st.error();
  const auto t_all = Clock::now();
  ReportFiles files;
  Steps steps(8, progress, &files);
  Content c;
  c.run = &run;

  steps.begin("renderer");
  Result<std::unique_ptr<render::GlContext>> ctx = render::create_headless_context();
  if (!ctx) return ctx.error();
  render::RenderOptions ro;
  ro.color_maps = options.color_maps;
  auto renderer = render::WoodRenderer::create(run.log, ro);
  if (!renderer) return renderer.error();
  render::WoodRenderer& r = *renderer.value();

  steps.begin("boards");
  const sawing::SawLog saw_log(run.log);
  c.summary = summarize(run.log);
  c.boards = place_boards(run, saw_log);
  for (const BoardRecord& b : run.sawing.boards) {
    c.boards_volume_m3 += b.volume_m3;
    c.boards_value += b.value;
  }
  const SawingRecord& s = run.sawing;
  char buf[512];

  steps.begin("end view");
  c.end_view_z = end_view_height(run);
  Result<SurfacePtr> ev = end_view(r, run, saw_log, c.boards, c.end_view_z, options.end_view_px);
  if (!ev) return ev.error();
  std::snprintf(buf, sizeof buf,
                "The log as it lies on the saw at rotation %.1f° (x %+.1f mm, y %+.1f mm), "
                "cross-section %.2f m from the butt, seen from the top end. Boards outlined and "
                "numbered as in the table; every knot's axis projected along the log, green where "
                "sound, red where dead.",
                s.chosen.pos.rotation_deg, s.chosen.pos.offset_x_mm, s.chosen.pos.offset_y_mm,
                (c.end_view_z - run.log.stem.z_begin()) * 1e-3);
  c.figures.push_back({"end_view.png", "End view", buf, std::move(ev).value(), {}});

  steps.begin("3D view");
  Result<SurfacePtr> lv =
      log_view(r, saw_log, run, c.boards, options.view_width_px, options.view_height_px);
  if (!lv) return lv.error();
  c.figures.push_back({"log_view.png",
                       "The log and its boards",
                       "The log model rendered with its knotted wood: the outer surface over the "
                       "butt half, the boards at the chosen position running through the whole "
                       "length, and beyond the surface every knot drawn along its axis as wide "
                       "as it is (green sound, red dead).",
                       std::move(lv).value(),
                       {}});

  steps.begin("board faces");
  for (size_t i = 0; i < c.boards.boards.size(); ++i) {
    Result<SurfacePtr> bf = board_faces(r, saw_log, s.chosen.pos, c.boards.boards[i],
                                        options.board_px_per_cm, options.supersample);
    if (!bf) return bf.error();
    std::snprintf(buf, sizeof buf, "board_%02zu.png", i + 1);
    c.board_figures.push_back({buf, s.boards[i].name, s.boards[i].name, std::move(bf).value(), {}});
  }

  steps.begin("plots");
  if (SurfacePtr vm = value_map(s, options.plot_width_px)) {
    std::snprintf(buf, sizeof buf,
                  "Expected value of the boards (%s) for each rotation and x offset the optimiser "
                  "tried, averaged over the saw's positioning error. Circle: the best position; "
                  "triangle: horns-down (rotation 0, no offset)%s.",
                  s.currency.c_str(), s.chosen_given ? "; diamond: the given position" : "");
    c.figures.push_back({"value_map.png", "Value map", buf, std::move(vm), {}});
  }
  c.figures.push_back({"log_profile.png",
                       "Log profile",
                       "Top: the pith's track in the scanner frame. Bottom: the diameter under "
                       "bark along the log (equal-area diameter; band: smallest to largest "
                       "across angles).",
                       log_profile(run.log, c.boards, options.plot_width_px),
                       {}});

  steps.begin("png");
  for (auto* list : {&c.figures, &c.board_figures})
    for (Figure& f : *list) {
      Result<std::string> png = encode_png(f.surface.get());
      if (!png) return png.error().with_context(f.file);
      f.png = std::move(png).value();
    }

  steps.begin("documents");
  Status st = write_dir_atomic(report_dir, [&](const fs::path& tmp) -> Status {
    fs::create_directories(tmp / "images");
    files.images.clear();
    for (const auto* list : {&c.figures, &c.board_figures})
      for (const Figure& f : *list) {
        if (Status w = write_bytes(tmp / "images" / f.file, f.png); !w) return w;
        files.images.push_back(report_dir / "images" / f.file);
      }
    if (Status w = write_pdf(c, tmp / "report.pdf", &files.pages); !w) return w;
    if (Status w = write_bytes(tmp / "report.html", report_html(c)); !w) return w;
    if (Status w = write_bytes(tmp / "boards.csv", boards_csv(c)); !w) return w;
    return write_bytes(tmp / "report.json", report_json(c, files));
  });
  if (!st) return st.error();
  steps.finish();
  files.dir = report_dir;
  files.pdf = report_dir / "report.pdf";
  files.html = report_dir / "report.html";
  files.csv = report_dir / "boards.csv";
  files.json = report_dir / "report.json";
  files.seconds = std::chrono::duration<double>(Clock::now() - t_all).count();
  return files;
}

}  // namespace sawyer::report

// write_report: renders the figures with one headless context and one WoodRenderer, draws the
// plots, then writes the documents into a temporary folder that replaces the report folder.
#include "sawyer/report/report.h"

#include <chrono>
#include <cstdio>
#include <fstream>
#include <optional>

#include "documents.h"
#include "figures.h"
#include "sawyer/core/file_util.h"
#include "sawyer/core/process_memory.h"
#include "sawyer/render/gl_context.h"
#include "sawyer/sawing/grading.h"
#include "sawyer/sawing/setup.h"

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

// The rule set sawing.json's grades come from: the one run.json names, else the bundled set
// whose name sawing.json gives.
Result<sawing::GradingRules> grading_rules(const RunFolder& run) {
  std::vector<std::string> names;
  if (!run.run.grading.empty())
    names.push_back(run.run.grading);
  else
    names = {"nordic", "gost"};
  std::string why = "grading rules '" + run.sawing.grading + "' not found";
  for (const std::string& name : names) {
    Result<sawing::GradingRules> g = sawing::grading_by_name(name);
    if (!g) {
      why = g.error().message();
      continue;
    }
    if (g.value().name == run.sawing.grading) return g;
    why =
        "grading '" + name + "' is now '" + g.value().name + "', not '" + run.sawing.grading + "'";
  }
  return Error("limiting knots", why);
}

// The knots that decide a board's grade, when its knots are known and grading it again gives
// the grade sawing.json records.
BoardDetail board_detail(const RunFolder& run, const Result<sawing::GradingRules>& rules,
                         const sawing::Board& board, const BoardRecord& rec,
                         const BoardFaces& faces) {
  BoardDetail d;
  if (!rules) {
    d.note = rules.error().message();
    return d;
  }
  const sawing::GradingRules& g = rules.value();
  const sawing::BoardGrade grade = sawing::grade_board(board, g);
  if (g.grade_name(grade.grade) != rec.grade) {
    d.note = "graded again: " + g.grade_name(grade.grade) + ", not " + rec.grade +
             " as sawing.json says; no knots listed";
    return d;
  }
  d.knots = sawing::limiting_knots(board, g, grade.grade);
  if (grade.grade > 0) d.grade_above = g.grade_name(grade.grade - 1);
  for (const sawing::LimitingKnot& k : d.knots) {
    std::string text = sawing::describe(k, g);
    // From a scan: how sure the fit is that it is a knot at all (a streak or a pocket may be
    // taken for one; docs/knots.md "How sure a knot is").
    const int ki = board.knots[k.index].knot;
    if (run.log.qa && ki >= 0 && ki < static_cast<int>(run.log.knots.size())) {
      const double c = run.log.knots[static_cast<size_t>(ki)].confidence();
      d.confidences.push_back(c);
      char b[64];
      std::snprintf(b, sizeof b, "; %.0f %% sure it is a knot", 100 * c);
      text += b;
    }
    d.texts.push_back(std::move(text));
  }
  if (d.confidences.size() != d.knots.size()) d.confidences.clear();
  d.marks = limiting_marks(faces, run.log, board, d.knots, d.texts);
  if (d.knots.empty())
    d.note = grade.grade == 0 ? "the best grade"
                              : "limited by " + rec.limited_by + ", not by a knot's size";
  return d;
}

// The figures as PNG, for the documents and images/.
Status encode_figures(Content& c) {
  for (auto* list : {&c.figures, &c.board_figures})
    for (Figure& f : *list) {
      Result<std::string> png = encode_png(f.surface.get());
      if (!png) return png.error().with_context(f.file);
      f.png = std::move(png).value();
    }
  for (BoardDetail& d : c.details)
    for (Figure& f : d.crops) {
      Result<std::string> png = encode_png(f.surface.get());
      if (!png) return png.error().with_context(f.file);
      f.png = std::move(png).value();
    }
  return Status::Ok();
}

// The report folder, written whole: images/, report.pdf, report.html, boards.csv, report.json.
Status write_documents(const Content& c, const fs::path& report_dir, ReportFiles& files) {
  Status st = write_dir_atomic(report_dir, [&](const fs::path& tmp) -> Status {
    fs::create_directories(tmp / "images");
    files.images.clear();
    for (const auto* list : {&c.figures, &c.board_figures})
      for (const Figure& f : *list) {
        if (Status w = write_bytes(tmp / "images" / f.file, f.png); !w) return w;
        files.images.push_back(report_dir / "images" / f.file);
      }
    for (const BoardDetail& d : c.details) {
      if (Status w = write_bytes(tmp / "images" / d.strip_file, d.strip_jpeg); !w) return w;
      files.images.push_back(report_dir / "images" / d.strip_file);
      for (const Figure& f : d.crops) {
        if (Status w = write_bytes(tmp / "images" / f.file, f.png); !w) return w;
        files.images.push_back(report_dir / "images" / f.file);
      }
    }
    if (Status w = write_pdf(c, tmp / "report.pdf", &files.pages); !w) return w;
    if (Status w = write_bytes(tmp / "report.html", report_html(c)); !w) return w;
    if (Status w = write_bytes(tmp / "boards.csv", boards_csv(c)); !w) return w;
    return write_bytes(tmp / "report.json", report_json(c, files));
  });
  if (!st) return st;
  files.dir = report_dir;
  files.pdf = report_dir / "report.pdf";
  files.html = report_dir / "report.html";
  files.csv = report_dir / "boards.csv";
  files.json = report_dir / "report.json";
  return Status::Ok();
}

// Both reports end alike: the log's profile, the figures encoded, the documents written.
Result<ReportFiles> finish_report(Content& c, const RunFolder& run, const fs::path& report_dir,
                                  const ReportOptions& options, Steps& steps, ReportFiles& files,
                                  Clock::time_point t_all) {
  c.figures.push_back({"log_profile.png",
                       "Log profile",
                       "Top: the pith's track in the scanner frame. Bottom: the diameter under "
                       "bark along the log (equal-area diameter; band: smallest to largest "
                       "across angles).",
                       log_profile(run.log, c.boards, options.plot_width_px),
                       {}});
  steps.begin("png");
  if (Status e = encode_figures(c); !e) return e.error();
  steps.begin("documents");
  if (Status w = write_documents(c, report_dir, files); !w) return w.error();
  steps.finish();
  files.seconds = std::chrono::duration<double>(Clock::now() - t_all).count();
  return files;
}

// The report of a log that was scanned but not sawn (RunInfo::not_sawn): the log's figures, the
// scan's QA, why it was not sawn with the diameter the pattern needs against the log's usable
// one, the top end with both circles and the log's profile. No renderer: there are no boards
// to show, and the scan's own QA images are in scan/qa/.
Result<ReportFiles> write_not_sawn_report(const RunFolder& run, const fs::path& report_dir,
                                          const ReportOptions& options,
                                          const ReportProgress& progress) {
  const auto t_all = Clock::now();
  ReportFiles files;
  Steps steps(3, progress, &files);
  Content c;
  c.run = &run;
  c.summary = summarize(run.log);
  c.boards.note = "The log was not sawn: no boards";

  steps.begin("plots");
  const NotSawn& why = *run.run.not_sawn;
  // The pattern run.json names, to draw its boards; without it the circles say enough.
  // With a pattern set, its smallest candidate for the log, which run.json names.
  std::optional<sawing::Pattern> pattern;
  if (!run.run.pattern.empty()) {
    if (Result<sawing::Pattern> p = sawing::pattern_by_name(run.run.pattern); p)
      pattern = std::move(p).value();
  } else if (!run.run.pattern_set.empty() && !why.pattern.empty()) {
    if (Result<sawing::PatternSet> set = sawing::pattern_set_by_name(run.run.pattern_set); set)
      for (const sawing::Pattern* p : set.value().patterns())
        if (p->name == why.pattern) pattern = *p;
  }
  c.figures.push_back(
      {"top_end.png",
       "Top end",
       "The log's top end as scanned (under bark), seen from the top end, scanner x to the "
       "right and y up. Green: its usable diameter, the largest circle about the pith line "
       "inside it; red, dashed: the diameter the pattern needs" +
           std::string(pattern ? "; blue: the pattern's boards about the same centre (at one "
                                 "of its rotations)"
                               : "") +
           ".",
       top_end_fit(run.log, why, pattern ? &*pattern : nullptr, options.end_view_px),
       {}});
  return finish_report(c, run, report_dir, options, steps, files, t_all);
}

}  // namespace

Status ReportOptions::validate() const {
  for (int v : {end_view_px, view_width_px, view_height_px, plot_width_px})
    if (v < 64 || v > 4096) return Error("report options", "image sizes must be 64..4096 px");
  if (!(board_px_per_cm >= 0.5 && board_px_per_cm <= 20))
    return Error("report options", "board resolution must be 0.5..20 px/cm");
  if (!(board_detail_px_per_cm >= 0.5 && board_detail_px_per_cm <= 20))
    return Error("report options", "board detail resolution must be 0.5..20 px/cm");
  if (jpeg_quality < 1 || jpeg_quality > 100)
    return Error("report options", "JPEG quality must be 1..100");
  if (supersample < 1 || supersample > 4)
    return Error("report options", "supersample must be 1..4");
  return Status::Ok();
}

Result<ReportFiles> write_report(const RunFolder& run, const fs::path& report_dir,
                                 const ReportOptions& options, const ReportProgress& progress) {
  if (Status st = options.validate(); !st) return st.error();
  if (!run.sawn()) return write_not_sawn_report(run, report_dir, options, progress);
  const auto t_all = Clock::now();
  ReportFiles files;
  Steps steps(8, progress, &files);
  Content c;
  c.run = &run;
  // What the caller freed before (a run's scan) is given back before the renderer starts.
  release_free_memory();

  steps.begin("renderer");
  Result<std::unique_ptr<render::GlContext>> ctx = render::create_headless_context();
  if (!ctx) return ctx.error();
  render::RenderOptions ro;
  ro.color_maps = options.color_maps;
  auto renderer = render::WoodRenderer::create(run.log, ro);
  if (!renderer) return renderer.error();
  render::WoodRenderer& r = *renderer.value();

  steps.begin("boards");
  std::optional<sawing::SawLog> saw_log_storage(std::in_place, run.log);
  const sawing::SawLog& saw_log = *saw_log_storage;
  c.summary = summarize(run.log);
  c.boards = place_boards(run, saw_log);
  // The boards are cut: the figures below need the centre line and turn, not the sawing tables
  // (~21 KB a stem sample; issue 24).
  saw_log_storage->release_tables();
  for (const BoardRecord& b : run.sawing.boards) {
    c.boards_volume_m3 += b.volume_m3;
    c.boards_value += b.value;
  }
  const SawingRecord& s = run.sawing;
  char buf[512];
  // The rule set the grades were given by, to find the knots that decide them.
  Result<sawing::GradingRules> rules = grading_rules(run);
  if (!rules) c.grading_note = rules.error().message();

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
                       "The boards at the chosen position as solid blocks in their knotted "
                       "wood, inside the log drawn as a translucent shell over its bark, seen "
                       "from above the top end where they are cut; every knot a cone along its "
                       "axis as wide as it is (green where sound, red where dead).",
                       std::move(lv).value(),
                       {}});

  steps.begin("board faces");
  for (size_t i = 0; i < c.boards.boards.size(); ++i) {
    const sawing::Board& board = c.boards.boards[i];
    Result<BoardFaces> faces = render_faces(r, saw_log, s.chosen.pos, board,
                                            options.board_detail_px_per_cm, options.supersample);
    if (!faces) return faces.error();
    BoardDetail d = c.boards.rebuilt ? board_detail(run, rules, board, s.boards[i], faces.value())
                                     : BoardDetail{};
    if (!c.boards.rebuilt) d.note = "the boards' knots are not known (" + c.boards.note + ")";
    std::snprintf(buf, sizeof buf, "board_%02zu.png", i + 1);
    c.board_figures.push_back(
        {buf,
         s.boards[i].name,
         s.boards[i].name,
         compose_faces(faces.value(), options.board_px_per_cm, 1.0, d.marks, true),
         {}});
    // The detailed strip: text and lines in proportion, no rings (the HTML page draws them).
    d.detail_px_per_cm = faces.value().px_per_mm * 10.0;
    const SurfacePtr strip = compose_faces(faces.value(), d.detail_px_per_cm,
                                           d.detail_px_per_cm / 3.0, d.marks, false, &d.strip);
    // The faces as rendered are in the figure and the strip now: freed before the JPEG is
    // encoded (each as large as the board is long; issue 24).
    std::vector<BoardFaces::Row>().swap(faces.value().rows);
    std::snprintf(buf, sizeof buf, "board_%02zu_faces.jpg", i + 1);
    d.strip_file = buf;
    // The PDF's crops: the knots with the largest excess over their limit, at most four, each
    // with the board's four faces 10 cm either side of it.
    for (size_t m = 0; m < d.marks.size() && m < 4; ++m) {
      const double half = std::max(100.0, 2.5 * d.marks[m].width_mm);
      std::snprintf(buf, sizeof buf, "board_%02zu_knot_%d.png", i + 1, d.marks[m].knot_id);
      d.crops.push_back(
          {buf,
           "",
           d.marks[m].text,
           crop_around(strip.get(), d.strip, faces.value().px_per_mm, d.marks[m], half),
           {}});
    }
    // Encoded now and freed: the strips at the detail resolution are the largest images, and
    // holding every board's until the end was the report's peak.
    Result<std::string> jpg = encode_jpeg(strip.get(), options.jpeg_quality);
    if (!jpg) return jpg.error().with_context(d.strip_file);
    d.strip_jpeg = std::move(jpg).value();
    c.details.push_back(std::move(d));
  }
  // The renderer, its GL context (llvmpipe's copies of the buffers and its compiled shaders)
  // and the sawing model are not needed past the faces: freed before the plots and documents.
  renderer.value().reset();
  ctx.value().reset();
  saw_log_storage.reset();
  release_free_memory();

  steps.begin("plots");
  if (SurfacePtr vm = value_map(s, options.plot_width_px)) {
    std::snprintf(buf, sizeof buf,
                  "Expected value of the boards (%s) for each rotation and x offset the optimiser "
                  "tried, averaged over the saw's positioning error. Circle: the best position; "
                  "triangle: horns-down (rotation 0, no offset)%s.",
                  s.currency.c_str(), s.chosen_given ? "; diamond: the given position" : "");
    c.figures.push_back({"value_map.png", "Value map", buf, std::move(vm), {}});
  }

  return finish_report(c, run, report_dir, options, steps, files, t_all);
}

}  // namespace sawyer::report

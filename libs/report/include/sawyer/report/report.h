// The cutting report of a run folder (issue 8, docs/report.md): a PDF and a self-contained HTML
// page for the sawmill, boards.csv and report.json for machines, and the images as PNG.
//
//   Result<RunFolder> run = load_run_folder(out);                     // run_folder.h
//   Result<ReportFiles> files = write_report(run.value(), out / "report", {},
//       [](int done, int total, const std::string& step) { ... });   // progress, optional
//
// The folder is written atomically (write_dir_atomic): on failure nothing new is left under
// `report_dir` and an existing report stays as it was. Needs no display: the images are rendered
// by the knotted-wood renderer on a headless EGL context created here (llvmpipe when there is no
// GPU). Not thread safe: one report at a time per thread (OpenGL).
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/report/run_folder.h"

namespace sawyer::report {

struct ReportOptions {
  int end_view_px = 760;     // the cross-section with the boards, square
  int view_width_px = 1200;  // the 3D view of the log and boards (the cut view, cropped)
  int view_height_px = 600;
  double board_px_per_cm = 3.0;  // board figures (PNG, PDF), along and across (mm kept square)
  // The faces as rendered: the HTML page's zoomable faces (JPEG) and the PDF's crops around the
  // knots that decide the grades; the PNG and PDF figures are scaled down from them. Lowered for
  // a board so long that its image would pass the renderer's 8192 px.
  double board_detail_px_per_cm = 8.0;
  int jpeg_quality = 85;     // of the detailed faces (1..100)
  int plot_width_px = 1200;  // value map and log profile plots
  int supersample = 1;       // per pixel side, for the wood images (1..4)
  // Folder of the wood colour strips; empty: the renderer's default (docs/render.md).
  std::filesystem::path color_maps;

  // Image sizes within 64..4096 px, board resolutions 0.5..20 px/cm, JPEG quality 1..100,
  // supersample 1..4.
  Status validate() const;
};

struct ReportFiles {
  std::filesystem::path dir, pdf, html, csv, json;
  std::vector<std::filesystem::path> images;  // under dir/images
  int pages = 0;                              // of the PDF
  struct Step {
    std::string name;
    double seconds = 0;
  };
  std::vector<Step> steps;  // wall time per step, in order
  double seconds = 0;       // all of write_report
};

// (done, total, what is being done now); done == total at the end.
using ReportProgress = std::function<void(int done, int total, const std::string& step)>;

Result<ReportFiles> write_report(const RunFolder& run, const std::filesystem::path& report_dir,
                                 const ReportOptions& options = {},
                                 const ReportProgress& progress = {});

}  // namespace sawyer::report

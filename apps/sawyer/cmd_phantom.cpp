// `sawyer phantom`: parses the options into ct::PhantomOptions, builds the phantom, writes the
// slice folder with its truth/ and reports progress (stderr) and speed (stdout).
#include "cmd_phantom.h"
#include "cli_checks.h"
#include "cli_error.h"

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include "sawyer/core/output_guard.h"
#include "sawyer/ct/phantom/phantom.h"
#include "sawyer/maps/open_log.h"

namespace sawyer::app {

namespace {

struct PhantomCli {
  std::string input, output, format = "dicom";
  ct::PhantomOptions o;
  std::optional<double> from_mm, to_mm, rescale_intercept;
  bool no_bed = false;
  std::string moisture = "green";
};

int run(const PhantomCli& c) {
  Result<ct::Format> format = ct::parse_phantom_format(c.format);
  if (!format) return fail(format.error());
  ct::PhantomOptions o = c.o;
  o.from_mm = c.from_mm;
  o.to_mm = c.to_mm;
  o.bed = !c.no_bed;
  if (c.moisture == "green") {
    o.moisture = ct::Moisture::kGreen;
  } else if (c.moisture == "dried") {
    o.moisture = ct::Moisture::kDried;
  } else {
    return fail(Error("--moisture", "unknown state '" + c.moisture + "' (green, dried)"));
  }
  if (Status st = o.validate(); !st) return fail(st.error());

  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(c.input, ec)) return fail(Error(c.input, "no such file or folder"));
  Result<OutputLock> lock =
      OutputLock::acquire({c.output, OutputKind::kPhantomFolder, {c.input}, "-o"});
  if (!lock) return fail(lock.error());
  Result<LogModel> log = maps::open_log(c.input);
  if (!log) return fail(log.error());
  auto ph = ct::Phantom::create(log.value(), o);
  if (!ph) return fail(ph.error().with_context(c.input));
  const ct::Phantom& p = *ph.value();

  ct::PhantomWriteOptions wo;
  wo.format = format.value();
  wo.rescale_intercept = c.rescale_intercept;
  wo.input_name = c.input;
  const int total = static_cast<int>(p.kept().size());
  const auto t0 = std::chrono::steady_clock::now();
  int next_report = 1;
  if (total >= 20) {
    wo.progress = [&](int done, int n) {
      // A line every 10 %.
      if (done * 10 < next_report * n) return;
      while (done * 10 >= next_report * n) ++next_report;
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::cerr << "phantom: " << (100 * done / n) << "% (" << done << "/" << n << " slices, "
                << static_cast<int>(done / std::max(s, 1e-9) * 10) / 10.0 << " slices/s)\n";
    };
  }
  auto sum = ct::write_phantom(p, c.output, wo);
  if (!sum) return fail(sum.error());
  const ct::VolumeGeometry& g = p.geometry();
  std::cout << "wrote " << c.output << " (" << ct::format_name(wo.format) << ", " << g.width
            << " x " << g.height << " at " << g.spacing_x << " mm, " << o.slice_spacing_mm
            << " mm spacing, truth/ beside): " << sum.value().brief_report() << "\n";
  return 0;
}

// The condition space (docs/phantom.md "Condition space"); PhantomOptions::validate checks
// the ranges, so that the library and the command refuse the same values.
void add_condition_options(CLI::App* cmd, PhantomCli& c) {
  ct::PhantomOptions& o = c.o;
  cmd->add_option("--juvenile-ring-width-mm", o.juvenile_ring_width_mm,
                  "ring width at the pith, changing to --ring-width-mm at --juvenile-radius-mm "
                  "(0: all rings alike)");
  cmd->add_option("--juvenile-radius-mm", o.juvenile_radius_mm,
                  "pith distance where the rings reach their mature width")
      ->capture_default_str();
  cmd->add_option("--ring-contrast-hu", o.ring_contrast_hu,
                  "ring contrast as a standard deviation, HU (0: from --ring-amplitude)");
  cmd->add_option("--latewood-fraction", o.latewood_fraction,
                  "dense latewood share of a ring (0: the original cubic profile)");
  cmd->add_option("--density-drift-hu-per-m", o.density_drift_hu_per_m,
                  "wood CT numbers change by this per metre along the log");
  cmd->add_option("--moisture", c.moisture, "green (wet sapwood) | dried (-600 HU throughout)")
      ->capture_default_str();
  cmd->add_option("--wet-pockets", o.wet_pockets, "irregular wet patches in the heartwood");
  cmd->add_option("--hu-offset", o.hu_offset, "scanner calibration: reported = offset + slope HU");
  cmd->add_option("--hu-slope", o.hu_slope, "scanner calibration slope")->capture_default_str();
  cmd->add_option("--cupping-hu", o.cupping_hu,
                  "beam hardening: the log's centre reads this much lower than its rim");
  cmd->add_option("--metal-streak-hu", o.metal_streak_hu,
                  "streaks from the clutter's steel, HU at the steel (needs --clutter)");
  cmd->add_option("--window-centre-hu", o.window_centre_hu, "8-bit export: window centre, HU")
      ->capture_default_str();
  cmd->add_option("--window-width-hu", o.window_width_hu,
                  "8-bit export (TIFF/PNG): window width, HU (0: 16-bit HU)");
  cmd->add_option("--cracks", o.cracks, "radial cracks: heart checks and checks from the bark");
  cmd->add_option("--crack-width-mm", o.crack_width_mm, "a crack's opening at its widest, mm")
      ->capture_default_str();
  cmd->add_option("--resin-pockets", o.resin_pockets, "resin pockets (dense lenses)");
  cmd->add_option("--rot-pockets", o.rot_pockets, "rot (low-density columns) in the heartwood");
  cmd->add_option("--compression-wood", o.compression_wood,
                  "0-1: one side denser with wider rings");
  cmd->add_option("--bark-missing", o.bark_missing, "patches without bark");
  cmd->add_option("--bark-loose", o.bark_loose, "patches of bark standing off on an air gap");
  cmd->add_option("--knot-bark-mm", o.knot_bark_mm, "bark ring encased around dead knots, mm")
      ->capture_default_str();
  cmd->add_option("--resin-knots", o.resin_knots, "share of dead knots that are resin-soaked");
}

}  // namespace

void add_phantom_command(CLI::App& app, std::function<int()>& run_out) {
  auto c = std::make_shared<PhantomCli>();
  CLI::App* cmd = app.add_subcommand(
      "phantom",
      "Synthesise CT slices of a log model (DICOM, TIFF/PNG stack or volume) with "
      "ground truth in truth/");
  cmd->add_option("input", c->input, "log.json (or a maps / stem-bank folder)")->required();
  cmd->add_option("-o,--output", c->output, "slice folder to create")->required();
  cmd->add_option("--format", c->format, "dicom | tiff | png | mha | vti | nrrd")
      ->capture_default_str();
  ct::PhantomOptions& o = c->o;
  cmd->add_option("--size", o.image_size, "image width and height, pixels")->capture_default_str();
  cmd->add_option("--pixel-mm", o.pixel_mm, "pixel size, mm")->capture_default_str();
  cmd->add_option("--spacing-mm", o.slice_spacing_mm, "distance between slices, mm")
      ->capture_default_str();
  cmd->add_option("--thickness-mm", o.slice_thickness_mm,
                  "slice thickness, mm (default: the spacing)");
  cmd->add_option("--sub-slices", o.sub_slices,
                  "samples across the slice thickness (default: one per ~1.25 mm)");
  cmd->add_option("--from-mm", c->from_mm, "first slice centre, log frame mm (default: log start)");
  cmd->add_option("--to-mm", c->to_mm, "last slice centre, log frame mm (default: log end)");
  cmd->add_option("--noise-hu", o.noise_hu, "Gaussian noise sigma, HU")->capture_default_str();
  cmd->add_option("--blur-px", o.blur_px, "Gaussian PSF sigma, pixels")->capture_default_str();
  cmd->add_option("--seed", o.seed, "random seed: noise, dropped slices, clutter")
      ->capture_default_str();
  cmd->add_option("--offset-x-mm", o.placement.offset_x_mm,
                  "pith (mid scan) right of the image centre, mm");
  cmd->add_option("--offset-y-mm", o.placement.offset_y_mm,
                  "pith (mid scan) below the image centre, mm");
  cmd->add_option("--tilt-x-deg", o.placement.tilt_x_deg, "tilt about the x axis, degrees (<= 10)");
  cmd->add_option("--tilt-y-deg", o.placement.tilt_y_deg, "tilt about the y axis, degrees (<= 10)");
  cmd->add_option("--roll-deg", o.placement.roll_deg, "rotation about the log axis, degrees");
  cmd->add_option("--ring-width-mm", o.ring_width_mm, "mean annual ring width, mm")
      ->capture_default_str();
  cmd->add_option("--ring-amplitude", o.ring_amplitude,
                  "ring modulation, peak to peak, fraction of dry density")
      ->capture_default_str();
  cmd->add_option("--knot-noise", o.knot_noise, "knot outline noise (0: exact diameters)")
      ->capture_default_str();
  cmd->add_option("--drop-slices", o.drop_slices, "leave out this many random slices")
      ->capture_default_str();
  cmd->add_flag("--clutter", o.clutter, "add steel support bars and a chain");
  cmd->add_flag("--second-log", o.second_log,
                "a second log (the same model end for end) touching this one on the +x side");
  cmd->add_flag("--allow-clipped", o.allow_clipped,
                "a log larger than the field of view is cut by the image's edge (else refused)");
  cmd->add_flag("--no-bed", c->no_bed, "leave out the scanner bed");
  cmd->add_option("--bed-gap-mm", o.bed_gap_mm,
                  "belt below the log's lowest point, mm (0: the log lies on it)")
      ->capture_default_str();
  cmd->add_option("--rescale-intercept", c->rescale_intercept,
                  "DICOM and image stacks: stored = HU - intercept (default: 0 for DICOM, "
                  "-1024 for TIFF/PNG; volume files always store HU)");
  add_condition_options(cmd, *c);
  add_threads_option(cmd, o.threads);
  cmd->callback([c, &run_out]() { run_out = [c]() { return run(*c); }; });
}

}  // namespace sawyer::app

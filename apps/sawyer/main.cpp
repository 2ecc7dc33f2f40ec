// sawyer: the command line. Each subcommand parses its options, calls the libraries, and turns
// errors into one line on stderr and a non-zero exit code.
#include <CLI/CLI.hpp>

#include <filesystem>
#include <functional>
#include <iostream>
#include <stdexcept>
#include <string>

#include "cli_checks.h"
#include "cli_error.h"
#include "cmd_phantom.h"
#ifdef SAWYER_HAVE_RENDER
#include "cmd_render.h"
#ifdef SAWYER_HAVE_EXPORT
#include "cmd_export.h"
#endif
#include "cmd_report.h"
#include "cmd_run.h"
#endif
#include "cmd_batch.h"
#include "cmd_logs.h"
#include "cmd_saw.h"
#include "cmd_scan.h"
#include "ct_options.h"
#include "sawyer/core/interrupt.h"
#include "sawyer/core/output_guard.h"
#include "sawyer/maps/float_maps.h"
#include "sawyer/maps/open_log.h"
#include "sawyer/maps/published_maps.h"
#include "sawyer/model/log_generator.h"
#include "sawyer/model/log_json.h"
#include "sawyer/model/log_summary.h"

namespace fs = std::filesystem;
using namespace sawyer;
using app::fail;

namespace {

// A log model (log.json, maps, stem bank) gets its summary; anything else is read as a CT scan.
int cmd_info(const std::string& input, const app::CtCliOptions& ct_options) {
  if (maps::detect_log_source(input)) {
    Result<LogModel> log = maps::open_log(input);
    if (!log) return fail(log.error());
    print_summary(std::cout, log.value(), summarize(log.value()));
    return 0;
  }
  Status st = app::print_ct_info(input, app::to_open_options(ct_options), std::cout, std::cerr);
  if (st) return 0;
  // A folder with neither: say both what was looked for.
  const std::string& m = st.error().message();
  if (m.find("the folder is empty") != std::string::npos ||
      m.find("no CT slices found") != std::string::npos)
    return fail(Error(m + "; nor a log model (log.json, published maps, float maps or "
                          "stem-bank files)"));
  return fail(st.error());
}

int cmd_convert(const std::string& input, const std::string& output, std::string format) {
  Result<LogModel> log = maps::open_log(input);
  if (!log) return fail(log.error());
  if (format.empty()) format = fs::path(output).extension() == ".json" ? "log" : "published";
  Result<OutputLock> lock = OutputLock::acquire(
      {output, format == "log" ? OutputKind::kFile : OutputKind::kMapsFolder, {input}, "-o"});
  if (!lock) return fail(lock.error());
  Status st;
  if (format == "log") {
    st = write_log_json(log.value(), output);
  } else if (format == "published") {
    st = export_published_maps(log.value(), output);
  } else if (format == "float") {
    st = export_float_maps(log.value(), output);
  } else {
    return fail(Error("--format", "unknown format '" + format + "' (log, published, float)"));
  }
  if (!st) return fail(st.error());
  std::cout << "wrote " << output << " (" << format << ", " << log.value().knots.size()
            << " knots)\n";
  return 0;
}

// --eccentricity MIN,MAX (or one share for both) into the generator's range.
Status parse_eccentricity(const std::string& text, GeneratorOptions& o) {
  const Error bad(
      "--eccentricity",
      "must be MIN,MAX or one value, shares of the radius (e.g. 0,0.25), got '" + text + "'");
  const size_t comma = text.find(',');
  try {
    size_t used = 0;
    const std::string a = text.substr(0, comma);
    o.eccentricity_min = std::stod(a, &used);
    if (used != a.size()) return bad;
    o.eccentricity_max = o.eccentricity_min;
    if (comma != std::string::npos) {
      const std::string b = text.substr(comma + 1);
      o.eccentricity_max = std::stod(b, &used);
      if (used != b.size()) return bad;
    }
  } catch (const std::exception&) {
    return bad;
  }
  // A negative maximum would mean "not asked" to the generator: refuse it here.
  if (o.eccentricity_max < 0) return bad;
  return Status::Ok();
}

int cmd_generate(const std::string& species, std::uint64_t seed, double length_m, double top_mm,
                 const std::string& position, const std::string& eccentricity,
                 const double* ecc_change, const double* ecc_turn_rad, const std::string& output) {
  Result<Species> sp = parse_species(species);
  if (!sp) return fail(sp.error());
  Result<LogPosition> pos = parse_log_position(position);
  if (!pos) return fail(pos.error());
  GeneratorOptions o;
  o.species = sp.value();
  o.position = pos.value();
  o.seed = seed;
  o.length_mm = length_m * 1e3;
  o.top_diameter_mm = top_mm;
  if (!eccentricity.empty()) {
    Status e = parse_eccentricity(eccentricity, o);
    if (!e) return fail(e.error());
  } else if (ecc_change || ecc_turn_rad) {
    return fail(Error(ecc_change ? "--eccentricity-change" : "--eccentricity-turn-rad",
                      "needs --eccentricity MIN,MAX"));
  }
  if (ecc_change) o.eccentricity_change = *ecc_change;
  if (ecc_turn_rad) o.eccentricity_turn_rad = *ecc_turn_rad;
  Status v = o.validate();
  if (!v) return fail(v.error());
  Result<OutputLock> lock = OutputLock::acquire({output, OutputKind::kFile, {}, "-o"});
  if (!lock) return fail(lock.error());
  Result<LogModel> log = generate_log(o);
  if (!log) return fail(log.error());
  Status st = write_log_json(log.value(), output);
  if (!st) return fail(st.error());
  std::cout << "wrote " << output << "\n";
  print_summary(std::cout, log.value(), summarize(log.value()));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // Ctrl-C or SIGTERM removes what is being written before the process ends (exit 130/143).
  install_interrupt_cleanup();
  CLI::App app{"sawyer: CT scans of logs in, log models, virtual sawing and cutting reports out"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "sawyer 0.1.0");

  std::string info_in;
  app::CtCliOptions info_ct;
  CLI::App* info = app.add_subcommand(
      "info",
      "Print a log's length, diameters, volume, taper, pith wander and knots, or what a CT scan "
      "holds (format, slices, spacing, HU range, problems)");
  info->add_option("input", info_in,
                   "log.json, a folder of published maps, float maps or stem-bank files, or a CT "
                   "scan (DICOM/TIFF/PNG folder, .vti, .mha, .nrrd)")
      ->required();
  app::add_ct_options(info, info_ct);

  std::string conv_in, conv_out, conv_format;
  CLI::App* convert = app.add_subcommand(
      "convert", "Convert between log.json, the published map format and float maps");
  convert->add_option("input", conv_in, "log.json or a maps / stem-bank folder")->required();
  convert->add_option("-o,--output", conv_out, "output: a .json file or a maps folder")->required();
  convert
      ->add_option("--format", conv_format,
                   "log | published | float (default: log for .json, else published)")
      ->check(app::one_of({"log", "published", "float"}));

  std::string gen_species = "spruce", gen_out, gen_position = "drawn", gen_ecc;
  std::uint64_t gen_seed = 1;
  double gen_length_m = 0, gen_top_mm = 0, gen_ecc_change = 0, gen_ecc_turn = 0;
  CLI::App* generate = app.add_subcommand("generate", "Generate a realistic random log model");
  generate->add_option("--species", gen_species, "pine | spruce")->capture_default_str();
  generate->add_option("--seed", gen_seed, "random seed (same seed, same log)")
      ->capture_default_str();
  generate->add_option("--length-m", gen_length_m, "log length in metres (default: random 3-6 m)");
  generate->add_option("--top-diameter-mm", gen_top_mm,
                       "top diameter under bark (default: random)");
  generate->add_option("--position", gen_position,
                       "where in the tree: butt | middle | top | drawn (default: drawn)");
  generate->add_option("--eccentricity", gen_ecc,
                       "MIN,MAX: the pith this share of the radius off the outline's centre "
                       "(0-0.4; real piths 0-0.25), changing along the log (default: 1-5 %)");
  CLI::Option* gen_ecc_change_opt = generate->add_option(
      "--eccentricity-change", gen_ecc_change,
      "with --eccentricity: how much it changes along the log, share of the radius "
      "(default 0.05)");
  CLI::Option* gen_ecc_turn_opt =
      generate->add_option("--eccentricity-turn-rad", gen_ecc_turn,
                           "with --eccentricity: its direction turns by up to this over the log "
                           "(default 0.5)");
  generate->add_option("-o,--output", gen_out, "log.json to write")->required();

  std::function<int()> run_phantom;
  app::add_phantom_command(app, run_phantom);
  std::function<int()> run_scan;
  app::add_scan_command(app, run_scan);
  std::function<int()> run_saw;
  app::add_saw_command(app, run_saw);
  std::function<int()> run_logs, run_batch;
  app::add_logs_command(app, run_logs);
  app::add_batch_command(app, run_batch);
  std::function<int()> run_render, run_run;
#ifdef SAWYER_HAVE_RENDER
  app::add_render_command(app, run_render);
  app::add_run_command(app, run_run);
#endif
  std::function<int()> run_export;
#ifdef SAWYER_HAVE_EXPORT
  app::add_export_command(app, run_export);
#endif
  std::function<int()> run_report;
#ifdef SAWYER_HAVE_RENDER
  app::add_report_command(app, run_report);
#endif

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every command-line error is bad input (exit 1), whatever
    // CLI11's own code for it, said in one line like every other refusal.
    if (e.get_exit_code() == 0) return app.exit(e);
    std::cerr << "sawyer: " << app::parse_error_line(app, e, {argv + 1, argv + argc}) << "\n";
    return kExitBadInput;
  }

  if (*info) return cmd_info(info_in, info_ct);
  if (*convert) return cmd_convert(conv_in, conv_out, conv_format);
  if (run_phantom) return run_phantom();
  if (run_scan) return run_scan();
  if (run_saw) return run_saw();
  if (run_logs) return run_logs();
  if (run_batch) return run_batch();
  if (run_render) return run_render();
  if (run_run) return run_run();
  if (run_report) return run_report();
  if (run_export) return run_export();
  if (*generate)
    return cmd_generate(gen_species, gen_seed, gen_length_m, gen_top_mm, gen_position, gen_ecc,
                        gen_ecc_change_opt->count() ? &gen_ecc_change : nullptr,
                        gen_ecc_turn_opt->count() ? &gen_ecc_turn : nullptr, gen_out);
  return 0;
}

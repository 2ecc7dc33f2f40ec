// Reading a run folder back (see run_folder.h). Every check names the file and the key.
#include "sawyer/report/run_folder.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <optional>

#include "sawyer/core/file_util.h"
#include "sawyer/model/log_json.h"
#include "sawyer/sawing/sawing_file.h"

namespace sawyer::report {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

Result<Json> read_json(const fs::path& path) {
  if (!fs::exists(path)) return Error(path.string(), "missing");
  Result<std::string> text = read_text_file(path);
  if (!text) return text.error();
  Json j = Json::parse(text.value(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return Error(path.string(), "not valid JSON");
  if (!j.is_object()) return Error(path.string(), "expected a JSON object");
  return j;
}

std::string opt_string(const Json& j, const char* key) {
  auto it = j.find(key);
  return it != j.end() && it->is_string() ? it->get<std::string>() : std::string();
}

Result<RunInfo> parse_run(const Json& j) {
  if (opt_string(j, "format") != "sawyer-run/1")
    return Error("format", "expected \"sawyer-run/1\"");
  RunInfo r;
  r.present = true;
  r.log_id = opt_string(j, "log_id");
  r.species = opt_string(j, "species");
  r.scan_source = opt_string(j, "scan_source");
  r.scan_description = opt_string(j, "scan_description");
  r.scan_checksum = opt_string(j, "scan_checksum");
  r.date = opt_string(j, "date");
  r.sawyer_version = opt_string(j, "sawyer_version");
  if (auto n = j.find("scan_notes"); n != j.end() && n->is_array())
    for (const Json& s : *n)
      if (s.is_string()) r.scan_notes.push_back(s.get<std::string>());
  if (auto o = j.find("options"); o != j.end() && o->is_object()) {
    r.pattern = opt_string(*o, "pattern");
    r.grading = opt_string(*o, "grading");
    r.prices = opt_string(*o, "prices");
    r.position = opt_string(*o, "position");
    r.pattern_set = opt_string(*o, "pattern_set");
  }
  // A run that scanned the log but could not saw it says why (run_json_text).
  if (opt_string(j, "outcome") == "not sawn") {
    NotSawn ns;
    if (auto n = j.find("not_sawn"); n != j.end() && n->is_object()) {
      ns.reason = opt_string(*n, "reason");
      ns.pattern = opt_string(*n, "pattern");
      ns.pattern_set = opt_string(*n, "pattern_set");
      auto num = [&](const char* key) {
        auto v = n->find(key);
        return v != n->end() && v->is_number() ? v->get<double>() : -1.0;
      };
      ns.needed_diameter_mm = num("needed_diameter_mm");
      ns.usable_diameter_mm = num("usable_diameter_mm");
    }
    r.not_sawn = ns;
  }
  if (auto st = j.find("stages"); st != j.end() && st->is_array())
    for (const Json& s : *st)
      if (s.is_object())
        r.stages.push_back(
            {opt_string(s, "name"),
             s.contains("seconds") && s["seconds"].is_number() ? s["seconds"].get<double>() : -1.0,
             s.contains("peak_mb") && s["peak_mb"].is_number() ? s["peak_mb"].get<double>()
                                                               : -1.0});
  if (auto t = j.find("time"); t != j.end() && t->is_object()) {
    auto num = [&](const char* key) {
      auto v = t->find(key);
      return v != t->end() && v->is_number() ? v->get<double>() : -1.0;
    };
    r.seconds_to_decision = num("to_decision_s");
    r.seconds_total = num("total_s");
  }
  return r;
}

}  // namespace

std::string run_json_text(const RunRecord& run) {
  using Ordered = nlohmann::ordered_json;
  const RunInfo& in = run.info;
  Ordered j;
  j["format"] = "sawyer-run/1";
  j["log_id"] = in.log_id;
  j["species"] = in.species;
  // "sawn", or "not sawn" with why: the scan is complete, the pattern cannot be sawn from the
  // log (the folder then has no sawing.json; docs/run.md).
  j["outcome"] = in.not_sawn ? "not sawn" : "sawn";
  if (in.not_sawn) {
    const NotSawn& ns = *in.not_sawn;
    j["not_sawn"] = {{"reason", ns.reason},
                     {"pattern", ns.pattern},
                     {"needed_diameter_mm", std::round(ns.needed_diameter_mm * 10) / 10},
                     {"usable_diameter_mm", std::round(ns.usable_diameter_mm * 10) / 10}};
    if (!ns.pattern_set.empty()) j["not_sawn"]["pattern_set"] = ns.pattern_set;
  }
  j["scan_source"] = in.scan_source;
  j["scan_description"] = in.scan_description;
  j["scan_notes"] = in.scan_notes;
  const RunRecord::ZResampling& zr = run.z_resampling;
  j["z_resampling"] = {{"resampled", zr.resampled},
                       {"source_slices", zr.source_slices},
                       {"invented_slices", zr.invented_slices},
                       {"gaps", zr.gaps},
                       {"widest_gap_mm", zr.widest_gap_mm},
                       {"widest_gap_z0_mm", zr.widest_gap_z0_mm}};
  // log.json's x, y are the scanner's; heights go back to its z through this (docs/formats.md).
  if (run.scanner_frame)
    j["scanner_frame"] = Ordered::parse(scanner_frame_json_text(*run.scanner_frame));
  j["scan_checksum"] = in.scan_checksum;
  j["slices"] = run.slices;
  j["knots"] = run.knots;
  // The scan's QA verdict (as in log.json); when it fails, the chosen position rests on a
  // model the scan itself does not trust, and says so.
  if (run.qa) {
    j["qa"] = Ordered::parse(qa_json_text(*run.qa));
    if (!in.not_sawn) j["position_trusted"] = run.qa->trusted;
  }
  j["date"] = in.date;
  j["sawyer_version"] = in.sawyer_version;
  j["options"] = {{"pattern", in.pattern},
                  {"grading", in.grading},
                  {"prices", in.prices},
                  {"position", in.position}};
  if (!in.pattern_set.empty()) j["options"]["pattern_set"] = in.pattern_set;
  // The pattern chosen from the set and the next best, with the values they give (sawing.json's
  // "pattern_choice" has every candidate).
  if (const auto& pc = run.pattern_choice) {
    j["pattern_choice"] = {{"set", pc->set},
                           {"class", pc->class_label},
                           {"usable_diameter_mm", std::round(pc->usable_diameter_mm * 10) / 10},
                           {"currency", run.currency},
                           {"chosen", sawing::pattern_candidate_value_json(*pc, pc->chosen)},
                           {"next_best", sawing::pattern_candidate_value_json(*pc, pc->next_best)},
                           {"line", sawing::pattern_choice_line(*pc, run.currency)}};
  }
  Ordered st = Ordered::array();
  for (const RunInfo::Stage& s : in.stages) {
    Ordered o = {{"name", s.name}, {"seconds", s.seconds}};
    if (s.peak_mb >= 0) o["peak_mb"] = std::round(s.peak_mb * 10) / 10;
    st.push_back(o);
  }
  j["stages"] = st;
  // What the saw line waits for (the decision) apart from the whole run (bench/run_bench).
  if (in.seconds_to_decision >= 0 || in.seconds_total >= 0) {
    Ordered t = Ordered::object();
    if (in.seconds_to_decision >= 0) t["to_decision_s"] = in.seconds_to_decision;
    if (in.seconds_total >= 0) t["total_s"] = in.seconds_total;
    j["time"] = t;
  }
  return j.dump(1) + "\n";
}

Status write_run_file(const RunRecord& run, const fs::path& path) {
  return write_text_file_atomic(path, run_json_text(run));
}

Result<RunFolder> load_run_folder(const fs::path& out) {
  if (!fs::is_directory(out)) return Error(out.string(), "not a run folder (no such folder)");
  RunFolder f;
  f.dir = out;
  const fs::path log_path = out / "scan" / "log.json";
  if (!fs::exists(log_path)) return Error(log_path.string(), "missing");
  Result<LogModel> log = read_log_json(log_path);
  if (!log) return log.error();
  f.log = std::move(log).value();

  // run.json first: a run that did not saw the log has no sawing.json. Its errors come after
  // sawing.json's, as before.
  const fs::path run_path = out / "run.json";
  std::optional<Result<RunInfo>> run;
  if (fs::exists(run_path)) {
    Result<Json> rj = read_json(run_path);
    if (!rj) {
      run.emplace(rj.error());
    } else {
      Result<RunInfo> parsed = parse_run(rj.value());
      if (parsed)
        run.emplace(std::move(parsed));
      else
        run.emplace(parsed.error().with_context(run_path.string()));
    }
  }
  const bool not_sawn = run && run->ok() && run->value().not_sawn;

  const fs::path sawing_path = out / "sawing.json";
  if (!not_sawn) {
    Result<SawingRecord> sawing = sawing::read_sawing_file(sawing_path);
    if (!sawing) return sawing.error();
    f.sawing = std::move(sawing).value();
    // A run's file is whole: a position saved by the viewer is not a run's results.
    if (!f.sawing.best.present) return Error(sawing_path.string(), "best: missing");
    if (f.sawing.log_id != f.log.id)
      return Error(sawing_path.string(), "log '" + f.sawing.log_id + "' does not match " +
                                             log_path.string() + " (log '" + f.log.id + "')");
  }

  if (run) {
    if (!*run) return run->error();
    f.run = std::move(*run).value();
    if (!f.run.log_id.empty() && f.run.log_id != f.log.id)
      return Error(run_path.string(), "log_id '" + f.run.log_id + "' does not match " +
                                          log_path.string() + " (log '" + f.log.id + "')");
  }
  return f;
}

}  // namespace sawyer::report

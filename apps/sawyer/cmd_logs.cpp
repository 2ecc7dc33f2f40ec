// `sawyer logs`: opens the register read-only (a missing file is an empty register, not an
// error), filters in SQL and prints a table, CSV or JSON on stdout. With --merge it copies other
// registers into --db first.
#include "cmd_logs.h"
#include "cli_checks.h"
#include "cli_error.h"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sawyer/register/log_register.h"
#include "sawyer/register/manifest.h"

namespace sawyer::app {
namespace {

namespace fs = std::filesystem;
using namespace sawyer::reg;
using Json = nlohmann::ordered_json;

struct LogsCli {
  std::string db, species, id, order_by = "scanned_at";
  double min_value = 0, min_diameter = 0;
  bool has_min_value = false, has_min_diameter = false;
  int limit = 0;
  bool csv = false, json = false;
  std::vector<std::string> merge;
};

// --id takes shell-style wildcards (* and ?); without any it matches anywhere in the id.
std::string id_like(const std::string& pattern) {
  if (pattern.empty()) return "";
  std::string like;
  bool wild = false;
  for (char c : pattern) {
    if (c == '*') {
      like += '%';
      wild = true;
    } else if (c == '?') {
      like += '_';
      wild = true;
    } else {
      like += c;
    }
  }
  return wild ? like : "%" + like + "%";
}

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

std::string position_text(const LogRecord& r) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.0f°,%.0f,%.0f", r.rotation_deg, r.offset_x_mm, r.offset_y_mm);
  return buf;
}

// Column widths follow the longest cell, so ids and paths of any length line up.
void print_table(const std::vector<LogRecord>& rows, const fs::path& db) {
  const std::vector<std::string> head = {"id",      "species",    "len m", "butt mm",  "top mm",
                                         "mean mm", "m3",         "knots", "position", "value",
                                         "gain",    "scanned at", "report"};
  std::vector<std::vector<std::string>> cells;
  for (const LogRecord& r : rows) {
    cells.push_back({r.log_id.empty() ? "-" : r.log_id, r.species.empty() ? "-" : r.species,
                     fmt("%.2f", r.length_m), fmt("%.0f", r.butt_diameter_mm),
                     fmt("%.0f", r.top_diameter_mm), fmt("%.0f", r.mean_diameter_mm),
                     fmt("%.3f", r.volume_m3), std::to_string(r.knot_count), position_text(r),
                     fmt("%.2f", r.value) + (r.currency.empty() ? "" : " " + r.currency),
                     fmt("%+.1f%%", 100 * r.gain_over_horns_down), r.scanned_at, r.report_path});
  }
  // Display width: UTF-8 continuation bytes (the degree sign) take no column.
  auto width = [](const std::string& s) {
    size_t w = 0;
    for (unsigned char c : s) w += (c & 0xC0) != 0x80;
    return w;
  };
  std::vector<size_t> w(head.size());
  for (size_t i = 0; i < head.size(); ++i) w[i] = width(head[i]);
  for (const auto& row : cells)
    for (size_t i = 0; i < row.size(); ++i) w[i] = std::max(w[i], width(row[i]));
  // Text columns left-aligned, numbers right-aligned.
  auto left = [](size_t i) { return i <= 1 || i >= 11; };
  auto line = [&](const std::vector<std::string>& row) {
    std::string s;
    for (size_t i = 0; i < row.size(); ++i) {
      const std::string pad(w[i] - width(row[i]), ' ');
      if (i) s += "  ";
      s += left(i) ? row[i] + (i + 1 == row.size() ? "" : pad) : pad + row[i];
    }
    std::cout << s << "\n";
  };
  line(head);
  for (const auto& row : cells) line(row);
  std::cout << rows.size() << (rows.size() == 1 ? " log" : " logs") << " in " << db.string()
            << "\n";
}

Json record_json(const LogRecord& r) {
  return Json{{"log_id", r.log_id},
              {"species", r.species},
              {"scan_source", r.scan_source},
              {"scan_checksum", r.scan_checksum},
              {"length_m", r.length_m},
              {"butt_diameter_mm", r.butt_diameter_mm},
              {"top_diameter_mm", r.top_diameter_mm},
              {"mean_diameter_mm", r.mean_diameter_mm},
              {"volume_m3", r.volume_m3},
              {"taper_mm_per_m", r.taper_mm_per_m},
              {"knot_count", r.knot_count},
              {"pattern", r.pattern},
              {"grading", r.grading},
              {"rotation_deg", r.rotation_deg},
              {"offset_x_mm", r.offset_x_mm},
              {"offset_y_mm", r.offset_y_mm},
              {"value", r.value},
              {"currency", r.currency},
              {"gain_over_horns_down", r.gain_over_horns_down},
              {"output_dir", r.output_dir},
              {"report_path", r.report_path},
              {"scanned_at", r.scanned_at},
              {"first_registered", r.first_registered},
              {"last_registered", r.last_registered},
              {"scans", r.scans}};
}

void print_csv(const std::vector<LogRecord>& rows) {
  // Same fields and order as the JSON, so a script can switch between them.
  bool header = true;
  for (const LogRecord& r : rows) {
    const Json j = record_json(r);
    if (header) {
      std::string h;
      for (auto it = j.begin(); it != j.end(); ++it) h += (h.empty() ? "" : ",") + it.key();
      std::cout << h << "\n";
      header = false;
    }
    std::string s;
    bool first = true;
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (!first) s += ",";
      first = false;
      s += it->is_string() ? csv_cell(it->get<std::string>()) : it->dump();
    }
    std::cout << s << "\n";
  }
  if (rows.empty()) std::cout << "log_id,species,scan_source\n";
}

int run(const LogsCli& c) {
  // Every option is checked before the register is looked at: a wrong field is wrong whether or
  // not there are logs yet.
  if (Status st = check_order_by(c.order_by); !st) return fail(st.error());
  Result<fs::path> db_path = register_path(c.db, "--db", "");
  if (!db_path) return fail(db_path.error());
  const fs::path db = db_path.value();
  if (!c.merge.empty()) {
    // Every source is checked before --db is touched; a refusal leaves no new register.
    Result<std::vector<MergeSummary>> merged =
        merge_registers(db, std::vector<fs::path>(c.merge.begin(), c.merge.end()));
    if (!merged) return fail(merged.error());
    for (size_t i = 0; i < c.merge.size(); ++i) {
      const MergeSummary& m = merged.value()[i];
      std::cout << "merged " << c.merge[i] << ": " << m.rows_read << " rows, " << m.added
                << " new, " << m.updated << " updated\n";
    }
    Result<LogRegister> reg = LogRegister::open_read_only(db);
    if (!reg) return fail(reg.error());
    Result<int> n = reg.value().count();
    if (!n) return fail(n.error());
    std::cout << db.string() << ": " << n.value() << " logs\n";
    return 0;
  }

  std::error_code ec;
  if (!fs::exists(db, ec)) {
    // Nothing scanned yet is a normal state, not an error; the output formats stay parseable.
    if (c.json)
      std::cout << "[]\n";
    else if (!c.csv)
      std::cout << "no logs registered yet (" << db.string() << " does not exist)\n";
    return 0;
  }
  Result<LogRegister> reg = LogRegister::open_read_only(db);
  if (!reg) return fail(reg.error());
  LogFilter f;
  f.species = c.species;
  f.log_id_like = id_like(c.id);
  if (c.has_min_value) f.min_value = c.min_value;
  if (c.has_min_diameter) f.min_diameter_mm = c.min_diameter;
  f.limit = c.limit;
  f.order_by = c.order_by;
  Result<std::vector<LogRecord>> rows = reg.value().list(f);
  if (!rows) return fail(rows.error());

  if (c.json) {
    Json a = Json::array();
    for (const LogRecord& r : rows.value()) a.push_back(record_json(r));
    std::cout << a.dump(2) << "\n";
  } else if (c.csv) {
    print_csv(rows.value());
  } else if (rows.value().empty()) {
    Result<int> n = reg.value().count();
    if (!n) return fail(n.error());
    if (n.value() == 0)
      std::cout << "no logs registered yet in " << db.string() << "\n";
    else
      std::cout << "no logs match (" << n.value() << " in " << db.string() << ")\n";
  } else {
    print_table(rows.value(), db);
  }
  return 0;
}

}  // namespace

void add_logs_command(CLI::App& app, std::function<int()>& run_out) {
  auto c = std::make_shared<LogsCli>();
  CLI::App* cmd = app.add_subcommand(
      "logs",
      "List the log register (every scanned log: figures, best position, value, report), or "
      "merge registers");
  cmd->add_option("--db", c->db,
                  "the register (default: $SAWYER_DB, else $XDG_DATA_HOME/sawyer/logs.sqlite, "
                  "else ~/.local/share/sawyer/logs.sqlite)");
  cmd->add_option("--species", c->species, "only this species (pine, spruce)");
  cmd->add_option("--id", c->id,
                  "only log ids matching this pattern: * and ? wildcards, else a substring");
  cmd->add_option("--min-value", c->min_value, "only logs worth at least this much");
  cmd->add_option("--min-diameter", c->min_diameter, "only logs with a mean diameter >= MM");
  cmd->add_option("--limit", c->limit, "at most N logs")
      ->check(whole_number_in(0, 1000000000, "0: all"));
  cmd->add_option("--sort", c->order_by,
                  "sort by a field (scanned_at, value, log_id, mean_diameter_mm, volume_m3, ...); "
                  "--sort=-field sorts descending")
      ->capture_default_str();
  CLI::Option* csv = cmd->add_flag("--csv", c->csv, "CSV on stdout (every field)");
  cmd->add_flag("--json", c->json, "JSON on stdout (every field)")->excludes(csv);
  cmd->add_option("--merge", c->merge,
                  "copy these registers into --db (e.g. one per batch shard); the later scan of "
                  "a source wins; merging twice changes nothing")
      ->expected(1, -1);
  cmd->callback([c, cmd, &run_out]() {
    c->has_min_value = cmd->count("--min-value") > 0;
    c->has_min_diameter = cmd->count("--min-diameter") > 0;
    run_out = [c]() { return run(*c); };
  });
}

}  // namespace sawyer::app

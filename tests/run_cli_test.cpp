// `sawyer run`: a CT folder in, the run folder out (scan/, sawing.json, run.json, report/) and
// the log in the register; bad input stops it with one line naming the problem, before or after
// the scan, and leaves neither output nor a register row.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "sawyer/register/log_register.h"
#include "sawyer/test/test_util.h"

using namespace sawyer;
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

// 40 cm of the real spruce log at 0.8 mm pixels (test_util.h): small enough to scan in a second or
// two.
fs::path small_ct() { return test::gran1_40cm_ct(); }

// 2ex with boards kept from 200 mm: the test log is short.
fs::path short_pattern(const test::TempDir& dir) {
  const fs::path p = dir / "short_2ex.json";
  test::write_file(p, R"({"format": "sawyer-pattern/1", "name": "2ex short",
    "wane": {"min_length_mm": 200, "length_step_mm": 100},
    "boards": [
      {"name": "centre 1", "u_mm": -26.5, "v_mm": 0, "thickness_mm": 50, "width_mm": 150},
      {"name": "centre 2", "u_mm": 26.5, "v_mm": 0, "thickness_mm": 50, "width_mm": 150},
      {"name": "side 1", "u_mm": -67.0, "v_mm": 0, "thickness_mm": 25, "width_mm": 100,
       "edged": true},
      {"name": "side 2", "u_mm": 67.0, "v_mm": 0, "thickness_mm": 25, "width_mm": 100,
       "edged": true}]})");
  return p;
}

Json read_json(const fs::path& p) {
  std::ifstream f(p);
  return Json::parse(f, nullptr, false);
}

size_t lines(const std::string& s) {
  size_t n = 0;
  for (char ch : s) n += ch == '\n';
  return n;
}

int rows(const fs::path& db) {
  auto reg = reg::LogRegister::open_read_only(db);
  if (!reg) return -1;
  auto n = reg.value().count();
  return n ? n.value() : -1;
}

// The run folder `out`'s report.html, whole.
std::string report_html(const fs::path& out) {
  std::ifstream f(out / "report" / "report.html");
  return std::string(std::istreambuf_iterator<char>(f), {});
}

// The text of the run folder `out`'s report.pdf (its first `pages` pages; 0: all) through
// pdftotext; false when pdftotext is not installed. A failing pdftotext fails the test.
bool report_pdf_text(const fs::path& out, std::string* text, int pages = 0) {
  if (test::run_command("command -v pdftotext >/dev/null", text) != 0) return false;
  const std::string first = pages > 0 ? "-l " + std::to_string(pages) + " " : "";
  EXPECT_EQ(test::run_command(
                "pdftotext " + first + test::quoted(out / "report" / "report.pdf") + " -", text),
            0);
  return true;
}

}  // namespace

TEST(RunCli, WritesScanSawingReportAndRegistersTheLog) {
  const fs::path ct = small_ct();
  ASSERT_FALSE(ct.empty());
  test::TempDir dir;
  std::string out;
  const std::string cmd = "run " + test::quoted(ct) + " -o " + test::quoted(dir / "out") +
                          " --pattern " + test::quoted(short_pattern(dir)) + " --db " +
                          test::quoted(dir / "logs.sqlite") + " --id g40 --species spruce";
  ASSERT_EQ(test::run_sawyer(cmd, &out), 0) << out;
  for (const char* f :
       {"scan/log.json", "scan/qa/pith_track.png", "sawing.json", "run.json", "report/report.pdf",
        "report/report.html", "report/boards.csv", "report/report.json"})
    EXPECT_TRUE(fs::exists(dir / "out" / f)) << f;
  const Json saw = read_json(dir / "out" / "sawing.json");
  ASSERT_FALSE(saw.is_discarded());
  EXPECT_EQ(saw["log"], "g40");
  EXPECT_EQ(saw["chosen"], "best");
  EXPECT_GT(saw["boards"].size(), 0u);
  const Json run = read_json(dir / "out" / "run.json");
  ASSERT_FALSE(run.is_discarded());
  EXPECT_EQ(run["format"], "sawyer-run/1");
  EXPECT_EQ(run["species"], "spruce");
  EXPECT_EQ(fs::path(run["scan_source"].get<std::string>()), fs::canonical(ct));
  EXPECT_FALSE(run["scan_checksum"].get<std::string>().empty());
  ASSERT_GE(run["stages"].size(), 2u);
  EXPECT_EQ(run["stages"][0]["name"], "scan");
  EXPECT_EQ(run["stages"][1]["name"], "saw");
  // The decision (scan and saw) comes before the files and the report (issue 42): run.json
  // keeps its time apart from the whole run's, and the summary prints both.
  ASSERT_TRUE(run.contains("time")) << run.dump(1);
  const double to_decision = run["time"]["to_decision_s"].get<double>();
  const double total = run["time"]["total_s"].get<double>();
  EXPECT_GE(to_decision,
            run["stages"][0]["seconds"].get<double>() + run["stages"][1]["seconds"].get<double>());
  EXPECT_LT(to_decision, total);
  EXPECT_LT(out.find("position: rot"), out.find("report  "));
  EXPECT_NE(out.find("(the decision at "), std::string::npos) << out;
  // The scan's QA verdict trusts this scan: run.json says so, and so does the summary.
  ASSERT_TRUE(run.contains("qa")) << run.dump(1);
  EXPECT_EQ(run["qa"]["trusted"], true) << run["qa"].dump(1);
  EXPECT_EQ(run["position_trusted"], true);
  EXPECT_NE(out.find("QA: trusted"), std::string::npos) << out;
  // The summary ends with where the report is.
  EXPECT_NE(out.find("report.pdf"), std::string::npos) << out;
  EXPECT_NE(out.find("volume yield"), std::string::npos) << out;

  // The scanner frame (issue 19): run.json and sawing.json carry the scan's origin as the CT
  // gives it (the phantom's truth), and the report states the frame with the scanner z it uses.
  const Json truth = read_json(ct / "truth" / "phantom.json");
  ASSERT_FALSE(truth.is_discarded());
  const Json& origin = truth["geometry"]["origin"];
  const double first_z = origin[2].get<double>() + truth["geometry"]["z"][0].get<double>();
  ASSERT_TRUE(run.contains("scanner_frame")) << run.dump(1);
  ASSERT_EQ(run["scanner_frame"]["origin_mm"].size(), 3u);
  EXPECT_NEAR(run["scanner_frame"]["origin_mm"][0].get<double>(), origin[0].get<double>(), 1e-3);
  EXPECT_NEAR(run["scanner_frame"]["origin_mm"][1].get<double>(), origin[1].get<double>(), 1e-3);
  EXPECT_NEAR(run["scanner_frame"]["origin_mm"][2].get<double>(), first_z, 1e-3);
  EXPECT_EQ(saw["frame"]["coordinates"], "scanner");
  EXPECT_EQ(saw["frame"]["scanner_frame"], run["scanner_frame"]);
  const std::string html = report_html(dir / "out");
  char frame[64];
  std::snprintf(frame, sizeof frame, "scanner x, y; z from %.1f mm",
                run["scanner_frame"]["z0_mm"].get<double>());
  EXPECT_NE(html.find(std::string("<th>Frame</th><td>") + frame + "</td>"), std::string::npos)
      << frame;
  std::string pdf_text;
  if (report_pdf_text(dir / "out", &pdf_text)) {
    EXPECT_NE(pdf_text.find(frame), std::string::npos) << frame << " not in\n" << pdf_text;
  }

  // The register holds the log with the chosen position and value of sawing.json.
  auto reg = reg::LogRegister::open_read_only(dir / "logs.sqlite");
  ASSERT_TRUE(reg) << reg.error().message();
  auto row = reg.value().find(fs::canonical(ct).string());
  ASSERT_TRUE(row && row.value()) << out;
  const reg::LogRecord& r = *row.value();
  EXPECT_EQ(r.log_id, "g40");
  EXPECT_NEAR(r.value, saw["best"]["value"].get<double>(), 1e-6);
  EXPECT_NEAR(r.rotation_deg, saw["best"]["rotation_deg"].get<double>(), 1e-9);
  EXPECT_GT(r.knot_count, 0);
  EXPECT_EQ(fs::path(r.report_path), fs::absolute(dir / "out" / "report" / "report.pdf"));

  // The same folder again: the row is updated, not duplicated.
  ASSERT_EQ(test::run_sawyer(cmd + " --quiet", &out), 0) << out;
  EXPECT_EQ(rows(dir / "logs.sqlite"), 1);
  auto again = reg.value().find(fs::canonical(ct).string());
  ASSERT_TRUE(again && again.value());
  EXPECT_EQ(again.value()->scans, 2);
}

// A scan whose QA verdict fails (the log is wider than the field of view, so the image's edge
// cuts its outline): everything is still written, the verdict is in log.json and run.json, the
// report's first page says the position is not to be trusted, and the exit code is 3.
TEST(RunCli, AScanThatFailsItsQaIsWrittenMarkedAndExitsThree) {
  const fs::path ct = test::cached_phantom(
      "qa_clipped", test::quoted(test::sample_log("pine_8") / "log.json") +
                        " --from-mm 1500 --to-mm 1700 --size 240 --pixel-mm 1.0 --offset-x-mm 40"
                        " --allow-clipped --seed 4");
  ASSERT_FALSE(ct.empty());
  test::TempDir dir;
  std::string out;
  ASSERT_EQ(
      test::run_sawyer("scan " + test::quoted(ct) + " -o " + test::quoted(dir / "scan"), &out), 3)
      << out;
  EXPECT_NE(out.find("QA: NOT TRUSTED"), std::string::npos) << out;
  EXPECT_NE(out.find("the image's edge"), std::string::npos) << out;
  const Json log = read_json(dir / "scan" / "log.json");
  ASSERT_FALSE(log.is_discarded());
  EXPECT_EQ(log["qa"]["trusted"], false) << log["qa"].dump(1);
  EXPECT_TRUE(fs::exists(dir / "scan" / "qa" / "pith_track.png"));

  // The cut outline leaves a narrow log: two small boards.
  const fs::path pattern = dir / "small.json";
  test::write_file(pattern, R"({"format": "sawyer-pattern/1", "name": "small",
    "wane": {"min_length_mm": 100, "length_step_mm": 100},
    "boards": [
      {"name": "1", "u_mm": -13, "v_mm": 0, "thickness_mm": 25, "width_mm": 75},
      {"name": "2", "u_mm": 13, "v_mm": 0, "thickness_mm": 25, "width_mm": 75}]})");
  const std::string cmd = "run " + test::quoted(ct) + " -o " + test::quoted(dir / "out") +
                          " --pattern " + test::quoted(pattern) + " --db " +
                          test::quoted(dir / "logs.sqlite") + " --quiet";
  ASSERT_EQ(test::run_sawyer(cmd, &out), 3) << out;
  EXPECT_NE(out.find("completed with warnings"), std::string::npos) << out;
  for (const char* f :
       {"scan/log.json", "sawing.json", "run.json", "report/report.pdf", "report/report.html"})
    EXPECT_TRUE(fs::exists(dir / "out" / f)) << f;
  const Json run = read_json(dir / "out" / "run.json");
  ASSERT_FALSE(run.is_discarded());
  EXPECT_EQ(run["position_trusted"], false);
  EXPECT_EQ(run["qa"]["trusted"], false);
  ASSERT_FALSE(run["qa"]["warnings"].empty());
  EXPECT_EQ(rows(dir / "logs.sqlite"), 1);  // registered all the same
  std::string pdf_text;
  if (report_pdf_text(dir / "out", &pdf_text, 1)) {
    EXPECT_NE(pdf_text.find("NOT TO BE TRUSTED"), std::string::npos) << pdf_text;
    EXPECT_NE(pdf_text.find("image's edge"), std::string::npos) << pdf_text;
  }
}

TEST(RunCli, GivenPositionIsTheChosenOne) {
  const fs::path ct = small_ct();
  ASSERT_FALSE(ct.empty());
  test::TempDir dir;
  std::string out;
  ASSERT_EQ(test::run_sawyer("run " + test::quoted(ct) + " -o " + test::quoted(dir / "out") +
                                 " --pattern " + test::quoted(short_pattern(dir)) +
                                 " --position 37,4,0 --no-register --no-report -q",
                             &out),
            0)
      << out;
  const Json saw = read_json(dir / "out" / "sawing.json");
  ASSERT_FALSE(saw.is_discarded());
  EXPECT_EQ(saw["chosen"], "given");
  EXPECT_DOUBLE_EQ(saw["given_position"]["rotation_deg"].get<double>(), 37.0);
  EXPECT_DOUBLE_EQ(saw["given_position"]["offset_x_mm"].get<double>(), 4.0);
  EXPECT_NE(out.find("given position rot 37.0°"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir / "out" / "report"));
}

TEST(RunCli, BadCtFolderGivesOneLineAndLeavesNothing) {
  test::TempDir dir;
  fs::create_directories(dir / "ct");
  test::write_file(dir / "ct" / "slice_0001.dcm", "this is not a DICOM file\n");
  test::write_file(dir / "ct" / "slice_0002.dcm", "nor is this\n");
  // An earlier good run's folder must survive a failed run over it.
  fs::create_directories(dir / "out");
  test::write_file(dir / "out" / "keep.txt", "earlier run\n");
  std::string out;
  EXPECT_NE(
      test::run_sawyer("run " + test::quoted(dir / "ct") + " -o " + test::quoted(dir / "out") +
                           " -q --db " + test::quoted(dir / "logs.sqlite"),
                       &out),
      0);
  EXPECT_EQ(lines(out), 1u) << out;
  EXPECT_NE(out.find((dir / "ct").string()), std::string::npos) << out;
  EXPECT_TRUE(fs::exists(dir / "out" / "keep.txt"));
  EXPECT_FALSE(fs::exists(dir / "out" / "report"));
  EXPECT_FALSE(fs::exists(dir / "logs.sqlite")) << "a failed run leaves no register (issue 44)";
}

TEST(RunCli, MissingAndEmptyCtFoldersAreRefused) {
  test::TempDir dir;
  fs::create_directories(dir / "empty");
  for (const char* name : {"missing", "empty"}) {
    std::string out;
    EXPECT_NE(test::run_sawyer("run " + test::quoted(dir / name) + " -o " +
                                   test::quoted(dir / "out") + " -q --no-register",
                               &out),
              0)
        << name;
    EXPECT_EQ(lines(out), 1u) << out;
    EXPECT_NE(out.find(name), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(dir / "out")) << name;
  }
}

TEST(RunCli, BadPatternIsRefusedBeforeTheScan) {
  test::TempDir dir;
  test::write_file(dir / "p.json", R"({"format": "sawyer-pattern/1", "boards": 3})");
  std::string out;
  // The CT folder does not exist either: the pattern is checked first.
  EXPECT_NE(
      test::run_sawyer("run " + test::quoted(dir / "no_ct") + " -o " + test::quoted(dir / "out") +
                           " -q --no-register --pattern " + test::quoted(dir / "p.json"),
                       &out),
      0);
  EXPECT_EQ(lines(out), 1u) << out;
  EXPECT_NE(out.find("p.json"), std::string::npos) << out;
  EXPECT_NE(out.find("boards"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(RunCli, ABadRegisterFileIsRefusedBeforeTheScan) {
  test::TempDir dir;
  test::write_file(dir / "logs.sqlite", std::string(4096, 'x'));
  std::string out;
  EXPECT_NE(
      test::run_sawyer("run " + test::quoted(dir / "no_ct") + " -o " + test::quoted(dir / "out") +
                           " -q --db " + test::quoted(dir / "logs.sqlite"),
                       &out),
      0);
  EXPECT_EQ(lines(out), 1u) << out;
  EXPECT_NE(out.find("logs.sqlite"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

// A complete scan is never thrown away (issue 41): a pattern far wider than the log cannot be
// sawn from it, yet the run writes the scan, run.json (saying why, with the two diameters) and a
// report that says why, adds no register row, prints one line why and exits 4 (docs/run.md);
// `sawyer report` on the folder writes the same report again.
// A position inside the scanned volume but off the log's wood is known to miss only once the
// log is scanned: the complete scan is kept, as for a pattern too large (exit 4), and the
// report says what to do.
TEST(RunCli, APositionOffTheLogWritesTheScanAndAReportAndExitsFour) {
  const fs::path ct = small_ct();
  ASSERT_FALSE(ct.empty());
  test::TempDir dir;
  std::string out;
  const int rc = test::run_sawyer("run " + test::quoted(ct) + " -o " + test::quoted(dir / "out") +
                                      " --pattern " + test::quoted(short_pattern(dir)) +
                                      " --position 0,190 --db " +
                                      test::quoted(dir / "logs.sqlite") + " --id g40 -q",
                                  &out);
  ASSERT_EQ(rc, 4) << out;
  EXPECT_NE(out.find("outside the log"), std::string::npos) << out;
  EXPECT_NE(out.find("NOT SAWN: "), std::string::npos) << out;
  for (const char* f : {"scan/log.json", "run.json", "report/report.pdf", "report/report.html"})
    EXPECT_TRUE(fs::exists(dir / "out" / f)) << f;
  EXPECT_FALSE(fs::exists(dir / "out" / "sawing.json"));
  const Json run = read_json(dir / "out" / "run.json");
  ASSERT_FALSE(run.is_discarded());
  EXPECT_EQ(run["outcome"], "not sawn") << run.dump(1);
  EXPECT_NE(run["not_sawn"]["reason"].get<std::string>().find("--position"), std::string::npos)
      << run.dump(1);
  const std::string html = report_html(dir / "out");
  EXPECT_NE(html.find("give a position or offsets within its wood"), std::string::npos);
  EXPECT_EQ(html.find("choose a pattern for smaller logs"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "logs.sqlite"));
}

TEST(RunCli, APatternThatDoesNotFitWritesTheScanAndAReportAndExitsFour) {
  const fs::path ct = small_ct();
  ASSERT_FALSE(ct.empty());
  test::TempDir dir;
  const fs::path pattern = dir / "huge.json";
  test::write_file(pattern, R"({"format": "sawyer-pattern/1", "name": "huge",
    "boards": [
      {"name": "1", "u_mm": -101.5, "v_mm": 0, "thickness_mm": 200, "width_mm": 400},
      {"name": "2", "u_mm": 101.5, "v_mm": 0, "thickness_mm": 200, "width_mm": 400}]})");
  std::string out;
  const int rc = test::run_sawyer("run " + test::quoted(ct) + " -o " + test::quoted(dir / "out") +
                                      " --pattern " + test::quoted(pattern) + " --db " +
                                      test::quoted(dir / "logs.sqlite") + " --id g40 -q",
                                  &out);
  ASSERT_EQ(rc, 4) << out;
  // One line on stderr says why (test::run_sawyer merges stderr into `out`).
  EXPECT_NE(out.find("sawyer: log 'g40': pattern 'huge' does not fit: it needs a diameter of"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("not sawn: the scan, run.json and report are in"), std::string::npos) << out;
  EXPECT_NE(out.find("NOT SAWN: pattern 'huge' needs a diameter of"), std::string::npos) << out;
  for (const char* f : {"scan/log.json", "scan/qa/pith_track.png", "run.json", "report/report.pdf",
                        "report/report.html", "report/report.json", "report/boards.csv",
                        "report/images/top_end.png"})
    EXPECT_TRUE(fs::exists(dir / "out" / f)) << f;
  EXPECT_FALSE(fs::exists(dir / "out" / "sawing.json"));

  const Json run = read_json(dir / "out" / "run.json");
  ASSERT_FALSE(run.is_discarded());
  EXPECT_EQ(run["outcome"], "not sawn") << run.dump(1);
  ASSERT_TRUE(run.contains("not_sawn")) << run.dump(1);
  const double needed = run["not_sawn"]["needed_diameter_mm"].get<double>();
  const double usable = run["not_sawn"]["usable_diameter_mm"].get<double>();
  EXPECT_GT(needed, 500.0);
  EXPECT_GT(usable, 100.0);
  EXPECT_LT(usable, needed);
  EXPECT_NE(run["not_sawn"]["reason"].get<std::string>().find("does not fit"), std::string::npos);
  EXPECT_EQ(run["not_sawn"]["pattern"], "huge");
  EXPECT_FALSE(run.contains("position_trusted"));
  EXPECT_TRUE(run.contains("qa"));
  ASSERT_GE(run["stages"].size(), 2u);
  EXPECT_EQ(run["stages"][0]["name"], "scan");
  const Json log = read_json(dir / "out" / "scan" / "log.json");
  ASSERT_FALSE(log.is_discarded());
  EXPECT_FALSE(log["knots"].empty());
  // No position, no value: the register has no row for it (and is not made for none).
  EXPECT_FALSE(fs::exists(dir / "logs.sqlite"));

  // The report says why, with both diameters.
  const Json rep = read_json(dir / "out" / "report" / "report.json");
  ASSERT_FALSE(rep.is_discarded());
  EXPECT_EQ(rep["outcome"], "not sawn");
  EXPECT_TRUE(rep["boards"].empty());
  const std::string html = report_html(dir / "out");
  char diameters[160];
  std::snprintf(diameters, sizeof diameters, "needs a log at least %.1f mm across",
                run["not_sawn"]["needed_diameter_mm"].get<double>());
  EXPECT_NE(html.find("NOT SAWN"), std::string::npos);
  EXPECT_NE(html.find(diameters), std::string::npos) << diameters;
  std::string pdf_text;
  if (report_pdf_text(dir / "out", &pdf_text)) {
    EXPECT_NE(pdf_text.find("NOT SAWN"), std::string::npos) << pdf_text;
    char usable_text[64];
    std::snprintf(usable_text, sizeof usable_text, "%.1f mm", usable);
    EXPECT_NE(pdf_text.find(usable_text), std::string::npos) << usable_text << "\n" << pdf_text;
  }

  // `sawyer report` on the folder: the same report again.
  fs::remove_all(dir / "out" / "report");
  ASSERT_EQ(test::run_sawyer("report -q " + test::quoted(dir / "out"), &out), 0) << out;
  EXPECT_TRUE(fs::exists(dir / "out" / "report" / "report.pdf"));
  EXPECT_EQ(read_json(dir / "out" / "report" / "report.json")["outcome"], "not sawn");
}

namespace {

// A pattern set for the short test log: one class for any log, boards kept from 200 mm.
fs::path short_set(const test::TempDir& dir) {
  const fs::path p = dir / "short_set.json";
  test::write_file(p, R"({"format": "sawyer-pattern-set/1", "name": "short set",
    "classes": [{"min_diameter_mm": 100, "max_diameter_mm": 500, "patterns": [
      {"preset": "2ex", "name": "2ex 50x100 short", "centre_width_mm": 100,
       "wane": {"min_length_mm": 200, "length_step_mm": 100}},
      {"preset": "2ex", "name": "2ex 50x150 short",
       "wane": {"min_length_mm": 200, "length_step_mm": 100}},
      {"preset": "4ex", "name": "4ex 38x100 short",
       "wane": {"min_length_mm": 200, "length_step_mm": 100}}]}]})");
  return p;
}

}  // namespace

// --pattern-set: the run chooses the pattern as well as the position. The chosen pattern and the
// next best, with their values, are in sawing.json and run.json, the summary, the register's row,
// the decision line and the report (HTML and PDF).
TEST(RunCli, APatternSetChoosesThePatternAndEveryFileSaysWhich) {
  const fs::path ct = small_ct();
  ASSERT_FALSE(ct.empty());
  test::TempDir dir;
  std::string out;
  const int rc = test::run_sawyer("run " + test::quoted(ct) + " -o " + test::quoted(dir / "out") +
                                      " --pattern-set " + test::quoted(short_set(dir)) + " --db " +
                                      test::quoted(dir / "logs.sqlite") + " --id g40 -q",
                                  &out);
  ASSERT_TRUE(rc == 0 || rc == 3) << out;
  const Json saw = read_json(dir / "out" / "sawing.json");
  ASSERT_FALSE(saw.is_discarded());
  ASSERT_TRUE(saw.contains("pattern_choice")) << out;
  const Json& pc = saw["pattern_choice"];
  EXPECT_EQ(pc["set"], "short set");
  EXPECT_EQ(pc["candidates"].size(), 3u);
  const std::string chosen = pc["chosen"]["name"];
  const std::string next = pc["next_best"]["name"];
  EXPECT_EQ(saw["pattern"], chosen);
  EXPECT_NE(chosen, next);
  EXPECT_GE(pc["chosen"]["expected_value"].get<double>(),
            pc["next_best"]["expected_value"].get<double>());
  EXPECT_EQ(pc["pattern"]["name"], chosen);
  EXPECT_EQ(saw["inputs"]["pattern_set"], short_set(dir).string());
  // The chosen pattern's value is that of the boards the run lists.
  double boards_value = 0;
  for (const Json& b : saw["boards"]) boards_value += b["value"].get<double>();
  EXPECT_NEAR(pc["chosen"]["value"].get<double>(), boards_value, 1e-6);
  EXPECT_GT(boards_value, 0.0);

  const Json run = read_json(dir / "out" / "run.json");
  EXPECT_EQ(run["options"]["pattern_set"], short_set(dir).string());
  EXPECT_EQ(run["options"]["pattern"], "");
  EXPECT_EQ(run["pattern_choice"]["chosen"]["name"], chosen);
  EXPECT_EQ(run["pattern_choice"]["next_best"]["name"], next);
  EXPECT_EQ(run["pattern_choice"]["next_best"]["value"], pc["next_best"]["value"]);

  // Summary and decision line.
  EXPECT_NE(out.find("pattern '" + chosen + "' chosen from set 'short set'"), std::string::npos)
      << out;
  EXPECT_NE(out.find("next best '" + next + "'"), std::string::npos) << out;
  EXPECT_NE(out.find("pattern '" + chosen + "', position: rot"), std::string::npos) << out;
  auto reg = reg::LogRegister::open_read_only(dir / "logs.sqlite");
  ASSERT_TRUE(reg.ok()) << reg.error().message();
  auto rows = reg.value().list({});
  ASSERT_TRUE(rows.ok());
  ASSERT_EQ(rows.value().size(), 1u);
  EXPECT_EQ(rows.value()[0].pattern, chosen);

  // The report: the choice in its sawing table, the boards sawn again with the chosen pattern.
  const std::string html = report_html(dir / "out");
  EXPECT_NE(html.find("chosen from set 'short set'"), std::string::npos);
  const Json rep = read_json(dir / "out" / "report" / "report.json");
  EXPECT_EQ(rep["sawing"]["pattern_choice"]["chosen"]["name"], chosen);
  EXPECT_EQ(rep["sawing"]["pattern_choice"]["next_best"]["name"], next);
  std::string pdf;
  if (report_pdf_text(dir / "out", &pdf, 1)) {
    EXPECT_NE(pdf.find("Pattern choice"), std::string::npos) << pdf;
    EXPECT_NE(pdf.find("next best"), std::string::npos) << pdf;
  }
}

// A log that no pattern of the set fits is not sawn, as one pattern too large: the scan, run.json
// and a report that say why (naming the set and its smallest candidate), exit 4.
TEST(RunCli, APatternSetThatFitsNothingWritesTheScanAndAReportAndExitsFour) {
  const fs::path ct = small_ct();
  ASSERT_FALSE(ct.empty());
  test::TempDir dir;
  const fs::path set = dir / "huge_set.json";
  test::write_file(set, R"({"format": "sawyer-pattern-set/1", "name": "huge set",
    "classes": [{"min_diameter_mm": 50, "max_diameter_mm": 1000, "patterns": [
      {"name": "huge", "boards": [
        {"name": "1", "u_mm": -101.5, "v_mm": 0, "thickness_mm": 200, "width_mm": 400},
        {"name": "2", "u_mm": 101.5, "v_mm": 0, "thickness_mm": 200, "width_mm": 400}]},
      {"preset": "4ex", "centre_thickness_mm": 150, "centre_width_mm": 300}]}]})");
  std::string out;
  const int rc = test::run_sawyer("run " + test::quoted(ct) + " -o " + test::quoted(dir / "out") +
                                      " --pattern-set " + test::quoted(set) + " --db " +
                                      test::quoted(dir / "logs.sqlite") + " --id g40 -q",
                                  &out);
  ASSERT_EQ(rc, 4) << out;
  EXPECT_NE(out.find("sawyer: log 'g40': no pattern of pattern set 'huge set' fits: the smallest "
                     "of its candidates for class 50-1000 mm, 'huge', needs a diameter of"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("NOT SAWN: log 'g40': no pattern of pattern set 'huge set' fits"),
            std::string::npos)
      << out;
  for (const char* f : {"scan/log.json", "run.json", "report/report.pdf", "report/report.html",
                        "report/images/top_end.png"})
    EXPECT_TRUE(fs::exists(dir / "out" / f)) << f;
  EXPECT_FALSE(fs::exists(dir / "out" / "sawing.json"));
  EXPECT_FALSE(fs::exists(dir / "logs.sqlite"));
  const Json run = read_json(dir / "out" / "run.json");
  EXPECT_EQ(run["outcome"], "not sawn");
  EXPECT_EQ(run["not_sawn"]["pattern_set"], "huge set");
  EXPECT_EQ(run["not_sawn"]["pattern"], "huge");
  EXPECT_NE(run["not_sawn"]["reason"].get<std::string>().find("pattern set 'huge set'"),
            std::string::npos);
  EXPECT_GT(run["not_sawn"]["needed_diameter_mm"].get<double>(),
            run["not_sawn"]["usable_diameter_mm"].get<double>());
  const std::string html = report_html(dir / "out");
  EXPECT_NE(html.find("NOT SAWN"), std::string::npos);
  EXPECT_NE(html.find("no pattern of pattern set 'huge set' fits"), std::string::npos);
  EXPECT_NE(html.find("give a pattern set with patterns for smaller logs"), std::string::npos);
  std::string pdf;
  if (report_pdf_text(dir / "out", &pdf)) {
    EXPECT_NE(pdf.find("huge set"), std::string::npos) << pdf;
  }
}

TEST(RunCli, PatternAndPatternSetExcludeEachOther) {
  test::TempDir dir;
  std::string out;
  EXPECT_EQ(test::run_sawyer("run " + test::quoted(dir.path()) + " -o " +
                                 test::quoted(dir / "out") + " --pattern 4ex --pattern-set nordic",
                             &out),
            1);
  EXPECT_NE(out.find("--pattern: cannot be given with --pattern-set"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

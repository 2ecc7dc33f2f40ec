// The cutting report (`sawyer report`, libs/report): the PDF read back with poppler's tools, the
// HTML page decoded by headless Chromium, boards.csv and report.json against sawing.json, broken
// run folders refused without leaving a report, and board placement in the scanner frame.
//
// Needs poppler-utils and chromium (scripts/install_deps.sh); a missing tool fails the test.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "sawyer/model/log_json.h"
#include "sawyer/render/image.h"
#include "sawyer/sawing/pattern.h"
#include "sawyer/sawing/placement.h"
#include "sawyer/sawing/sawing.h"
#include "sawyer/test/test_util.h"

using namespace sawyer;
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

std::string read(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

// Runs a shell command, returns its exit code and stdout (stderr dropped).
int shell(const std::string& cmd, std::string* out) {
  FILE* pipe = popen((cmd + " 2>/dev/null").c_str(), "r");
  if (!pipe) return -1;
  char buf[4096];
  size_t n;
  out->clear();
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) out->append(buf, n);
  const int st = pclose(pipe);
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

bool have_tool(const std::string& name) {
  std::string out;
  return shell("command -v " + name, &out) == 0 && !out.empty();
}

#define REQUIRE_TOOL(name)                                                                \
  ASSERT_TRUE(have_tool(name)) << name << " is missing: run scripts/install_deps.sh (it " \
                               << "installs poppler-utils and chromium)"

// A run folder as `sawyer run` leaves it, from the bundled 4 m spruce: scan/log.json, sawing.json
// from `sawyer saw` (with `position`, "chosen": "given"), and run.json.
void make_run_folder(const fs::path& dir, const std::string& position = "") {
  fs::create_directories(dir / "scan");
  fs::copy_file(test::sample_log("gran1_spruce") / "log.json", dir / "scan" / "log.json");
  std::string out;
  const std::string pos = position.empty() ? "" : " --position " + position;
  ASSERT_EQ(test::run_sawyer("saw " + test::quoted(dir / "scan" / "log.json") + " -q" + pos +
                                 " -o " + test::quoted(dir / "sawing.json"),
                             &out),
            0)
      << out;
  if (!position.empty()) {
    Json s = Json::parse(read(dir / "sawing.json"));
    s["chosen"] = "given";
    test::write_file(dir / "sawing.json", s.dump(1));
  }
  Json run = {
      {"format", "sawyer-run/1"},
      {"log_id", "gran1_spruce"},
      {"species", "spruce"},
      {"scan_source", "/data/ct/gran1"},
      {"scan_description", "test fixture: the bundled model"},
      {"date", "2026-11-24T05:00:00Z"},
      {"sawyer_version", "test"},
      {"options",
       {{"pattern", "2ex"}, {"grading", "nordic"}, {"prices", ""}, {"position", position}}},
      {"stages", {{{"name", "scan"}, {"seconds", 1.5}}, {{"name", "saw"}, {"seconds", 0.3}}}}};
  test::write_file(dir / "run.json", run.dump(1));
}

void make_report(const fs::path& dir) {
  std::string out;
  ASSERT_EQ(test::run_sawyer("report -q " + test::quoted(dir), &out), 0) << out;
  ASSERT_TRUE(fs::exists(dir / "report" / "report.pdf")) << out;
}

// The boards at the chosen position.
const Json& chosen_boards(const Json& sawing) {
  return sawing.value("chosen", "best") == "given" ? sawing["given_position"]["boards"]
                                                   : sawing["boards"];
}

}  // namespace

TEST(Report, PdfHasPagesImagesRotationAndGrades) {
  REQUIRE_TOOL("pdfinfo");
  REQUIRE_TOOL("pdfimages");
  REQUIRE_TOOL("pdftoppm");
  REQUIRE_TOOL("pdftotext");
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  ASSERT_NO_FATAL_FAILURE(make_report(dir.path()));
  const fs::path pdf = dir / "report/report.pdf";
  const Json sawing = Json::parse(read(dir / "sawing.json"));
  const Json& boards = chosen_boards(sawing);

  std::string out;
  ASSERT_EQ(shell("pdfinfo " + test::quoted(pdf), &out), 0);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("Pages:\\s+(\\d+)"))) << out;
  EXPECT_GE(std::stoi(m[1]), 2);

  // pdfimages -list: two header lines, then one line per image (and soft mask).
  ASSERT_EQ(shell("pdfimages -list " + test::quoted(pdf), &out), 0);
  int images = 0;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);)
    if (std::regex_search(line, std::regex("^\\s*\\d+\\s+\\d+\\s+image"))) ++images;
  EXPECT_GE(images, 3 + static_cast<int>(boards.size())) << out;

  ASSERT_EQ(
      shell("pdftoppm -r 40 -png -f 1 -l 1 " + test::quoted(pdf) + " " + test::quoted(dir / "page"),
            &out),
      0);
  fs::path page;
  for (const auto& e : fs::directory_iterator(dir.path()))
    if (e.path().filename().string().rfind("page", 0) == 0) page = e.path();
  ASSERT_FALSE(page.empty()) << "pdftoppm wrote no page image";
  Result<render::Image> img = render::read_image(page);
  ASSERT_TRUE(img.ok()) << img.error().message();
  // Non-blank: a fair share of the page is neither white nor one flat colour.
  int dark = 0;
  for (int y = 0; y < img.value().height; ++y)
    for (int x = 0; x < img.value().width; ++x)
      dark += img.value().value(x, y, 0) + img.value().value(x, y, 1) < 1.6f;
  EXPECT_GT(dark, img.value().width * img.value().height / 50);

  ASSERT_EQ(shell("pdftotext -layout " + test::quoted(pdf) + " -", &out), 0);
  EXPECT_NE(out.find("gran1_spruce"), std::string::npos);
  char rot[32];
  std::snprintf(rot, sizeof rot, "%.1f°", sawing["best"]["rotation_deg"].get<double>());
  EXPECT_NE(out.find(rot), std::string::npos) << "rotation " << rot << " not in\n" << out;
  for (const Json& b : boards) {
    const std::string grade = b["grade"];
    EXPECT_TRUE(std::regex_search(out, std::regex("\\b" + grade + "\\b"))) << grade;
  }
  // The bundled model has no scanner frame, and the report says so (issue 19).
  EXPECT_NE(out.find("log model (no scanner frame)"), std::string::npos) << out;
}

TEST(Report, HtmlIsSelfContainedAndEveryImageDecodesInChromium) {
  REQUIRE_TOOL("chromium");
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  ASSERT_NO_FATAL_FAILURE(make_report(dir.path()));
  std::string html = read(dir / "report/report.html");
  EXPECT_NE(html.find("<th>Frame</th><td>log model (no scanner frame)</td>"), std::string::npos);
  EXPECT_EQ(html.find("http://"), std::string::npos);
  EXPECT_EQ(html.find("https://"), std::string::npos);
  const Json sawing = Json::parse(read(dir / "sawing.json"));
  // End view, 3D view, value map, log profile and one image per board.
  const size_t expected = 4 + chosen_boards(sawing).size();

  // A copy with a script that writes, on load, each image's state into the DOM.
  html +=
      "<script>window.addEventListener('load', function () {"
      "  var out = [];"
      "  for (var i = 0; i < document.images.length; ++i)"
      "    out.push(document.images[i].complete + ':' + document.images[i].naturalWidth);"
      "  var p = document.createElement('pre'); p.id = 'imgcheck';"
      "  p.textContent = 'IMGCHECK[' + out.join(',') + ']'; document.body.appendChild(p);"
      "});</script>\n";
  test::TempDir view;
  test::write_file(view / "page.html", html);
  std::string dom;
  shell(
      "timeout 120 chromium --headless --no-sandbox --disable-gpu --no-first-run "
      "--user-data-dir=" +
          test::quoted(view / "profile") + " --virtual-time-budget=10000 --dump-dom " +
          test::quoted("file://" + (view / "page.html").string()),
      &dom);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(dom, m, std::regex("id=\"imgcheck\">IMGCHECK\\[([^\\]]*)\\]")))
      << "chromium gave no result; its DOM begins:\n"
      << dom.substr(0, 400);
  std::vector<std::string> states;
  std::istringstream items(m[1].str());
  for (std::string s; std::getline(items, s, ',');) states.push_back(s);
  EXPECT_EQ(states.size(), expected);
  for (size_t i = 0; i < states.size(); ++i) {
    EXPECT_EQ(states[i].rfind("true:", 0), 0u) << "image " << i << ": " << states[i];
    EXPECT_GT(std::atoi(states[i].c_str() + states[i].find(':') + 1), 0)
        << "image " << i << " did not decode: " << states[i];
  }
}

TEST(Report, CsvAndJsonAgreeWithSawingJson) {
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  ASSERT_NO_FATAL_FAILURE(make_report(dir.path()));
  const Json sawing = Json::parse(read(dir / "sawing.json"));
  const Json& boards = chosen_boards(sawing);
  double total = 0;
  for (const Json& b : boards) total += b["value"].get<double>();

  const Json rep = Json::parse(read(dir / "report/report.json"));
  EXPECT_EQ(rep["format"], "sawyer-report/1");
  EXPECT_EQ(rep["log"]["id"], "gran1_spruce");
  EXPECT_EQ(rep["chosen"], "best");
  EXPECT_EQ(rep["boards"].size(), boards.size());
  EXPECT_EQ(rep["totals"]["boards"].get<size_t>(), boards.size());
  EXPECT_NEAR(rep["totals"]["value"].get<double>(), total, 1e-6);
  EXPECT_NEAR(rep["position"]["value"].get<double>(), sawing["best"]["value"].get<double>(), 1e-6);
  EXPECT_NEAR(rep["gain_over_horns_down"].get<double>(),
              sawing["gain_over_horns_down"].get<double>(), 1e-12);
  EXPECT_TRUE(rep["boards_rebuilt"].get<bool>()) << rep["boards_note"];
  const double yield = rep["totals"]["volume_yield"];
  EXPECT_GT(yield, 0.1);
  EXPECT_LT(yield, 1.0);
  for (const Json& img : rep["images"])
    EXPECT_TRUE(fs::exists(dir / "report" / img.get<std::string>()));

  // boards.csv: a header and one line per board; the value column sums to the same total.
  std::istringstream csv(read(dir / "report/boards.csv"));
  std::string header;
  std::getline(csv, header);
  ASSERT_EQ(header.rfind("board,name,", 0), 0u) << header;
  size_t rows = 0;
  double csv_total = 0;
  for (std::string line; std::getline(csv, line); ++rows) {
    // value is the 12th column; limited_by (10th) may be quoted and hold commas.
    std::vector<std::string> cells;
    std::string cell;
    bool quoted = false;
    for (char ch : line) {
      if (ch == '"')
        quoted = !quoted;
      else if (ch == ',' && !quoted)
        cells.push_back(std::exchange(cell, ""));
      else
        cell += ch;
    }
    cells.push_back(cell);
    ASSERT_EQ(cells.size(), 15u) << line;
    EXPECT_EQ(cells[1], boards[rows]["name"]);
    EXPECT_EQ(cells[8], boards[rows]["grade"]);
    csv_total += std::stod(cells[11]);
  }
  EXPECT_EQ(rows, boards.size());
  EXPECT_NEAR(csv_total, total, 1e-6 * boards.size() + 1e-6);
}

// A log scanned from CT (issue 19): its scanner_frame reaches sawing.json's frame with the
// scan's origin, and the PDF and the HTML page state the frame and the scanner z of z = 0.
TEST(Report, StatesTheScannerFrameOfTheScan) {
  REQUIRE_TOOL("pdftotext");
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  Json log = Json::parse(read(dir / "scan" / "log.json"));
  log["scanner_frame"] = {{"origin_mm", {-191.4, 87.5, 1234.5}},
                          {"row_dir", {1, 0, 0}},
                          {"col_dir", {0, 1, 0}},
                          {"z0_mm", 1234.5},
                          {"z_dir", 1}};
  test::write_file(dir / "scan" / "log.json", log.dump(1));
  std::string out;
  ASSERT_EQ(test::run_sawyer("saw " + test::quoted(dir / "scan" / "log.json") + " -q -o " +
                                 test::quoted(dir / "sawing.json"),
                             &out),
            0)
      << out;
  const Json sawing = Json::parse(read(dir / "sawing.json"));
  EXPECT_EQ(sawing["frame"]["coordinates"], "scanner");
  EXPECT_EQ(sawing["frame"]["scanner_frame"]["origin_mm"], Json({-191.4, 87.5, 1234.5}));
  EXPECT_EQ(sawing["frame"]["scanner_frame"]["z0_mm"], 1234.5);
  // Every position states its saw set-up in the scanner frame: the pattern centre at the log's
  // two ends, at the scanner z of the log's first and last slab edges.
  const Json& sc = sawing["best"]["scanner"];
  ASSERT_EQ(sc["pattern_centre_at_ends_mm"].size(), 2u);
  const double z0 = log["stem"]["z0_mm"].get<double>(), dz = log["stem"]["dz_mm"].get<double>();
  EXPECT_NEAR(sc["pattern_centre_at_ends_mm"][0][2].get<double>(), 1234.5 + z0 - 0.5 * dz, 1e-9);
  EXPECT_GT(sc["pattern_centre_at_ends_mm"][1][2].get<double>(), 1234.5 + 3900.0);
  for (const char* key : {"horns_down", "horns_up"})
    EXPECT_TRUE(sawing[key].contains("scanner")) << key;
  EXPECT_TRUE(sawing["ranked"][0].contains("scanner"));
  EXPECT_FALSE(sawing["bow"]["straight"].get<bool>());  // gran1 bows by about 13 mm
  ASSERT_NO_FATAL_FAILURE(make_report(dir.path()));
  ASSERT_EQ(shell("pdftotext -layout " + test::quoted(dir / "report/report.pdf") + " -", &out), 0);
  EXPECT_NE(out.find("scanner x, y; z from 1234.5 mm"), std::string::npos) << out;
  EXPECT_EQ(out.find("no scanner frame"), std::string::npos) << out;
  EXPECT_NE(read(dir / "report/report.html")
                .find("<th>Frame</th><td>scanner x, y; z from 1234.5 mm</td>"),
            std::string::npos);
  char turn[64];
  std::snprintf(turn, sizeof turn, "turn %+.1f° from the scan", sc["turn_deg"].get<double>());
  EXPECT_NE(read(dir / "report/report.html").find(std::string("<th>Saw set-up</th><td>") + turn),
            std::string::npos)
      << turn;
  const Json rep = Json::parse(read(dir / "report/report.json"));
  EXPECT_NEAR(rep["position"]["scanner"]["turn_deg"].get<double>(), sc["turn_deg"].get<double>(),
              1e-9);
}

// A log from a scan, sawn with draws of its scan uncertainty (issue 43, item 2): the report
// states the held-out claim with its range as sawing.json has it, and every knot that decides a
// grade carries how sure its fit is that it is a knot (Knot::confidence of the log's knot).
TEST(Report, AScannedLogsClaimHasItsRangeAndItsLimitingKnotsTheirConfidence) {
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  {  // Plain: a model without a scan verdict has no claim range and no knot confidence.
    ASSERT_NO_FATAL_FAILURE(make_report(dir.path()));
    const Json rep = Json::parse(read(dir / "report/report.json"));
    EXPECT_FALSE(rep.contains("claim"));
    for (const Json& b : rep["boards"])
      for (const Json& k : b["limiting_knots"]) EXPECT_FALSE(k.contains("confidence"));
  }
  Json log = Json::parse(read(dir / "scan" / "log.json"));
  log["qa"] = {{"trusted", true}, {"scan_class", "fine"}, {"warnings", Json::array()}};
  for (size_t i = 0; i < log["knots"].size(); ++i) {  // fits from good to ragged
    log["knots"][i]["fit_rms_mm"] = 0.3 + 0.5 * static_cast<double>(i % 5);
    log["knots"][i]["support"] = 20 + 15 * static_cast<int>(i % 4);
  }
  test::write_file(dir / "scan" / "log.json", log.dump(1));
  std::string out;
  ASSERT_EQ(test::run_sawyer("saw " + test::quoted(dir / "scan" / "log.json") +
                                 " -q --scan-draws 4 -o " + test::quoted(dir / "sawing.json"),
                             &out),
            0)
      << out;
  const Json sawing = Json::parse(read(dir / "sawing.json"));
  ASSERT_TRUE(sawing.contains("claim")) << sawing.dump(1).substr(0, 400);
  ASSERT_NO_FATAL_FAILURE(make_report(dir.path()));
  const Json rep = Json::parse(read(dir / "report/report.json"));
  ASSERT_TRUE(rep.contains("claim"));
  EXPECT_EQ(rep["claim"]["low"], sawing["claim"]["low"]);
  EXPECT_EQ(rep["claim"]["high"], sawing["claim"]["high"]);
  EXPECT_LE(rep["claim"]["low"].get<double>(), rep["claim"]["gain_over_horns_down"].get<double>());
  const std::string line = rep["claim"]["line"];
  EXPECT_NE(line.find("90 % range"), std::string::npos) << line;
  EXPECT_NE(read(dir / "report/report.html").find("<th>Claim</th><td>" + line), std::string::npos)
      << line;
  // The knots that decide grades, each with its own fit's confidence.
  Result<LogModel> model = read_log_json(dir / "scan" / "log.json");
  ASSERT_TRUE(model.ok()) << model.error().message();
  int listed = 0;
  for (const Json& b : rep["boards"])
    for (const Json& k : b["limiting_knots"]) {
      ASSERT_TRUE(k.contains("confidence")) << k.dump();
      const int id = k["knot"];
      for (const Knot& kn : model.value().knots)
        if (kn.id == id) EXPECT_NEAR(k["confidence"].get<double>(), kn.confidence(), 1e-12);
      char sure[48];
      std::snprintf(sure, sizeof sure, "%.0f %% sure it is a knot",
                    100 * k["confidence"].get<double>());
      EXPECT_NE(k["text"].get<std::string>().find(sure), std::string::npos) << k["text"];
      ++listed;
    }
  EXPECT_GT(listed, 0) << "no limiting knot on gran1's boards";
}

// Issue 44: the header's line (the run's date, the scan's description, the version) ran off the
// right edge of page 1. With a long description and a long log id, every word of the PDF lies
// inside the page's margins, the description is wrapped (at most three lines, then cut with
// "…"), and the id is still there.
TEST(Report, HeaderStaysInsideThePageWithALongDescriptionAndLogId) {
  REQUIRE_TOOL("pdftotext");
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  const std::string id = "gran1_spruce_from_the_yard_of_the_northern_mill_log_number_000123";
  for (const auto& [file, key] : {std::pair{"scan/log.json", "id"}, std::pair{"sawing.json", "log"},
                                  std::pair{"run.json", "log_id"}}) {
    Json j = Json::parse(read(dir / file));
    j[key] = id;
    if (std::string(file) == "run.json") {
      std::string d = "CT \"Microtec CT.LOG\" series 3 of study 1.2.840.113619.2.55.3.604688119.";
      for (int i = 0; i < 40; ++i) d += " word" + std::to_string(i);
      d += " reconstructed with the bone kernel at 0.8 mm";
      j["scan_description"] = d;
    }
    test::write_file(dir / file, j.dump(1));
  }
  ASSERT_NO_FATAL_FAILURE(make_report(dir.path()));
  std::string out;
  ASSERT_EQ(shell("pdftotext -bbox " + test::quoted(dir / "report/report.pdf") + " -", &out), 0);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex("<page width=\"([0-9.]+)\""))) << out;
  const double width = std::stod(m[1]);
  const std::regex word(
      "<word xMin=\"([0-9.]+)\" yMin=\"([0-9.]+)\" xMax=\"([0-9.]+)\"[^>]*>([^<]*)</word>");
  int words = 0;
  std::string page1;
  const size_t page2 = out.find("<page", out.find("<page") + 1);
  for (auto it = std::sregex_iterator(out.begin(), out.end(), word); it != std::sregex_iterator();
       ++it) {
    const double x0 = std::stod((*it)[1]), x1 = std::stod((*it)[3]);
    ++words;
    EXPECT_GE(x0, 30.0) << (*it)[4];
    EXPECT_LE(x1, width - 30.0) << "'" << (*it)[4] << "' runs off the page (" << x1 << " of "
                                << width << ")";
    if (static_cast<size_t>(it->position()) < page2) page1 += std::string((*it)[4]) + " ";
  }
  EXPECT_GT(words, 100);
  EXPECT_NE(page1.find("Microtec"), std::string::npos) << page1;
  EXPECT_NE(page1.find("word10"), std::string::npos) << "wrapped onto a second line: " << page1;
  EXPECT_EQ(page1.find("kernel"), std::string::npos) << "cut after three lines: " << page1;
  EXPECT_NE(page1.find("\u2026"), std::string::npos) << page1;
  EXPECT_NE(page1.find("log_number"), std::string::npos) << "the id, whole or shortened";
}

// A saw set-up that is not two [x, y, z] points is refused, naming the key.
TEST(Report, BrokenSawSetUpIsNamedAndNoReportIsLeft) {
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  Json s = Json::parse(read(dir / "sawing.json"));
  s["best"]["scanner"]["pattern_centre_at_ends_mm"] = Json::array({Json::array({1.0, 2.0})});
  test::write_file(dir / "sawing.json", s.dump());
  std::string out;
  EXPECT_EQ(test::run_sawyer("report -q " + test::quoted(dir.path()), &out), 1);
  EXPECT_NE(out.find("best.scanner.pattern_centre_at_ends_mm"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir / "report"));
}

TEST(Report, GivenPositionIsTheOneReported) {
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path(), "30,4,0"));
  ASSERT_NO_FATAL_FAILURE(make_report(dir.path()));
  const Json sawing = Json::parse(read(dir / "sawing.json"));
  const Json rep = Json::parse(read(dir / "report/report.json"));
  EXPECT_EQ(rep["chosen"], "given");
  EXPECT_DOUBLE_EQ(rep["position"]["rotation_deg"].get<double>(), 30.0);
  EXPECT_DOUBLE_EQ(rep["position"]["offset_x_mm"].get<double>(), 4.0);
  EXPECT_NEAR(rep["position"]["value"].get<double>(),
              sawing["given_position"]["value"].get<double>(), 1e-9);
  EXPECT_EQ(rep["boards"].size(), sawing["given_position"]["boards"].size());
  EXPECT_TRUE(rep["boards_rebuilt"].get<bool>()) << rep["boards_note"];
}

TEST(Report, BoardsComeFromSawingJsonWhenThePatternFileHasMoved) {
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  Json run = Json::parse(read(dir / "run.json"));
  run["options"]["pattern"] = (dir / "moved.pattern.json").string();
  test::write_file(dir / "run.json", run.dump());
  ASSERT_NO_FATAL_FAILURE(make_report(dir.path()));
  const Json rep = Json::parse(read(dir / "report/report.json"));
  EXPECT_FALSE(rep["boards_rebuilt"].get<bool>());
  EXPECT_NE(rep["boards_note"].get<std::string>().find("moved.pattern.json"), std::string::npos)
      << rep["boards_note"];
  const Json sawing = Json::parse(read(dir / "sawing.json"));
  EXPECT_EQ(rep["boards"].size(), chosen_boards(sawing).size());
  EXPECT_TRUE(fs::exists(dir / "report/images/board_01.png"));
}

TEST(Report, MissingSawingJsonIsNamedAndNoReportIsLeft) {
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  fs::remove(dir / "sawing.json");
  std::string out;
  EXPECT_EQ(test::run_sawyer("report -q " + test::quoted(dir.path()), &out), 1);
  EXPECT_NE(out.find("sawing.json"), std::string::npos) << out;
  EXPECT_NE(out.find("missing"), std::string::npos) << out;
  EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
  EXPECT_FALSE(fs::exists(dir / "report"));
}

TEST(Report, CorruptJsonIsNamedAndNoReportIsLeft) {
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  for (const char* name : {"sawing.json", "run.json"}) {
    const std::string good = read(dir / name);
    test::write_file(dir / name, good.substr(0, good.size() / 2));
    std::string out;
    EXPECT_EQ(test::run_sawyer("report -q " + test::quoted(dir.path()), &out), 1);
    EXPECT_NE(out.find(name), std::string::npos) << out;
    EXPECT_NE(out.find("not valid JSON"), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(dir / "report"));
    test::write_file(dir / name, good);
  }
  // A log.json that does not parse names itself too.
  test::write_file(dir / "scan/log.json", "{\"format\": \"sawyer-log/1\"");
  std::string out;
  EXPECT_EQ(test::run_sawyer("report -q " + test::quoted(dir.path()), &out), 1);
  EXPECT_NE(out.find("log.json"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir / "report"));
}

TEST(Report, LogIdMismatchIsNamedAndNoReportIsLeft) {
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  Json s = Json::parse(read(dir / "sawing.json"));
  s["log"] = "another_log";
  test::write_file(dir / "sawing.json", s.dump());
  std::string out;
  EXPECT_EQ(test::run_sawyer("report -q " + test::quoted(dir.path()), &out), 1);
  EXPECT_NE(out.find("sawing.json"), std::string::npos) << out;
  EXPECT_NE(out.find("another_log"), std::string::npos) << out;
  EXPECT_NE(out.find("gran1_spruce"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir / "report"));
}

TEST(Report, ExistingReportIsReplacedWholeOnlyOnSuccess) {
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  test::write_file(dir / "report/old.txt", "an old report");
  // A failure (a broken sawing.json) leaves the old report as it was.
  const std::string good = read(dir / "sawing.json");
  test::write_file(dir / "sawing.json", "[]");
  std::string out;
  EXPECT_EQ(test::run_sawyer("report -q " + test::quoted(dir.path()), &out), 1);
  EXPECT_TRUE(fs::exists(dir / "report/old.txt"));
  EXPECT_FALSE(fs::exists(dir / "report/report.pdf"));
  // Success replaces it whole.
  test::write_file(dir / "sawing.json", good);
  ASSERT_NO_FATAL_FAILURE(make_report(dir.path()));
  EXPECT_FALSE(fs::exists(dir / "report/old.txt"));
  for (const char* f : {"report.pdf", "report.html", "boards.csv", "report.json",
                        "images/end_view.png", "images/board_01.png"})
    EXPECT_TRUE(fs::exists(dir / "report" / f)) << f;
  for (const auto& e : fs::directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

TEST(BoardPlacement, MapsBackToThePatternFrame) {
  const LogModel& model = test::sample_model("gran1_spruce");
  const sawing::SawLog log(model);
  const sawing::LogPosition pos{37.0, 6.0, -3.0};
  const sawing::SawResult r = sawing::saw(log, sawing::two_ex_pattern({}), pos);
  ASSERT_FALSE(r.boards.empty());
  const double phi = sawing::pattern_rotation(log, pos);
  for (const sawing::Board& b : r.boards) {
    const BoardBox p = sawing::board_placement(log, b, pos);
    // The centre, turned back into the pattern frame, is the board's (u, v).
    const Vec2 o = log.line_at(0.5 * (p.z0 + p.z1));
    const double dx = p.cx - o.x, dy = p.cy - o.y;
    EXPECT_NEAR(std::cos(phi) * dx - std::sin(phi) * dy - pos.offset_x_mm, b.u_mm, 1e-9);
    EXPECT_NEAR(std::sin(phi) * dx + std::cos(phi) * dy - pos.offset_y_mm, b.v_mm, 1e-9);
    // The width runs along pattern v for a board whose thickness runs along u, else along u.
    const Vec2 wdir{std::cos(p.rotation), std::sin(p.rotation)};
    const double wu = std::cos(phi) * wdir.x - std::sin(phi) * wdir.y;
    EXPECT_NEAR(std::abs(wu), b.thickness_axis == sawing::ThicknessAxis::kU ? 0.0 : 1.0, 1e-9);
    EXPECT_EQ(p.width, b.width_mm);
    EXPECT_EQ(p.thickness, b.thickness_mm);
    EXPECT_EQ(p.z0, b.z_begin);
  }
}

// A board cross-cut to value (sawing.json "offcuts_mm") shows its offcuts in the board table;
// a broken offcut list is refused, naming the key.
TEST(Report, ShowsTheOffcutsOfACrossCutBoard) {
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  Json s = Json::parse(read(dir / "sawing.json"));
  Json& b = s["boards"][0];
  const double z0 = b["z_begin_mm"].get<double>(), z1 = b["z_end_mm"].get<double>();
  b["z_begin_mm"] = z0 + 600.0;
  b["offcuts_mm"] = {600.0, 0.0};
  test::write_file(dir / "sawing.json", s.dump());
  ASSERT_NO_FATAL_FAILURE(make_report(dir.path()));
  char want[96];
  std::snprintf(want, sizeof want, "cross-cut from %.2f m: 0.60 m off at z %.2f m",
                (z1 - z0) * 1e-3, z0 * 1e-3);
  EXPECT_NE(read(dir / "report/report.html").find(want), std::string::npos) << want;

  b["offcuts_mm"] = {600.0};
  test::write_file(dir / "sawing.json", s.dump());
  std::string out;
  EXPECT_EQ(test::run_sawyer("report -q " + test::quoted(dir.path()), &out), 1);
  EXPECT_NE(out.find("boards[0].offcuts_mm"), std::string::npos) << out;
}

namespace {

// ReportOptions::board_detail_px_per_cm's default.
constexpr double kDetailPxPerCm = 8.0;

// A board of report.json with knots that decide its grade: its number (1-based), else 0.
int board_with_limiting_knots(const Json& rep) {
  for (size_t i = 0; i < rep["boards"].size(); ++i)
    if (!rep["boards"][i]["limiting_knots"].empty()) return static_cast<int>(i) + 1;
  return 0;
}

// Headless Chromium on `url` in a window of w x h: its DOM after the page's scripts ran, or a
// screenshot written to `png`. (A DOM dump's viewport is the window less the browser's bars, a
// screenshot's the whole window.)
std::string chromium(const fs::path& profile, const std::string& url, int w, int h,
                     const std::string& what) {
  std::string out;
  shell(
      "timeout 120 chromium --headless --no-sandbox --disable-gpu --no-first-run "
      "--user-data-dir=" +
          test::quoted(profile) + " --window-size=" + std::to_string(w) + "," + std::to_string(h) +
          " --force-device-scale-factor=1 --hide-scrollbars --virtual-time-budget=5000 " + what +
          " " + test::quoted(url),
      &out);
  return out;
}

// data-view="left,top,scale,width,height" of board `board`'s viewer in a DOM dump.
bool view_of(const std::string& dom, int board, double v[5]) {
  std::smatch m;
  const std::string num = "([-0-9.e]+)";
  const std::regex re("<div class=\"zoom[^\"]*\" data-board=\"" + std::to_string(board) +
                      "\"[^>]*data-view=\"" + num + "," + num + "," + num + "," + num + "," + num +
                      "\"");
  if (!std::regex_search(dom, m, re)) return false;
  for (int i = 0; i < 5; ++i) v[i] = std::stod(m[i + 1]);
  return true;
}

// Mean absolute difference (0..255, RGB) between the screenshot and the face image seen
// through view (left, top, scale), over the screenshot's pixels in [x0, x1) × [y0, y1) that
// map inside the image.
double view_difference(const render::Image& shot, const render::Image& face, const double v[3],
                       int x0, int x1, int y0, int y1, int* samples) {
  double sum = 0;
  int n = 0;
  for (int y = y0; y < y1; y += 3)
    for (int x = x0; x < x1; x += 3) {
      const int u = static_cast<int>(std::floor((x + 0.5 - v[0]) / v[2]));
      const int w = static_cast<int>(std::floor((y + 0.5 - v[1]) / v[2]));
      if (u < 0 || w < 0 || u >= face.width || w >= face.height) continue;
      for (int c = 0; c < 3; ++c)
        sum += 255.0 * std::abs(shot.value(x, y, c) - face.value(u, w, c));
      ++n;
    }
  *samples = n;
  return n ? sum / (3.0 * n) : 1e9;
}

}  // namespace

// The HTML page's board faces at full resolution with pan and zoom in the page: the hash opens a
// board zoomed on a knot that decides its grade; Chromium's screenshot then shows the face image
// pixel for pixel as the viewer says it placed it, unlike the whole-board view; the knot's ring
// carries its description.
TEST(Report, HtmlZoomShowsTheFacesAtFullResolutionAndNamesTheLimitingKnots) {
  REQUIRE_TOOL("chromium");
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  ASSERT_NO_FATAL_FAILURE(make_report(dir.path()));
  const Json rep = Json::parse(read(dir / "report/report.json"));
  const int board = board_with_limiting_knots(rep);
  ASSERT_GT(board, 0) << "no board of gran1 has a limiting knot: " << rep["boards"].dump(1);
  const Json& knot = rep["boards"][board - 1]["limiting_knots"][0];
  const int knot_id = knot["knot"];
  char name[64];
  std::snprintf(name, sizeof name, "board_%02d_faces.jpg", board);
  Result<render::Image> face = render::read_image(dir / "report/images" / name);
  ASSERT_TRUE(face.ok()) << face.error().message();
  // The detail resolution along the board (plus its label column), several times the PDF's.
  const double length_mm = rep["boards"][board - 1]["length_mm"];
  const double px_per_mm = kDetailPxPerCm / 10.0;
  EXPECT_GT(face.value().width, px_per_mm * length_mm);
  EXPECT_LT(face.value().width, px_per_mm * length_mm + 400);

  const std::string html = read(dir / "report/report.html");
  EXPECT_EQ(html.find("http://"), std::string::npos);
  EXPECT_EQ(html.find("https://"), std::string::npos);
  // The ring of the knot, with its description as the tooltip, and a link that opens it.
  const std::string text = knot["text"];
  EXPECT_NE(html.find("data-knot=\"" + std::to_string(knot_id) + "\""), std::string::npos);
  EXPECT_NE(html.find("<title>" + text + "</title>"), std::string::npos) << text;
  EXPECT_NE(html.find("href=\"#board=" + std::to_string(board) +
                      "&amp;zoom=6&amp;knot=" + std::to_string(knot_id) + "\""),
            std::string::npos);

  const std::string page = "file://" + (dir / "report/report.html").string();
  const std::string fit = page + "#board=" + std::to_string(board) + "&zoom=1";
  const std::string zoomed =
      page + "#board=" + std::to_string(board) + "&zoom=6&knot=" + std::to_string(knot_id);
  double vzoom[5];
  const std::string dom_zoom = chromium(dir / "profile", zoomed, 1200, 800, "--dump-dom");
  ASSERT_TRUE(view_of(dom_zoom, board, vzoom)) << dom_zoom.substr(0, 600);
  // The screenshots in a window of the viewport the view was laid out in.
  const int vw = static_cast<int>(vzoom[3]), vh = static_cast<int>(vzoom[4]);
  ASSERT_GT(vh, 200);
  EXPECT_GE(vzoom[2], 1.0);  // image pixels at least screen pixels: full detail
  // The knot in the middle of the window (or as near as the board's edge allows).
  const double kx = (0.5 * vw - vzoom[0]) / vzoom[2];
  EXPECT_NEAR(kx, knot["along_mm"].get<double>() * px_per_mm + 84 * kDetailPxPerCm / 3, 700);

  chromium(dir / "profile", fit, vw, vh, "--screenshot=" + test::quoted(dir / "fit.png"));
  chromium(dir / "profile", zoomed, vw, vh, "--screenshot=" + test::quoted(dir / "zoom.png"));
  Result<render::Image> shot_fit = render::read_image(dir / "fit.png");
  Result<render::Image> shot_zoom = render::read_image(dir / "zoom.png");
  ASSERT_TRUE(shot_fit.ok()) << shot_fit.error().message();
  ASSERT_TRUE(shot_zoom.ok()) << shot_zoom.error().message();
  const render::Image& a = shot_fit.value();
  const render::Image& b = shot_zoom.value();
  ASSERT_EQ(a.width, vw);
  ASSERT_EQ(a.height, vh);
  ASSERT_EQ(b.width, vw);
  ASSERT_EQ(b.height, vh);
  // The zoom changes what is shown: most of the window differs.
  int differ = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      double d = 0;
      for (int c = 0; c < 3; ++c) d += std::abs(a.value(x, y, c) - b.value(x, y, c));
      differ += d > 0.1;
    }
  EXPECT_GT(differ, a.width * a.height / 3);
  // What the zoomed window shows is the face image where the viewer placed it (JPEG and
  // resampling aside), and not what another placement would show.
  int n = 0, n_other = 0;
  const double here = view_difference(b, face.value(), vzoom, 0, b.width, 60, b.height, &n);
  const double other_view[3] = {vzoom[0] + 97, vzoom[1] + 31, vzoom[2]};  // shifted
  const double other =
      view_difference(b, face.value(), other_view, 0, b.width, 60, b.height, &n_other);
  EXPECT_GT(n, 20000);
  EXPECT_LT(here, 10.0);
  EXPECT_GT(other, 2 * here);
  std::printf("zoomed view against the face image: %.2f levels (shifted: %.2f) over %d pixels\n",
              here, other, n);
}

// The PDF's page of decisions: a crop of the faces around each of the (at most four) largest
// limiting knots of each board, captioned with the knot's description.
TEST(Report, PdfShowsWhereTheGradesAreDecided) {
  REQUIRE_TOOL("pdftotext");
  REQUIRE_TOOL("pdfimages");
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  ASSERT_NO_FATAL_FAILURE(make_report(dir.path()));
  const Json rep = Json::parse(read(dir / "report/report.json"));
  ASSERT_GT(board_with_limiting_knots(rep), 0);
  const fs::path pdf = dir / "report/report.pdf";
  std::string out;
  ASSERT_EQ(shell("pdftotext -raw " + test::quoted(pdf) + " -", &out), 0);
  auto squeeze = [](std::string s) {
    s.erase(std::remove_if(s.begin(), s.end(), [](unsigned char ch) { return std::isspace(ch); }),
            s.end());
    return s;
  };
  const std::string text = squeeze(out);
  EXPECT_NE(text.find(squeeze("Where the grades are decided")), std::string::npos);
  size_t crops = 0;
  for (const Json& b : rep["boards"]) {
    const Json& lim = b["limiting_knots"];
    for (size_t k = 0; k < lim.size() && k < 4; ++k) {
      EXPECT_NE(text.find(squeeze(lim[k]["text"])), std::string::npos) << lim[k]["text"];
      ++crops;
    }
  }
  // Their images: one file each, and in the PDF beside the other figures.
  size_t crop_files = 0;
  for (const Json& img : rep["images"])
    crop_files += img.get<std::string>().find("_knot_") != std::string::npos;
  EXPECT_EQ(crop_files, crops);
  ASSERT_EQ(shell("pdfimages -list " + test::quoted(pdf), &out), 0);
  size_t images = 0;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);)
    if (std::regex_search(line, std::regex("^\\s*\\d+\\s+\\d+\\s+image"))) ++images;
  EXPECT_GE(images, 3 + rep["boards"].size() + crops) << out;
}

// The detail options out of range: one line naming the option's meaning, exit 1, no report.
TEST(Report, BadDetailOptionsAreNamedAndNoReportIsLeft) {
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  for (const auto& [flag, words] :
       {std::pair<std::string, std::string>{"--board-detail 40", "board detail resolution"},
        {"--board-detail 0", "board detail resolution"},
        {"--jpeg-quality 0", "JPEG quality"},
        {"--jpeg-quality 101", "JPEG quality"}}) {
    SCOPED_TRACE(flag);
    std::string out;
    EXPECT_EQ(test::run_sawyer("report -q " + flag + " " + test::quoted(dir.path()), &out), 1);
    EXPECT_NE(out.find(words), std::string::npos) << out;
    EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
    EXPECT_FALSE(fs::exists(dir / "report"));
  }
}

// The report stage's memory (issue 24, docs/run.md "Memory of the report stage"): `sawyer
// report` on this run folder peaked at 303 MiB (2026-12-04, 318 MiB before the detailed faces
// were encoded one board at a time and the renderer freed before the documents). Twice that
// fails. The peak is the process's own, from getrusage over the waited-for children.
TEST(Report, PeakMemoryStaysWithinTwiceTheMeasured) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's shadow memory is not the report's";
#endif
  test::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(make_run_folder(dir.path()));
  rusage before{};
  ASSERT_EQ(getrusage(RUSAGE_CHILDREN, &before), 0);
  ASSERT_NO_FATAL_FAILURE(make_report(dir.path()));
  rusage after{};
  ASSERT_EQ(getrusage(RUSAGE_CHILDREN, &after), 0);
  // `sawyer saw` ran first; the report, using the renderer, is the larger of the two.
  ASSERT_GT(after.ru_maxrss, before.ru_maxrss) << "the report's peak was not measured";
  const double mib = static_cast<double>(after.ru_maxrss) / 1024.0;  // Linux: kilobytes
  EXPECT_LT(mib, 2 * 303.0) << "sawyer report peaked at " << mib << " MiB";
}

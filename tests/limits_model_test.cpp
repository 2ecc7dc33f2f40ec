// Limits on what reaches the log model, the sawing optimiser and the renderer (issue 18): numbers
// that overflow a double, absurd values in log.json and stem banks, sawing grids that cannot be
// counted or held, data files that are FIFOs, devices or huge, and render sizes past the memory
// budget. Each is refused with one line naming the file or option, the value and the range; the
// logs Sawyer ships and writes still load.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "sawyer/model/gran1_import.h"
#include "sawyer/model/log_generator.h"
#include "sawyer/model/log_json.h"
#include "sawyer/sawing/optimise.h"
#include "sawyer/sawing/pattern.h"
#include "sawyer/sawing/setup.h"
#include "sawyer/test/test_util.h"
#ifdef SAWYER_HAVE_RENDER
#include "sawyer/render/scene.h"
#include "sawyer/render/views.h"
#endif

namespace sawyer {
namespace {

// "ulimit -v 4000000; " (4 GB of address space bounds a reader that fills memory), except under
// AddressSanitizer, which reserves terabytes of address space for its shadow and cannot start
// under such a limit (there the `timeout` alone bounds the call).
std::string memory_limit() {
#if defined(__SANITIZE_ADDRESS__)
  return "";
#else
  return "ulimit -v 4000000; ";
#endif
}

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;
using ::testing::HasSubstr;
using ::testing::Not;

size_t lines(const std::string& s) {
  size_t n = 0;
  for (char ch : s) n += ch == '\n';
  return n;
}

fs::path gran1_json() { return test::sample_log("gran1_spruce") / "log.json"; }

Json gran1_doc() {
  std::ifstream in(gran1_json());
  return Json::parse(in);
}

// The bundled log with `edit` applied, written to dir/name; returns the path.
fs::path edited_log(const test::TempDir& dir, const std::function<void(Json&)>& edit,
                    const std::string& name = "log.json") {
  Json j = gran1_doc();
  edit(j);
  test::write_file(dir / name, j.dump());
  return dir / name;
}

// The bundled log with one number replaced by the text `raw` (e.g. 1e999, which no JSON
// library writes).
fs::path log_with_raw_number(const test::TempDir& dir, const std::function<void(Json&)>& mark,
                             const std::string& raw) {
  Json j = gran1_doc();
  mark(j);  // sets the key to the marker 123456.789
  std::string text = j.dump();
  const size_t at = text.find("123456.789");
  EXPECT_NE(at, std::string::npos);
  text.replace(at, 10, raw);
  test::write_file(dir / "log.json", text);
  return dir / "log.json";
}

std::string read_error(const fs::path& path) {
  Result<LogModel> r = read_log_json(path);
  return r ? "(accepted)" : r.error().message();
}

// ---- log.json --------------------------------------------------------------------------------

TEST(LogJsonLimits, NumberOverflowingADoubleIsOneErrorNamingFileAndLine) {
  test::TempDir dir;
  for (auto mark : std::vector<std::function<void(Json&)>>{
           [](Json& j) { j["stem"]["dz_mm"] = 123456.789; },
           [](Json& j) { j["knots"][3]["a"] = 123456.789; },
           [](Json& j) { j["stem"]["radius"][7][9] = 123456.789; }}) {
    const fs::path p = log_with_raw_number(dir, mark, "1e999");
    const std::string e = read_error(p);
    EXPECT_THAT(e, HasSubstr(p.string() + ": line "));
    EXPECT_THAT(e, HasSubstr("1e999 does not fit a double"));
    EXPECT_EQ(lines(e), 0u) << e;
  }
}

TEST(LogJsonLimits, EveryCommandThatReadsALogRefusesAnOverflowingNumberInOneLine) {
  test::TempDir dir;
  const fs::path p = log_with_raw_number(
      dir, [](Json& j) { j["knots"][0]["b"] = 123456.789; }, "-1e999");
  const std::string log = test::quoted(p);
  std::vector<std::string> commands = {
      "info " + log,
      "convert " + log + " -o " + test::quoted(dir / "out.json"),
      "phantom " + log + " -o " + test::quoted(dir / "ct"),
      "saw " + log + " -q -o " + test::quoted(dir / "sawing.json"),
  };
#ifdef SAWYER_HAVE_RENDER
  commands.push_back("render " + log + " --section 100 -o " + test::quoted(dir / "s.png"));
#endif
  for (const std::string& c : commands) {
    std::string out;
    EXPECT_EQ(test::run_sawyer(c, &out), 1) << c << "\n" << out;
    EXPECT_EQ(lines(out), 1u) << c << "\n" << out;
    EXPECT_THAT(out, HasSubstr(p.string() + ": line ")) << c;
  }
  EXPECT_FALSE(fs::exists(dir / "out.json"));
  EXPECT_FALSE(fs::exists(dir / "ct"));
  EXPECT_FALSE(fs::exists(dir / "sawing.json"));
  EXPECT_FALSE(fs::exists(dir / "s.png"));
}

TEST(LogJsonLimits, AbsurdValuesAreNamedWithKeyValueAndRange) {
  test::TempDir dir;
  const std::vector<std::pair<std::function<void(Json&)>, std::string>> cases = {
      {[](Json& j) { j["stem"]["dz_mm"] = 1e12; }, "stem.dz_mm: 1e+12 mm is outside 0.01-1000 mm"},
      {[](Json& j) { j["stem"]["dz_mm"] = 200; },
       "stem: length 80000 mm (400 samples × dz_mm 200)"},
      {[](Json& j) { j["stem"]["z0_mm"] = -1e9; }, "stem.z0_mm: -1e+09 mm is outside"},
      {[](Json& j) { j["stem"]["n_angles"] = 1000000000000LL; }, "stem.n_angles: 1000000000000"},
      {[](Json& j) { j["stem"]["pith"][3][1] = 1e7; }, "stem.pith[3]: 1e+07 mm is outside"},
      {[](Json& j) { j["stem"]["radius"][5][6] = 2e3; },
       "stem.radius[5][6]: 2000 mm is outside 0-1500 mm"},
      {[](Json& j) { j["knots"][12]["d_dead"] = 5e3; },
       "knots[12].d_dead: 5000 mm is outside 0-1000 mm"},
      {[](Json& j) { j["knots"][1]["r_end"] = 1e9; }, "knots[1].r_end: 1e+09 mm is outside 0-2000"},
      {[](Json& j) { j["knots"][1]["r_dead"] = 1e9; }, "knots[1].r_dead: 1e+09 mm is outside"},
      {[](Json& j) { j["knots"][2]["z0"] = 1e15; }, "knots[2].z0: 1e+15 mm is outside"},
      {[](Json& j) { j["knots"][2]["a"] = -1e6; }, "knots[2].a: -1e+06 mm/√mm is outside"},
      {[](Json& j) { j["knots"][2]["b"] = 1e6; }, "knots[2].b: 1e+06 mm/mm is outside"},
      {[](Json& j) { j["knots"][4]["omega0"] = 360; }, "knots[4].omega0: 360 rad is outside"},
      {[](Json& j) { j["knots"][4]["twist"] = 1e4; }, "knots[4].twist: 10000 rad per ln(mm)"},
      {[](Json& j) { j["knots"][4]["d_exp"] = 1e3; }, "knots[4].d_exp: 1000 is outside 0-10"},
      {[](Json& j) { j["knots"][4]["fit_rms_mm"] = -1; }, "knots[4].fit_rms_mm: -1 mm is outside"},
      {[](Json& j) { j["knots"][4]["support"] = 1e12; }, "knots[4].support: expected an integer"},
      {[](Json& j) { j["knots"][4]["support"] = 1000000000000LL; },
       "knots[4].support: 1000000000000 is outside 0-2147483647"},
      {[](Json& j) { j["knots"][4]["id"] = -1000000000000LL; }, "knots[4].id: -1000000000000"},
      {[](Json& j) {
         j["stem"]["heartwood"] = Json::array();
         for (size_t i = 0; i < j["stem"]["radius"].size(); ++i)
           j["stem"]["heartwood"].push_back(std::vector<double>(360, 1e5));
       },
       "stem.heartwood[0][0]: 100000 mm is outside 0-1500 mm"},
      {[](Json& j) { j["stem"]["bark_mm"] = std::vector<double>(400, 1e6); },
       "stem.bark_mm[0]: 1e+06 mm is outside 0-500 mm"},
  };
  for (const auto& [edit, message] : cases) {
    const fs::path p = edited_log(dir, edit);
    const std::string e = read_error(p);
    EXPECT_THAT(e, HasSubstr(p.string() + ": " + message));
    EXPECT_EQ(lines(e), 0u) << e;
  }
}

TEST(LogJsonLimits, TooManySamplesAreRefusedBeforeTheRowsAreRead) {
  // n_angles is checked before the radius rows are matched against it.
  Json j = gran1_doc();
  j["stem"]["n_angles"] = 100000;
  Result<LogModel> r = log_from_json(j.dump());
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(), HasSubstr("stem.n_angles: 100000 is outside 3-7200"));
}

TEST(LogJsonLimits, ALogWithAbsurdDzIsNotSawn) {
  test::TempDir dir;
  const fs::path p = edited_log(dir, [](Json& j) { j["stem"]["dz_mm"] = 1e12; });
  std::string out;
  EXPECT_EQ(test::run_sawyer(
                "saw " + test::quoted(p) + " -q -o " + test::quoted(dir / "sawing.json"), &out),
            1);
  EXPECT_THAT(out, HasSubstr("stem.dz_mm: 1e+12 mm is outside"));
  EXPECT_FALSE(fs::exists(dir / "sawing.json"));
}

TEST(LogJsonLimits, BundledGeneratedAndBigRealisticLogsStillLoad) {
  for (const char* name : {"gran1_spruce", "pine_8", "spruce_77"})
    EXPECT_TRUE(read_log_json(test::sample_log(name) / "log.json")) << name;
  // A big tropical log: 1.4 m across, 25 m long at 5 mm, knots to the bark.
  test::TempDir dir;
  const fs::path p = edited_log(dir, [](Json& j) {
    Json& s = j["stem"];
    s["dz_mm"] = 5.0;
    Json rows = Json::array(), pith = Json::array();
    for (int i = 0; i < 5000; ++i) {
      rows.push_back(std::vector<double>(360, 700.0));
      pith.push_back({0.0, 0.0});
    }
    s["radius"] = rows;
    s["pith"] = pith;
    j["knots"][0]["r_end"] = 720.0;
    j["knots"][0]["d_dead"] = 180.0;
  });
  Result<LogModel> r = read_log_json(p);
  ASSERT_TRUE(r) << r.error().message();
  EXPECT_DOUBLE_EQ(r.value().stem.length_mm(), 25000.0);
  // Written and read back by Sawyer itself.
  ASSERT_TRUE(write_log_json(r.value(), dir / "again.json"));
  EXPECT_TRUE(read_log_json(dir / "again.json"));
}

TEST(LogJsonLimits, FifosDevicesAndHugeFilesAreRefusedBeforeReading) {
  test::TempDir dir;
  const fs::path fifo = dir / "fifo.json";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  // No writer ever opens the FIFO: a reader that opened it would wait for ever.
  EXPECT_THAT(read_error(fifo), HasSubstr(fifo.string() + ": is a FIFO, expected a regular file"));
  EXPECT_THAT(read_error("/dev/zero"), HasSubstr("/dev/zero: is a device"));
  // A sparse file past the limit costs no disk and would be read whole.
  const fs::path huge = dir / "huge.json";
  { std::ofstream(huge).put(' '); }
  fs::resize_file(huge, log_limits::kMaxFileBytes + 1);
  EXPECT_THAT(read_error(huge),
              HasSubstr(huge.string() + ": is 536870913 bytes, more than the 512 MiB allowed"));
  // The CLI: one line, bounded by construction (timeout, memory limit).
  std::string out;
  const int rc =
      test::run_command(memory_limit() + "timeout 60 " + test::quoted(test::sawyer_bin()) +
                            " info " + test::quoted(fifo) + " 2>&1",
                        &out);
  EXPECT_EQ(rc, 1) << out;
  EXPECT_EQ(lines(out), 1u) << out;
  EXPECT_THAT(out, HasSubstr(fifo.string()));
}

// ---- stem banks and maps ---------------------------------------------------------------------

TEST(StemBankLimits, OverflowAndAbsurdValuesAreRefusedNamingTheFile) {
  test::TempDir dir;
  const fs::path src = test::gran1_source_dir();
  for (const auto& e : fs::directory_iterator(src)) fs::copy(e.path(), dir / e.path().filename());
  const fs::path knots = dir / "Gran_1_knots.json";
  std::ifstream in(knots);
  Json kj = Json::parse(in);
  in.close();
  kj[2][3] = 123456.789;
  std::string text = kj.dump();
  text.replace(text.find("123456.789"), 10, "1e999");
  test::write_file(knots, text);
  Result<LogModel> r = import_gran1(dir.path(), "Gran_1");
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(), HasSubstr(knots.string() + ": malformed JSON"));

  kj[2][3] = 1e7;  // the knot's rise A, beyond any knot
  test::write_file(knots, kj.dump());
  r = import_gran1(dir.path(), "Gran_1");
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(), HasSubstr(dir.path().string() + ": knots[2].a: -1e+07"));
}

// ---- sawing options ----------------------------------------------------------------------------

std::string options_error(const std::function<void(sawing::OptimiseOptions&)>& edit) {
  sawing::OptimiseOptions o;
  edit(o);
  Result<sawing::Pattern> p = sawing::pattern_by_name("2ex");
  EXPECT_TRUE(p);
  Status st = o.validate(p.value());
  return st ? "(accepted)" : st.error().message();
}

TEST(SawingLimits, GridOptionsOutOfRangeAreRefusedNamingTheOption) {
  using O = sawing::OptimiseOptions;
  EXPECT_EQ(options_error([](O&) {}), "(accepted)");
  EXPECT_EQ(options_error([](O& o) { o.rot_step_deg = 0.5, o.offset_x_max_mm = 50; }),
            "(accepted)");
  EXPECT_THAT(options_error([](O& o) { o.rot_step_deg = 1e-9; }),
              HasSubstr("rotation step (rot_step_deg): 1e-09° is outside 0.01-180°"));
  EXPECT_THAT(options_error([](O& o) { o.offset_x_max_mm = 1e9, o.offset_x_step_mm = 1e-3; }),
              HasSubstr("offset x (offset_x_max_mm): 1e+09 mm is outside 0-1500 mm"));
  EXPECT_THAT(options_error([](O& o) { o.offset_x_max_mm = 10, o.offset_x_step_mm = 1e-9; }),
              HasSubstr("offset x step (offset_x_step_mm): 1e-09 mm is outside 0.01-10 mm"));
  EXPECT_THAT(options_error([](O& o) { o.offset_y_max_mm = 1e300; }),
              HasSubstr("(offset_y_max_mm): 1e+300 mm is outside"));
  EXPECT_THAT(options_error([](O& o) { o.sigma_rot_deg = 1e6; }),
              HasSubstr("sigma (sigma_rot_deg): 1e+06° is outside 0-90°"));
  EXPECT_THAT(options_error([](O& o) { o.sigma_offset_mm = 1e300; }),
              HasSubstr("sigma (sigma_offset_mm): 1e+300 mm is outside 0-100 mm"));
  // Each step in range, the grid too big: 18000 rotations × 2001 × 1 offsets.
  const std::string big = options_error(
      [](O& o) { o.rot_step_deg = 0.01, o.offset_x_max_mm = 10, o.offset_x_step_mm = 0.01; });
  EXPECT_THAT(big, HasSubstr("sawing grid: 3.6018e+07 positions (18000 rotations × 2001 × 1"));
  EXPECT_THAT(big, HasSubstr("rot_step_deg 0.01, offset_x_max_mm 10 offset_x_step_mm 0.01"));
  EXPECT_THAT(big, HasSubstr("more than the 1e+06 allowed"));
}

TEST(SawingLimits, PositionsOutOfRangeAreRefused) {
  EXPECT_TRUE(sawing::parse_position("20,4,-2"));
  EXPECT_TRUE(sawing::parse_position("-360,1500,-1500"));
  Result<sawing::LogPosition> p = sawing::parse_position("1e300");
  ASSERT_FALSE(p);
  EXPECT_THAT(p.error().message(),
              HasSubstr("SawNames::position: rotation 1e+300° is outside -360 to 360°"));
  p = sawing::parse_position("0,0,-1e9");
  ASSERT_FALSE(p);
  EXPECT_THAT(p.error().message(),
              HasSubstr("SawNames::position: y offset -1e+09 mm is outside -1500"));
}

TEST(SawingLimits, HugeGridsAreRefusedByTheCommandsBeforeAnyWork) {
  test::TempDir dir;
  const std::string log = test::quoted(gran1_json());
  for (const std::string& opts :
       {std::string("--rot-step 1e-9"), std::string("--offsets 1e9 --offset-step 1e-3"),
        std::string("--rot-step 0.01 --offsets 50 --offset-step 0.01"),
        std::string("--position 0,1e9")}) {
    std::string out;
    const int rc = test::run_command(
        memory_limit() + "timeout 60 " + test::quoted(test::sawyer_bin()) + " saw " + log + " -q " +
            opts + " -o " + test::quoted(dir / "sawing.json") + " 2>&1",
        &out);
    EXPECT_EQ(rc, 1) << opts << "\n" << out;
    EXPECT_EQ(lines(out), 1u) << out;
    EXPECT_THAT(out, HasSubstr(opts.substr(0, opts.find(' ')))) << out;
    EXPECT_FALSE(fs::exists(dir / "sawing.json"));
  }
}

#ifdef SAWYER_HAVE_RENDER
TEST(SawingLimits, RunRefusesABadGridBeforeTheScan) {
  // The input is not even a scan: the options are refused first.
  test::TempDir dir;
  fs::create_directories(dir / "ct");
  std::string out;
  EXPECT_EQ(test::run_sawyer("run " + test::quoted(dir / "ct") + " -o " + test::quoted(dir / "o") +
                                 " --rot-step 1e-9 --no-register -q",
                             &out),
            1);
  EXPECT_EQ(lines(out), 1u) << out;
  EXPECT_THAT(out, HasSubstr("--rot-step")) << out;
  EXPECT_FALSE(fs::exists(dir / "o"));
}
#endif

// ---- sawing data files -------------------------------------------------------------------------

TEST(SawingLimits, DataFilesMustBeSmallRegularFiles) {
  test::TempDir dir;
  const fs::path fifo = dir / "pattern.json";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  Result<sawing::Pattern> p = sawing::pattern_by_name(fifo.string());
  ASSERT_FALSE(p);
  EXPECT_THAT(p.error().message(),
              HasSubstr(fifo.string() + ": is a FIFO, expected a regular file"));
  Result<sawing::PriceTable> v = sawing::prices_by_name("/dev/zero");
  ASSERT_FALSE(v);
  EXPECT_THAT(v.error().message(), HasSubstr("/dev/zero: is a device, expected a regular file"));
  const fs::path big = dir / "grading.json";
  test::write_file(big, std::string(2 << 20, ' '));
  Result<sawing::GradingRules> g = sawing::grading_by_name(big.string());
  ASSERT_FALSE(g);
  EXPECT_THAT(g.error().message(),
              HasSubstr(big.string() + ": is 2097152 bytes, more than the 1 MiB allowed"));
  g = sawing::grading_by_name(dir.path().string());
  ASSERT_FALSE(g);
  EXPECT_THAT(g.error().message(), HasSubstr("is a folder"));
  // The bundled files are well inside the limit.
  EXPECT_TRUE(sawing::grading_by_name("nordic"));
  EXPECT_TRUE(sawing::prices_by_name(""));
}

TEST(SawingLimits, DataFileWithAnOverflowingNumberIsOneLine) {
  test::TempDir dir;
  test::write_file(dir / "prices.json",
                   R"({"format": "sawyer-prices/1", "default": {"A": 1e999}})");
  Result<sawing::PriceTable> v = sawing::prices_by_name((dir / "prices.json").string());
  ASSERT_FALSE(v);
  EXPECT_THAT(v.error().message(), HasSubstr((dir / "prices.json").string() + ": "));
  EXPECT_THAT(v.error().message(), HasSubstr("out of range"));
}

TEST(SawingLimits, FifoAndDeviceAsDataFilesDoNotHangTheCommand) {
  test::TempDir dir;
  const fs::path fifo = dir / "p.json";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string log = test::quoted(gran1_json());
  for (const std::string& opt :
       {"--pattern " + test::quoted(fifo), std::string("--prices /dev/zero")}) {
    std::string out;
    // Bounded by construction: an old reader would block on the FIFO or fill memory from
    // /dev/zero, and is stopped by the timeout or the memory limit.
    const int rc = test::run_command(memory_limit() + "timeout 60 " +
                                         test::quoted(test::sawyer_bin()) + " saw " + log + " -q " +
                                         opt + " -o " + test::quoted(dir / "sawing.json") + " 2>&1",
                                     &out);
    EXPECT_EQ(rc, 1) << opt << "\n" << out;
    EXPECT_EQ(lines(out), 1u) << out;
    EXPECT_THAT(out, HasSubstr("expected a regular file")) << out;
    EXPECT_FALSE(fs::exists(dir / "sawing.json"));
  }
}

// ---- issue 44: inputs that ran for minutes, offsets far outside the log -------------------------

// The bundled log with its knots copied (new ids, turned and shifted along the log) until there
// are `n`.
Json log_with_knots(int n) {
  Json j = gran1_doc();
  const Json base = j["knots"];
  Json knots = Json::array();
  for (int i = 0; i < n; ++i) {
    Json k = base[static_cast<size_t>(i) % base.size()];
    k["id"] = i;
    k["omega0"] = std::fmod(k["omega0"].get<double>() + 0.7 * (i / base.size()), 2 * kPi);
    k["z0"] = k["z0"].get<double>() + std::fmod(37.0 * i, 100.0) - 50.0;
    knots.push_back(k);
  }
  j["knots"] = knots;
  return j;
}

// A pattern of n edged boards 20 x 20 mm on a grid (3 mm kerfs), centred on the pith.
Json grid_pattern(int n) {
  Json boards = Json::array();
  const int side = static_cast<int>(std::ceil(std::sqrt(n)));
  for (int i = 0; i < n; ++i)
    boards.push_back({{"name", "b" + std::to_string(i)},
                      {"u_mm", 23.0 * (i % side - side / 2)},
                      {"v_mm", 23.0 * (i / side - side / 2)},
                      {"thickness_mm", 20},
                      {"width_mm", 20},
                      {"edged", true}});
  return {{"format", "sawyer-pattern/1"}, {"name", "grid"}, {"kerf_mm", 3}, {"boards", boards}};
}

std::vector<std::string> listing(const fs::path& dir) {
  std::vector<std::string> v;
  for (const auto& e : fs::directory_iterator(dir)) v.push_back(e.path().filename().string());
  std::sort(v.begin(), v.end());
  return v;
}

// `sawyer saw` with `args`, bounded by `timeout` (a refusal must come long before it); returns
// the exit code, stdout and stderr in *out.
int saw_bounded(const std::string& args, std::string* out) {
  return test::run_command(
      memory_limit() + "timeout 300 " + test::quoted(test::sawyer_bin()) + " saw " + args + " 2>&1",
      out);
}

TEST(LogJsonLimits, AbsurdKnotCountsAreRefusedBeforeAnyWork) {
  // 100 000 knots (issue 44: `sawyer saw` was still running after a minute, at 1.1 GB).
  test::TempDir dir;
  test::write_file(dir / "log.json", log_with_knots(100000).dump());
  const std::vector<std::string> before = listing(dir.path());
  Result<LogModel> r = read_log_json(dir / "log.json");
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(),
              HasSubstr("knots: has 100000 knots, more than the 10000 allowed"));
  std::string out;
  EXPECT_EQ(
      saw_bounded(test::quoted(dir / "log.json") + " -q -o " + test::quoted(dir / "sawing.json"),
                  &out),
      1)
      << out;
  EXPECT_EQ(lines(out), 1u) << out;
  EXPECT_THAT(out, HasSubstr("log.json: knots: has 100000 knots, more than the 10000 allowed"));
  EXPECT_EQ(listing(dir.path()), before) << "a refusal writes nothing";
  // The most a model may hold still loads; one more is refused, by the reader and by validate().
  Result<LogModel> most = log_from_json(log_with_knots(log_limits::kMaxKnots).dump());
  ASSERT_TRUE(most) << most.error().message();
  LogModel more = most.value();
  more.knots.push_back(more.knots.back());
  EXPECT_THAT(validate(more).error().message(), HasSubstr("more than the 10000 allowed"));
}

TEST(SawingLimits, ALogWithManyKnotsIsSawnAtEveryPosition) {
  // 2000 knots on the bundled 4 m log (500 a metre, twenty times the real log's density; a 40 m
  // log at 50 a metre has as many): sawn on the default grid like any log. The work is bounded
  // by the knots (at most 10 000) times the positions (at most 10^6); `timeout` bounds the test.
  test::TempDir dir;
  test::write_file(dir / "log.json", log_with_knots(2000).dump());
  std::string out;
  ASSERT_EQ(
      saw_bounded(test::quoted(dir / "log.json") + " -q -o " + test::quoted(dir / "sawing.json"),
                  &out),
      0)
      << out;
  std::ifstream in(dir / "sawing.json");
  const Json saw = Json::parse(in);
  EXPECT_EQ(saw["log"], "gran1_spruce");
  size_t knots_on_boards = 0;
  for (const Json& b : saw["boards"]) knots_on_boards += b["knots"].size();
  EXPECT_GT(knots_on_boards, 100u) << "the boards carry the knots";
  EXPECT_THAT(out, HasSubstr("2000 knots")) << out;
}

TEST(SawingLimits, AbsurdBoardCountsAreRefusedBeforeAnyWork) {
  // 10 000 boards (issue 44: still running after a minute at 0.6 GB); the most allowed loads.
  Result<sawing::Pattern> p = sawing::pattern_from_json(grid_pattern(10000).dump());
  ASSERT_FALSE(p);
  EXPECT_THAT(p.error().message(),
              HasSubstr("boards: has 10000 boards, more than the 200 allowed"));
  EXPECT_TRUE(sawing::pattern_from_json(grid_pattern(sawing::kMaxPatternBoards).dump()));
  sawing::Pattern big = sawing::pattern_from_json(grid_pattern(200).dump()).value();
  big.boards.push_back(big.boards.back());
  big.boards.back().u_mm += 1000;
  EXPECT_THAT(big.validate().error().message(), HasSubstr("201 boards, more than the 200"));
  big.boards.pop_back();
  big.boards.back().width_mm = 1e300;
  EXPECT_THAT(big.validate().error().message(), HasSubstr("at most 3000 mm"));

  test::TempDir dir;
  test::write_file(dir / "p.json", grid_pattern(10000).dump());
  const std::vector<std::string> before = listing(dir.path());
  std::string out;
  EXPECT_EQ(
      saw_bounded(test::quoted(gran1_json()) + " -q --pattern " + test::quoted(dir / "p.json") +
                      " -o " + test::quoted(dir / "sawing.json"),
                  &out),
      1)
      << out;
  EXPECT_EQ(lines(out), 1u) << out;
  EXPECT_THAT(out, HasSubstr("p.json: boards: has 10000 boards, more than the 200 allowed"));
  EXPECT_EQ(listing(dir.path()), before);
}

TEST(SawingLimits, OffsetsOutsideTheLogAreRefusedNamingTheOption) {
  // The bundled log's wood lies within about 140 mm of its centre line: a position or a grid
  // reaching a metre from it saws nothing of the log.
  test::TempDir dir;
  const std::string log = test::quoted(gran1_json());
  for (const auto& [opts, option] :
       {std::pair{std::string("--position 0,1000"), std::string("--position: offset (1000, 0)")},
        std::pair{std::string("--position 30,0,-400"), std::string("--position: offset (0, -400)")},
        std::pair{std::string("--offsets 1000 --offset-step 10"),
                  std::string("--offsets: 1000 mm")},
        std::pair{std::string("--offsets-y 600 --offset-y-step 20"),
                  std::string("--offsets-y: 600 mm")}}) {
    std::string out;
    EXPECT_EQ(saw_bounded(log + " -q " + opts + " -o " + test::quoted(dir / "sawing.json"), &out),
              1)
        << opts << "\n"
        << out;
    EXPECT_EQ(lines(out), 1u) << out;
    EXPECT_THAT(out, HasSubstr(option)) << out;
    EXPECT_THAT(out, HasSubstr("of the log's centre line")) << out;
    EXPECT_FALSE(fs::exists(dir / "sawing.json"));
  }
  // Within the log: sawn.
  std::string out;
  EXPECT_EQ(
      saw_bounded(log + " -q --position 10,20,-5 -o " + test::quoted(dir / "sawing.json"), &out), 0)
      << out;
}

#ifdef SAWYER_HAVE_RENDER
TEST(SawingLimits, RunRefusesOffsetsOutsideTheScanBeforeTheScan) {
  // The scanned box of the small test scan is about 0.4 m across: an offset of 1.4 m is outside
  // any log in it. Refused before a slice is read, nothing written.
  test::TempDir dir;
  const std::vector<std::string> before = listing(dir.path());
  std::string out;
  EXPECT_EQ(test::run_sawyer("run " + test::quoted(test::gran1_40cm_ct()) + " -o " +
                                 test::quoted(dir / "o") + " --position 0,1400 --db " +
                                 test::quoted(dir / "reg.sqlite") + " -q",
                             &out),
            1);
  EXPECT_EQ(lines(out), 1u) << out;
  EXPECT_THAT(out, HasSubstr("--position: offset (1400, 0) mm")) << out;
  EXPECT_THAT(out, HasSubstr("the scanned volume")) << out;
  EXPECT_EQ(listing(dir.path()), before) << "no register, no run folder";
}
#endif

// ---- render sizes ------------------------------------------------------------------------------

#ifdef SAWYER_HAVE_RENDER
TEST(RenderLimits, SizesPastTheSideOrMemoryBudgetAreRefused) {
  using render::check_image_size;
  EXPECT_TRUE(check_image_size(1200, 900, 2, false));
  EXPECT_TRUE(check_image_size(8192, 8192, 1, false));
  EXPECT_TRUE(check_image_size(4096, 4096, 2, false));
  Status st = check_image_size(16384, 100, 1, false);
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message(), HasSubstr("ImageSize: 16384x100 outside 1..8192 pixels"));
  st = check_image_size(8192, 8192, 2, false);
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message(),
              HasSubstr("ImageSize: 8192x8192 at 2x2 supersampling needs 1024 MiB of framebuffer, "
                        "more than the 512 MiB allowed"));
  st = check_image_size(8192, 8192, 1, true);  // the float field: 16 bytes a sample
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message(), HasSubstr("ImageSize: 8192x8192 needs 1024 MiB"));
}

TEST(RenderLimits, BoardGeometryOutOfRangeIsRefused) {
  EXPECT_TRUE(BoardBox::from_string("0,0,150,50,0,100,3900"));
  for (const auto& [text, message] : std::vector<std::pair<std::string, std::string>>{
           {"0,0,1e300,50,0,100,3900",
            "BoardBox::from_string: board: width 1e+300 is outside 0-3000 mm"},
           {"0,0,150,50,1e6,100,3900",
            "BoardBox::from_string: rotation 1e+06° is outside -360 to 360°"},
           {"1e9,0,150,50,0,100,3900", "BoardBox::from_string: board: centre x 1e+09 is outside"},
           {"0,0,150,50,0,-1e12,3900", "BoardBox::from_string: board: z0 -1e+12 is outside"}}) {
    Result<BoardBox> b = BoardBox::from_string(text);
    ASSERT_FALSE(b) << text;
    EXPECT_THAT(b.error().message(), HasSubstr(message));
  }
}

TEST(RenderLimits, TheCommandRefusesAnOversizedImageBeforeRendering) {
  test::TempDir dir;
  const std::string log = test::quoted(gran1_json());
  for (const std::string& opts :
       {std::string("--size 16384"), std::string("--size 8192x8192 --supersample-all"),
        std::string("--size 6000x6000 --supersample 1 --field")}) {
    std::string out;
    const fs::path img = dir / (opts.find("--field") != std::string::npos ? "s.exr" : "s.png");
    EXPECT_EQ(test::run_sawyer(
                  "render " + log + " --section 1000 " + opts + " -o " + test::quoted(img), &out),
              1)
        << out;
    EXPECT_EQ(lines(out), 1u) << out;
    EXPECT_THAT(out, HasSubstr("--size")) << out;
    EXPECT_FALSE(fs::exists(img));
  }
}
#endif

}  // namespace
}  // namespace sawyer

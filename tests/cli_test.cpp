// The `sawyer` command line, run as a user would: figures printed, errors as one line.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "sawyer/core/file_util.h"
#include "sawyer/core/option_names.h"
#include "sawyer/model/gran1_import.h"
#include "sawyer/model/log_json.h"
#include "sawyer/test/test_util.h"

namespace sawyer {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

int lines(const std::string& s) { return static_cast<int>(std::count(s.begin(), s.end(), '\n')); }

TEST(Cli, InfoOnTheBundledSpruceLogPrintsItsFigures) {
  std::string out;
  const fs::path log = test::sample_log("gran1_spruce") / "log.json";
  ASSERT_EQ(test::run_sawyer("info " + test::quoted(log), &out), 0) << out;
  EXPECT_THAT(out, HasSubstr("log gran1_spruce  species spruce"));
  EXPECT_THAT(out, HasSubstr("4.000 m  (400 samples of 10.0 mm)"));
  EXPECT_THAT(out, HasSubstr("104.06 .. 143.38 mm"));
  EXPECT_THAT(out, HasSubstr("knots                   108"));
  for (const char* label : {"diameter butt", "diameter top", "diameter mean", "volume", "taper",
                            "pith wander", "largest knot"})
    EXPECT_THAT(out, HasSubstr(label));
}

TEST(Cli, BundledSpruceLogJsonMatchesAFreshImport) {
  // sample_logs/gran1_spruce/log.json is the committed conversion of the source files; it must
  // stay what the importer makes of them.
  Result<LogModel> fresh = import_gran1(test::gran1_source_dir());
  ASSERT_TRUE(fresh) << fresh.error().message();
  Result<std::string> committed = read_text_file(test::sample_log("gran1_spruce") / "log.json");
  ASSERT_TRUE(committed) << committed.error().message();
  EXPECT_TRUE(log_to_json(fresh.value()) == committed.value())
      << "regenerate with: sawyer convert sample_logs/gran1_spruce/source -o "
         "sample_logs/gran1_spruce/log.json";
}

TEST(Cli, InfoReadsTheStemBankFolderToo) {
  std::string a, b;
  ASSERT_EQ(test::run_sawyer("info " + test::quoted(test::gran1_source_dir()), &a), 0) << a;
  ASSERT_EQ(
      test::run_sawyer("info " + test::quoted(test::sample_log("gran1_spruce") / "log.json"), &b),
      0);
  EXPECT_EQ(a, b);
}

TEST(Cli, ConvertToLogJsonRoundTrips) {
  test::TempDir dir;
  std::string out;
  ASSERT_EQ(test::run_sawyer("convert " + test::quoted(test::gran1_source_dir()) + " -o " +
                                 test::quoted(dir / "a.json"),
                             &out),
            0)
      << out;
  ASSERT_EQ(
      test::run_sawyer(
          "convert " + test::quoted(dir / "a.json") + " -o " + test::quoted(dir / "b.json"), &out),
      0)
      << out;
  Result<std::string> a = read_text_file(dir / "a.json");
  Result<std::string> b = read_text_file(dir / "b.json");
  ASSERT_TRUE(a && b);
  EXPECT_TRUE(a.value() == b.value());
}

TEST(Cli, MalformedLogGivesOneLineNamingFileAndKeyAndFails) {
  test::TempDir dir;
  const fs::path bad = dir / "bad.json";
  test::write_file(bad, R"({"format": "sawyer-log/1", "stem": {"z0_mm": 0, "pith": []}})");
  std::string out;
  EXPECT_NE(test::run_sawyer("info " + test::quoted(bad), &out), 0);
  EXPECT_EQ(lines(out), 1) << out;
  EXPECT_THAT(out, HasSubstr(bad.string()));
  EXPECT_THAT(out, HasSubstr("stem.dz_mm: missing key"));
}

TEST(Cli, ConvertOfBadInputWritesNothing) {
  test::TempDir dir;
  const fs::path bad = dir / "bad.json";
  test::write_file(bad, "{ not json");
  std::string out;
  EXPECT_NE(test::run_sawyer(
                "convert " + test::quoted(bad) + " -o " + test::quoted(dir / "out.json"), &out),
            0);
  EXPECT_EQ(lines(out), 1) << out;
  EXPECT_FALSE(fs::exists(dir / "out.json"));
}

TEST(Cli, UnknownInputIsNamed) {
  test::TempDir dir;
  std::string out;
  EXPECT_NE(test::run_sawyer("info " + test::quoted(dir / "missing"), &out), 0);
  EXPECT_THAT(out, HasSubstr((dir / "missing").string() + ": no such file or folder"));
  EXPECT_NE(test::run_sawyer("info " + test::quoted(dir.path()), &out), 0);
  EXPECT_THAT(out, HasSubstr("the folder is empty; nor a log model (log.json"));
  test::write_file(dir / "notes.txt", "log 42");
  EXPECT_NE(test::run_sawyer("info " + test::quoted(dir.path()), &out), 0);
  EXPECT_THAT(out, HasSubstr("no CT slices found among 1 files"));
  EXPECT_THAT(out, HasSubstr("nor a log model"));
}

TEST(Cli, EverySubcommandHasHelp) {
  std::string out;
  ASSERT_EQ(test::run_sawyer("--help", &out), 0);
  // Every subcommand listed in the top-level help answers --help itself.
  std::vector<std::string> subs;
  const size_t pos = out.find("Subcommands:");
  ASSERT_NE(pos, std::string::npos) << out;
  std::string rest = out.substr(pos);
  size_t at = rest.find('\n');
  while (at != std::string::npos && at + 1 < rest.size()) {
    const size_t end = rest.find('\n', at + 1);
    const std::string line = rest.substr(at + 1, end - at - 1);
    const size_t first = line.find_first_not_of(' ');
    if (first != std::string::npos && first > 0)
      subs.push_back(line.substr(first, line.find(' ', first) - first));
    at = end;
  }
  EXPECT_GE(subs.size(), 3u) << out;
  for (const std::string& s : subs) {
    std::string h;
    EXPECT_EQ(test::run_sawyer(s + " --help", &h), 0) << s;
    EXPECT_THAT(h, HasSubstr("Usage")) << s;
  }
}

TEST(Cli, NoSubcommandIsAnError) {
  std::string out;
  EXPECT_NE(test::run_sawyer("", &out), 0);
  EXPECT_NE(test::run_sawyer("frobnicate", &out), 0);
}

}  // namespace
}  // namespace sawyer

// Libraries name their own options; the command line puts its flags in (option_names.h): whole
// words only, so an option inside a longer identifier or a plain word stays as it is.
TEST(OptionNames, AFrontEndPutsItsFlagsInPlaceOfTheLibrarysOptionNames) {
  static constexpr sawyer::OptionName kFlags[] = {{"rot_step_deg", "--rot-step"},
                                                  {"SawNames::position", "--position"}};
  EXPECT_EQ(sawyer::with_option_names("rotation step (rot_step_deg): 0 is outside", kFlags),
            "rotation step (--rot-step): 0 is outside");
  EXPECT_EQ(sawyer::with_option_names("SawNames::position: bad; the best position", kFlags),
            "--position: bad; the best position");
  EXPECT_EQ(sawyer::with_option_names("rot_step_deg2 my_rot_step_deg X::rot_step_deg rot_step_deg",
                                      kFlags),
            "rot_step_deg2 my_rot_step_deg X::rot_step_deg --rot-step");
  EXPECT_EQ(sawyer::with_option_names(sawyer::Error("rot_step_deg", "too small"), kFlags).message(),
            "--rot-step: too small");
  // A prefix rule, with an exception before it.
  static constexpr sawyer::OptionName kPrefix[] = {{"PhantomOptions::image_size", "--size"},
                                                   {"PhantomOptions::", "--"}};
  EXPECT_EQ(sawyer::with_option_names(
                "PhantomOptions::ring_width_mm: 0.1; PhantomOptions::image_size: 9; X::y", kPrefix),
            "--ring-width-mm: 0.1; --size: 9; X::y");
}

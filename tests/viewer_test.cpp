// The interactive viewer (apps/viewer) run as a user would, under a virtual X server (Xvfb): a
// screenshot of the window with the log, its knots and the section panels in it, the sawing
// mode, the frame-timing table, bad input rejected with one line. Its parts are tested where
// they live: view_geometry_test.cpp (libs/render), sawing_session_test.cpp (libs/sawing).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "sawyer/model/log_json.h"
#include "sawyer/render/image.h"
#include "sawyer/sawing/setup.h"
#include "sawyer/test/test_util.h"

namespace sawyer::view {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// --- the program --------------------------------------------------------------------------------

std::string viewer_bin() {
  const char* env = std::getenv("SAWYER_VIEW_BIN");
  return (env && *env) ? env : SAWYER_VIEW_BIN;
}

int run_viewer(const std::string& args, std::string* output, const std::string& display = "") {
  std::string env = display.empty() ? "env -u DISPLAY -u WAYLAND_DISPLAY "
                                    : "env -u WAYLAND_DISPLAY DISPLAY=" + display + " ";
  return test::run_command(env + test::quoted(viewer_bin()) + " " + args, output);
}

int lines(const std::string& s) { return static_cast<int>(std::count(s.begin(), s.end(), '\n')); }

TEST(Viewer, HelpNamesTheOptions) {
  std::string out;
  ASSERT_EQ(run_viewer("--help", &out), 0) << out;
  for (const char* o : {"--screenshot", "--bench-frames", "--size", "--board", "--section-z"})
    EXPECT_THAT(out, HasSubstr(o));
}

TEST(Viewer, MissingLogIsOneLineNamingTheFile) {
  test::TempDir dir;
  const fs::path missing = dir / "no_such_log.json";
  std::string out;
  EXPECT_NE(run_viewer(test::quoted(missing), &out), 0);
  EXPECT_EQ(lines(out), 1) << out;
  EXPECT_THAT(out, HasSubstr(missing.string()));
}

TEST(Viewer, InvalidLogIsOneLineNamingTheFileAndTheProblem) {
  test::TempDir dir;
  const fs::path bad = dir / "bad.json";
  test::write_file(bad, R"({"format": "sawyer-log/1", "stem": {"z0_mm": "ten"}})");
  std::string out;
  EXPECT_NE(run_viewer(test::quoted(bad), &out), 0);
  EXPECT_EQ(lines(out), 1) << out;
  EXPECT_THAT(out, HasSubstr("bad.json"));
  test::write_file(bad, "{ not json");
  EXPECT_NE(run_viewer(test::quoted(bad), &out), 0);
  EXPECT_EQ(lines(out), 1) << out;
  EXPECT_THAT(out, HasSubstr("bad.json"));
}

TEST(Viewer, BadOptionsAreOneLine) {
  const std::string log = test::quoted(test::sample_log("gran1_spruce") / "log.json");
  for (const char* args : {" --size 12x", " --board 1,2,3", " --hide leaves"}) {
    std::string out;
    EXPECT_NE(run_viewer(log + args, &out), 0) << args;
    EXPECT_EQ(lines(out), 1) << args << ": " << out;
  }
}

// A virtual X server on a display nobody else uses (Xvfb picks it and reports it: -displayfd),
// stopped when the object goes. display() is empty when the server did not come up.
class Xvfb {
 public:
  static bool installed() { return std::system("command -v Xvfb >/dev/null 2>&1") == 0; }

  Xvfb() {
    const fs::path file = dir_ / "display";
    const std::string cmd = "Xvfb -displayfd 3 -screen 0 1600x1000x24 -nolisten tcp 3>" +
                            test::quoted(file) + " >/dev/null 2>" +
                            test::quoted(dir_ / "xvfb.log") + " & echo $!";
    std::string out;
    if (test::run_command(cmd, &out) != 0) return;
    pid_ = std::atoi(out.c_str());
    // The server writes its display number once it accepts connections (give up after 30 s).
    for (int i = 0; i < 300 && display_.empty(); ++i) {
      std::ifstream in(file);
      std::string line;
      if (std::getline(in, line) && !line.empty() && in.good()) display_ = ":" + line;
      if (display_.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
  ~Xvfb() {
    if (pid_ > 0) kill(pid_, SIGTERM);
  }
  const std::string& display() const { return display_; }
  std::string log() const {
    std::ifstream in(dir_ / "xvfb.log");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }

 private:
  test::TempDir dir_;
  int pid_ = -1;
  std::string display_;
};

#define REQUIRE_XVFB(server)                                                              \
  if (!Xvfb::installed()) GTEST_SKIP() << "Xvfb is not installed (apt-get install xvfb)"; \
  Xvfb server;                                                                            \
  ASSERT_FALSE(server.display().empty()) << "Xvfb did not start: " << server.log()

// The viewer's window with `args`, saved by --screenshot to `png` and read back (an empty image,
// reported, on failure).
render::Image screenshot(const Xvfb& xvfb, const fs::path& png, const std::string& args) {
  std::string out;
  const int rc = run_viewer(args + " --screenshot " + test::quoted(png), &out, xvfb.display());
  EXPECT_EQ(rc, 0) << out;
  EXPECT_THAT(out, HasSubstr("wrote"));
  Result<render::Image> img = render::read_image(png);
  EXPECT_TRUE(img.ok()) << (img.ok() ? "" : img.error().message()) << out;
  return img.ok() ? img.value() : render::Image{};
}

// Wood: warm, light, red above green above blue (the colour strip from pith to bark).
bool is_wood(const render::Image& img, int x, int y) {
  const float r = img.value(x, y, 0), g = img.value(x, y, 1), b = img.value(x, y, 2);
  return r > 0.45f && r > g && g > b && r - b > 0.12f;
}

// Pixels in [x0, x1) x [y0, y1) where two images of the same size differ clearly.
int differing(const render::Image& a, const render::Image& b, int x0, int y0, int x1, int y1) {
  int n = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      float d = 0;
      for (int c = 0; c < 3; ++c) d += std::abs(a.value(x, y, c) - b.value(x, y, c));
      n += d > 0.1f ? 1 : 0;
    }
  return n;
}

TEST(Viewer, ScreenshotUnderXvfbShowsTheLogItsKnotsAndTheSections) {
  REQUIRE_XVFB(xvfb);
  test::TempDir dir;
  const std::string log = test::quoted(test::sample_log("gran1_spruce") / "log.json");
  const int w = 1024, h = 640;
  auto shoot = [&](const std::string& name, const std::string& extra) {
    return screenshot(xvfb, dir / name,
                      log + " --size " + std::to_string(w) + "x" + std::to_string(h) + extra);
  };
  const render::Image full = shoot("full.png", "");
  ASSERT_EQ(full.width, w);
  ASSERT_EQ(full.height, h);

  // The whole window: wood where the log, its sections and the board faces are drawn, and
  // far from one flat colour.
  int wood = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) wood += is_wood(full, x, y) ? 1 : 0;
  EXPECT_GT(wood, w * h / 10) << "wood-coloured pixels";

  // The 3D view (right of the controls, above the section strip; the layout keeps at least
  // this part of the window for it): the knots and the semi-transparent surface show, seen by
  // what changes when each is hidden.
  const int x0 = w / 3, x1 = w, y0 = 0, y1 = h / 2;
  const render::Image no_knots = shoot("no_knots.png", " --hide knots");
  const render::Image no_surface = shoot("no_surface.png", " --hide surface");
  ASSERT_EQ(no_knots.width, w);
  ASSERT_EQ(no_surface.width, w);
  EXPECT_GT(differing(full, no_knots, x0, y0, x1, y1), 500) << "knot tubes in the 3D view";
  EXPECT_GT(differing(full, no_surface, x0, y0, x1, y1), 5000) << "log surface in the 3D view";
  // Hiding things in the 3D view leaves the section and board panels (bottom right) as they were.
  EXPECT_LT(differing(full, no_knots, x0, h * 3 / 4, x1, h), 50);
}

TEST(Viewer, SawingModeDrawsThePatternOnTheSectionAndTheSawingPanel) {
  REQUIRE_XVFB(xvfb);
  test::TempDir dir;
  const std::string log = test::quoted(test::sample_log("gran1_spruce") / "log.json");
  const int w = 1024, h = 640;
  auto shoot = [&](const std::string& name, const std::string& extra) {
    return screenshot(xvfb, dir / name, log + " --size 1024x640" + extra);
  };
  const render::Image plain = shoot("plain.png", "");
  const render::Image sawing = shoot("sawing.png", " --saw 2ex --position 20,4,-2");
  const render::Image turned = shoot("turned.png", " --saw 2ex --position 65,4,-2");
  ASSERT_EQ(plain.width, w);
  ASSERT_EQ(sawing.width, w);
  ASSERT_EQ(turned.width, w);
  ASSERT_EQ(sawing.height, h);

  // The cross-section panel (bottom left of the views, right of the 280-pixel controls): the
  // pattern's grade-coloured boards replace the single board, and follow the rotation.
  const int sx0 = 290, sx1 = 560, sy0 = 420, sy1 = h;
  EXPECT_GT(differing(plain, sawing, sx0, sy0, sx1, sy1), 3000) << "boards on the section";
  EXPECT_GT(differing(sawing, turned, sx0, sy0, sx1, sy1), 2000) << "boards turn with the log";
  // Saturated grade colours (green to orange, red: reject) where the outlines are: strongly
  // coloured, unlike the pale wood.
  auto outline_pixels = [&](const render::Image& img) {
    int n = 0;
    for (int y = sy0; y < sy1; ++y)
      for (int x = sx0; x < sx1; ++x) {
        const float r = img.value(x, y, 0), g = img.value(x, y, 1), b = img.value(x, y, 2);
        n += std::max(r, g) > 0.6f && std::max(r, g) - b > 0.45f ? 1 : 0;
      }
    return n;
  };
  EXPECT_GT(outline_pixels(sawing), outline_pixels(plain) + 1000);
  // The sawing window over the top right (pattern, boards, value).
  EXPECT_GT(differing(plain, sawing, w - 400, 40, w, 300), 5000) << "the sawing window";
}

TEST(Viewer, SawingOptionsAreCheckedBeforeAnyWindow) {
  const std::string log = test::quoted(test::sample_log("gran1_spruce") / "log.json");
  std::string out;
  EXPECT_EQ(run_viewer(log + " --saw 2ex --position 1,x", &out), 1);
  EXPECT_THAT(out, HasSubstr("--position"));
  EXPECT_EQ(lines(out), 1) << out;
  EXPECT_EQ(run_viewer(log + " --position 10", &out), 1);
  EXPECT_THAT(out, HasSubstr("--saw"));
  EXPECT_EQ(lines(out), 1) << out;
}

TEST(Viewer, BenchmarkPrintsTheFrameRateOfTheTypicalFrame) {
  REQUIRE_XVFB(xvfb);
  const std::string log = test::quoted(test::sample_log("pine_8") / "log.json");
  std::string out;
  ASSERT_EQ(run_viewer(log + " --size 800x500 --bench-frames 2", &out, xvfb.display()), 0) << out;
  EXPECT_THAT(out, HasSubstr("window 800 x 500"));
  EXPECT_THAT(out, HasSubstr("board faces panel"));
  const size_t at = out.find("typical: 3D view + section + board faces");
  ASSERT_NE(at, std::string::npos) << out;
  double ms = 0, fps = 0;
  const std::string row =
      out.substr(at + std::string("typical: 3D view + section + board faces").size());
  ASSERT_EQ(std::sscanf(row.c_str(), "%lf %lf", &ms, &fps), 2) << row;
  EXPECT_GT(ms, 0);
  EXPECT_NEAR(fps * ms, 1000.0, 1.0 + 0.01 * 1000.0);  // the two columns agree
}

}  // namespace
}  // namespace sawyer::view

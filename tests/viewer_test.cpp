// The interactive viewer (apps/viewer): its geometry (knot tubes on the knot formula, the orbit
// camera's framing and panning) and the program run as a user would, under a virtual X server
// (Xvfb): a screenshot of the window with the log, its knots and the section panels in it, the
// frame-timing table, bad input rejected with one line.
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

#include "knot_mesh.h"
#include "orbit_camera.h"
#include "sawing_session.h"
#include "sawyer/model/log_json.h"
#include "sawyer/render/image.h"
#include "sawyer/sawing/setup.h"
#include "sawyer/test/test_util.h"

namespace sawyer::view {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// --- geometry -------------------------------------------------------------------------------

// A straight log along z with one knot running along +x at z = 500: the axis is the x axis at
// that height, so a tube vertex at pith distance r has x = r and lies d(r)/2 from the axis.
LogModel straight_log_with_one_knot() {
  LogModel log;
  log.id = "straight";
  Stem& st = log.stem;
  st.z0_mm = 5;
  st.dz_mm = 10;
  st.n_angles = 36;
  for (int i = 0; i < 100; ++i) {
    st.pith.push_back({0, 0});
    st.radius.push_back(std::vector<double>(36, 150.0));
  }
  Knot k;
  k.z0 = 500;
  k.r_dead = 60;
  k.r_end = 100;
  k.diameter = {20.0, 1.0};  // d(r) = 20 r / 60 up to r_dead, 20 mm beyond
  log.knots.push_back(k);
  return log;
}

TEST(ViewerGeometry, KnotTubeLiesOnTheKnotSurfaceAndItsDeadPartIsDark) {
  const LogModel log = straight_log_with_one_knot();
  KnotTubeOptions o;
  o.min_diameter_mm = 2.0;
  const Mesh mesh = knot_tubes(log, o);
  ASSERT_FALSE(mesh.lines);
  ASSERT_GT(mesh.vertices.size(), 100u);
  ASSERT_EQ(mesh.vertices.size() % 3, 0u);
  int sound = 0, dead = 0;
  for (const MeshVertex& v : mesh.vertices) {
    const double x = v.pos[0], dist = std::hypot(v.pos[1], v.pos[2] - 500.0);
    const bool is_dead = v.color[0] == o.dead_color[0] && v.color[1] == o.dead_color[1];
    const bool is_sound = v.color[0] == o.sound_color[0] && v.color[1] == o.sound_color[1];
    ASSERT_TRUE(is_dead || is_sound);
    EXPECT_GE(x, -1e-3);
    EXPECT_LE(x, 100.0 + 1e-3);
    const double d = std::max(x <= 60 ? 20.0 * x / 60.0 : 20.0, o.min_diameter_mm);
    if (x < 100.0 - 1e-3) {  // the end cap's centre is on the axis
      EXPECT_NEAR(dist, 0.5 * d, 1e-3) << "x " << x;
    }
    if (is_dead) {
      ++dead;
      EXPECT_GE(x, 60.0 - 1e-3);  // dark only beyond the sound/dead border
    } else {
      ++sound;
      EXPECT_LE(x, 60.0 + 1e-3);
    }
  }
  EXPECT_GT(sound, 0);
  EXPECT_GT(dead, 0);
}

TEST(ViewerGeometry, EveryKnotOfTheSpruceLogGetsATube) {
  const LogModel& log = test::sample_model("gran1_spruce");
  ASSERT_FALSE(log.knots.empty());
  KnotTubeOptions o;
  const Mesh all = knot_tubes(log, o);
  LogModel one = log;
  one.knots.resize(1);
  const size_t per_knot = knot_tubes(one, o).vertices.size();
  ASSERT_GT(per_knot, 0u);
  // Each knot is rings x sides x 6 vertices plus a cap, plus one more ring with a dead part.
  EXPECT_GE(all.vertices.size(), log.knots.size() * static_cast<size_t>(o.rings * o.sides * 6));
  int dead_knots = 0;
  for (const Knot& k : log.knots) dead_knots += k.has_dead_part() ? 1 : 0;
  EXPECT_GT(dead_knots, 0);
}

TEST(ViewerGeometry, LightSurfaceLiesOnTheOuterRadiusFromEndToEnd) {
  LogModel log = straight_log_with_one_knot();
  // An elliptical outline: r = 150 + 30 cos 2w.
  for (auto& row : log.stem.radius)
    for (int k = 0; k < log.stem.n_angles; ++k)
      row[k] = 150.0 + 30.0 * std::cos(2.0 * kTwoPi * k / log.stem.n_angles);
  const Mesh m = log_surface(log.stem, {1, 1, 1}, 72, 20.0);
  ASSERT_FALSE(m.lines);
  ASSERT_EQ(m.vertices.size() % 6, 0u);
  double zmin = 1e9, zmax = -1e9;
  for (const MeshVertex& v : m.vertices) {
    const double w = std::atan2(v.pos[1], v.pos[0]);
    EXPECT_NEAR(std::hypot(v.pos[0], v.pos[1]), log.stem.radius_at(wrap_angle(w), v.pos[2]), 1e-3);
    // Normals point outwards.
    EXPECT_GT(v.normal[0] * v.pos[0] + v.normal[1] * v.pos[1], 0.0);
    zmin = std::min(zmin, static_cast<double>(v.pos[2]));
    zmax = std::max(zmax, static_cast<double>(v.pos[2]));
  }
  EXPECT_NEAR(zmin, log.stem.z_begin(), 1e-3);
  EXPECT_NEAR(zmax, log.stem.z_end(), 1e-3);
}

TEST(ViewerGeometry, BoardOutlineHasTwelveEdgesAtTheBoardsCorners) {
  render::Board b;
  b.cx = 10;
  b.cy = -20;
  b.width = 100;
  b.thickness = 40;
  b.rotation = 0.3;
  b.z0 = 100;
  b.z1 = 900;
  const Mesh m = board_outline(b, {1, 1, 0});
  ASSERT_TRUE(m.lines);
  ASSERT_EQ(m.vertices.size(), 24u);
  for (const MeshVertex& v : m.vertices) {
    const Vec3 d = Vec3{v.pos[0], v.pos[1], 0} - Vec3{b.cx, b.cy, 0};
    EXPECT_NEAR(std::abs(dot(d, b.u())), 50.0, 1e-3);
    EXPECT_NEAR(std::abs(dot(d, b.v())), 20.0, 1e-3);
    EXPECT_TRUE(std::abs(v.pos[2] - 100.0) < 1e-3 || std::abs(v.pos[2] - 900.0) < 1e-3);
  }
}

// The largest |x| and |y| of the log's outline in normalised device coordinates.
std::array<double, 2> reach(const OrbitCamera& orbit, const LogModel& log, double aspect) {
  const render::Mat4 vp = orbit.camera().view_projection(aspect);
  std::array<double, 2> r{0, 0};
  const Stem& st = log.stem;
  for (int i = 0; i < st.slice_count(); i += 10)
    for (int k = 0; k < st.n_angles; k += 10) {
      const double w = kTwoPi * k / st.n_angles;
      const Vec2 c = st.pith[i];
      const Vec3 p{c.x + st.radius[i][k] * std::cos(w), c.y + st.radius[i][k] * std::sin(w),
                   st.z_at(i)};
      const Vec3 n = vp.transform_point(p);
      r[0] = std::max(r[0], std::abs(n.x));
      r[1] = std::max(r[1], std::abs(n.y));
    }
  return r;
}

TEST(ViewerGeometry, ResetViewFitsTheWholeLogAndFillsTheView) {
  const LogModel& log = test::sample_model("gran1_spruce");
  for (double aspect : {0.6, 1.0, 2.2}) {
    for (bool ortho : {false, true}) {
      OrbitCamera orbit;
      orbit.orthographic = ortho;
      orbit.frame_log(log, aspect);
      const std::array<double, 2> r = reach(orbit, log, aspect);
      EXPECT_LE(std::max(r[0], r[1]), 0.95) << "aspect " << aspect << " ortho " << ortho;
      EXPECT_GE(std::max(r[0], r[1]), 0.75) << "aspect " << aspect << " ortho " << ortho;
    }
  }
}

TEST(ViewerGeometry, PanKeepsThePointUnderTheCursorAndRotateStopsShortOfThePoles) {
  const LogModel& log = test::sample_model("gran1_spruce");
  const double aspect = 1.5, height_px = 600, width_px = aspect * height_px;
  for (bool ortho : {false, true}) {
    OrbitCamera orbit;
    orbit.orthographic = ortho;
    orbit.frame_log(log, aspect);
    const Vec3 target = orbit.target;
    orbit.pan(30, -20, height_px);  // 30 px right, 20 px up
    const Vec3 n = orbit.camera().view_projection(aspect).transform_point(target);
    EXPECT_NEAR(0.5 * n.x * width_px, 30.0, 0.5) << "ortho " << ortho;
    EXPECT_NEAR(0.5 * n.y * height_px, 20.0, 0.5) << "ortho " << ortho;
  }
  OrbitCamera orbit;
  orbit.frame_log(log, aspect);
  orbit.rotate(0, 1e6);
  EXPECT_LE(orbit.pitch, OrbitCamera::kPitchLimit);
  orbit.rotate(0, -1e6);
  EXPECT_GE(orbit.pitch, -OrbitCamera::kPitchLimit);
  const double d = orbit.distance;
  orbit.zoom(3);
  EXPECT_NEAR(orbit.distance, d * std::pow(OrbitCamera::kZoomPerStep, 3), 1e-6 * d);
  orbit.zoom(1e4);
  EXPECT_EQ(orbit.distance, orbit.min_distance);
}

// --- the sawing mode's logic ------------------------------------------------------------------

double luminance(const std::array<unsigned char, 3>& c) {
  return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

TEST(ViewerSawing, HeatColoursGetLighterWithTheValueAndClampOutside) {
  double last = -1;
  for (int i = 0; i <= 100; ++i) {
    const double l = luminance(heat_colour(i / 100.0));
    EXPECT_GT(l, last) << "t " << i / 100.0;
    last = l;
  }
  EXPECT_EQ(heat_colour(-3.0), heat_colour(0.0));
  EXPECT_EQ(heat_colour(7.0), heat_colour(1.0));
  EXPECT_EQ(heat_colour(std::nan("")), (std::array<unsigned char, 3>{128, 128, 128}));
}

TEST(ViewerSawing, GradeColoursRunFromGreenToOrangeAndRejectIsRed) {
  const auto best = grade_colour(0, 7), last = grade_colour(6, 7), reject = grade_colour(7, 7);
  EXPECT_GT(best[1], best[0]);  // green
  EXPECT_GT(last[0], last[1]);  // orange
  EXPECT_GT(reject[0], 200);    // red
  EXPECT_LT(reject[1], 100);
  EXPECT_NE(grade_colour(3, 7), best);
  EXPECT_EQ(grade_colour(-1, 7), reject);
}

TEST(ViewerSawing, PositionParsesLikeTheSawCommand) {
  Result<sawing::LogPosition> p = sawing::parse_position("20,4,-2");
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p.value().rotation_deg, 20);
  EXPECT_EQ(p.value().offset_x_mm, 4);
  EXPECT_EQ(p.value().offset_y_mm, -2);
  EXPECT_TRUE(sawing::parse_position("15").ok());
  for (const char* bad : {"", "a", "1,2,3,4", "1,,2", "1;2"})
    EXPECT_FALSE(sawing::parse_position(bad).ok()) << bad;
}

TEST(ViewerSawing, SessionSawsValuesPlacesAndSavesThePosition) {
  Result<LogModel> log = read_log_json(test::sample_log("gran1_spruce") / "log.json");
  ASSERT_TRUE(log.ok()) << log.error().message();
  Result<std::unique_ptr<SawingSession>> made =
      SawingSession::create(log.value(), {"2ex", "nordic", ""});
  ASSERT_TRUE(made.ok()) << made.error().message();
  SawingSession& s = *made.value();
  EXPECT_GT(s.horns_down_value(), 0);
  EXPECT_NEAR(s.value().value, s.horns_down_value(), 1e-9);  // starts at horns-down
  EXPECT_NEAR(s.gain_over_horns_down(), 0.0, 1e-12);

  const sawing::LogPosition pos{20.0, 4.0, -2.0};
  s.set_position(pos);
  ASSERT_FALSE(s.sawn().boards.empty());
  ASSERT_EQ(s.value().boards.size(), s.sawn().boards.size());
  double sum = 0;
  for (const sawing::BoardValue& b : s.value().boards) sum += b.value;
  EXPECT_NEAR(s.value().value, sum, 1e-9);
  EXPECT_NEAR(s.gain_over_horns_down(), s.value().value / s.horns_down_value() - 1.0, 1e-12);

  // Each board in the scanner frame: its centre is the centre of its outline at mid-height, and
  // its width and thickness run along the outline's sides.
  for (size_t i = 0; i < s.sawn().boards.size(); ++i) {
    const sawing::Board& b = s.sawn().boards[i];
    const bool along_u = b.thickness_axis == sawing::ThicknessAxis::kU;
    const double zm = 0.5 * (b.z_begin + b.z_end);
    const std::array<Vec2, 4> c =
        s.rect_in_scanner(b.u_mm, b.v_mm, along_u ? b.thickness_mm : b.width_mm,
                          along_u ? b.width_mm : b.thickness_mm, zm);
    const render::Board rb = s.board_in_scanner(i);
    EXPECT_NEAR(0.25 * (c[0].x + c[1].x + c[2].x + c[3].x), rb.cx, 1e-6);
    EXPECT_NEAR(0.25 * (c[0].y + c[1].y + c[2].y + c[3].y), rb.cy, 1e-6);
    EXPECT_EQ(rb.width, b.width_mm);
    EXPECT_EQ(rb.thickness, b.thickness_mm);
    // The side from corner 0 to 1 runs along pattern u: the board's u when the thickness is
    // along v, its v when the thickness is along u.
    const Vec3 dir = along_u ? rb.v() : rb.u();
    const double len = std::hypot(c[1].x - c[0].x, c[1].y - c[0].y);
    EXPECT_NEAR(std::abs((c[1].x - c[0].x) * dir.x + (c[1].y - c[0].y) * dir.y), len, 1e-6);
  }
  // A drag on the section: the offset change it gives moves the pattern's outline by the drag.
  const sawing::BoardSpec& spec = s.pattern().boards.front();
  const std::array<Vec2, 4> before = s.rect_in_scanner(spec.u_mm, spec.v_mm, 50, 100, 2000);
  const Vec2 d = s.scanner_to_pattern_delta(3.0, 4.0);
  EXPECT_NEAR(std::hypot(d.x, d.y), 5.0, 1e-9);
  s.set_position({pos.rotation_deg, pos.offset_x_mm + d.x, pos.offset_y_mm + d.y});
  const std::array<Vec2, 4> after = s.rect_in_scanner(spec.u_mm, spec.v_mm, 50, 100, 2000);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(after[i].x - before[i].x, 3.0, 1e-9);
    EXPECT_NEAR(after[i].y - before[i].y, 4.0, 1e-9);
  }
  s.set_position(pos);

  test::TempDir dir;
  const fs::path out = dir / "position.json";
  ASSERT_TRUE(s.save(out, log.value().id).ok());
  Result<sawing::LogPosition> back = read_saw_position(out);
  ASSERT_TRUE(back.ok()) << back.error().message();
  EXPECT_EQ(back.value().rotation_deg, pos.rotation_deg);
  EXPECT_EQ(back.value().offset_x_mm, pos.offset_x_mm);
  EXPECT_EQ(back.value().offset_y_mm, pos.offset_y_mm);
  std::ifstream in(out);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_THAT(text, HasSubstr("\"format\": \"sawyer-sawing/1\""));
  EXPECT_THAT(text, HasSubstr("\"given_position\""));
  EXPECT_THAT(text, HasSubstr("\"limited_by\""));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1)
      << "no temporary file left";

  EXPECT_FALSE(read_saw_position(dir / "missing.json").ok());
  {
    std::ofstream bad(dir / "bad.json");
    bad << "{\"format\": \"sawyer-sawing/1\", \"horns_down\": {\"rotation_deg\": 0, "
           "\"offset_x_mm\": 0, \"offset_y_mm\": 0, \"value\": 1}, "
           "\"given_position\": {\"rotation_deg\": 1}}";
  }
  Result<sawing::LogPosition> bad = read_saw_position(dir / "bad.json");
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.error().message(), HasSubstr("offset_x_mm"));
  // The one sawing-file reader (sawyer/sawing/sawing_file.h) wants the format tag.
  {
    std::ofstream untagged(dir / "untagged.json");
    untagged << "{\"given_position\": {\"rotation_deg\": 1, \"offset_x_mm\": 0, "
                "\"offset_y_mm\": 0, \"value\": 1}}";
  }
  Result<sawing::LogPosition> untagged = read_saw_position(dir / "untagged.json");
  ASSERT_FALSE(untagged.ok());
  EXPECT_THAT(untagged.error().message(), HasSubstr("untagged.json: format"));
}

TEST(ViewerSawing, UnknownPatternOrGradingIsAnErrorNamingIt) {
  Result<LogModel> log = read_log_json(test::sample_log("gran1_spruce") / "log.json");
  ASSERT_TRUE(log.ok());
  Result<std::unique_ptr<SawingSession>> p =
      SawingSession::create(log.value(), {"no_such.pattern.json", "nordic", ""});
  ASSERT_FALSE(p.ok());
  EXPECT_THAT(p.error().message(), HasSubstr("no_such.pattern.json"));
  Result<std::unique_ptr<SawingSession>> g =
      SawingSession::create(log.value(), {"2ex", "no_such_grading.json", ""});
  ASSERT_FALSE(g.ok());
  EXPECT_THAT(g.error().message(), HasSubstr("no_such_grading.json"));
}

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

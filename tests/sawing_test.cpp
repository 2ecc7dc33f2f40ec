// Virtual sawing: patterns, the pattern file, log positions, board geometry, wane and knots on
// the board sides, on synthetic logs whose answers are known.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>

#include "sawyer/sawing/pattern.h"
#include "sawyer/sawing/sawing.h"
#include "sawyer/test/test_util.h"

using namespace sawyer;
using namespace sawyer::sawing;

namespace {

// A log along z from 0 to `length` (10 mm samples), radius R(z), pith p(z).
LogModel make_log(
    double length, const std::function<double(double)>& radius,
    const std::function<Vec2(double)>& pith = [](double) {
      return Vec2{0, 0};
    }) {
  LogModel log;
  log.id = "synthetic";
  log.stem.dz_mm = 10.0;
  log.stem.z0_mm = 5.0;
  log.stem.n_angles = 360;
  const int n = static_cast<int>(length / 10.0);
  for (int i = 0; i < n; ++i) {
    const double z = log.stem.z_at(i);
    log.stem.pith.push_back(pith(z));
    log.stem.radius.push_back(std::vector<double>(360, radius(z)));
  }
  return log;
}

LogModel cylinder(double R, double length = 3000.0) {
  return make_log(length, [R](double) { return R; });
}

// A straight horizontal knot at height z0 along azimuth omega0: axis r ↦ (r cos ω, r sin ω, z0),
// diameter d(r) = 30·r/60 up to r_dead = 60, then 30.
Knot straight_knot(int id, double z0, double omega0) {
  Knot k;
  k.id = id;
  k.z0 = z0;
  k.omega0 = omega0;
  k.r_dead = 60.0;
  k.r_end = 150.0;
  k.diameter.d_dead = 30.0;
  k.diameter.exponent = 1.0;
  return k;
}

Pattern single_board(double u, double v, double thickness, double width,
                     ThicknessAxis axis = ThicknessAxis::kU) {
  Pattern p;
  p.name = "test";
  p.wane.min_length_mm = 0;
  p.wane.length_step_mm = 0;
  BoardSpec b;
  b.name = "b";
  b.u_mm = u;
  b.v_mm = v;
  b.thickness_mm = thickness;
  b.width_mm = width;
  b.thickness_axis = axis;
  p.boards.push_back(b);
  return p;
}

}  // namespace

TEST(Sawing, PerpendicularKnotCrossesFaceAtPredictedPlaceAndSize) {
  LogModel log = cylinder(200.0);
  log.knots.push_back(straight_knot(7, 1500.0, 0.0));
  const SawLog saw_log(log);
  // Straight log: rotation 0 leaves the pattern frame on the scanner frame (u = x, v = y).
  for (const auto& [u, inner_dead, outer_dead] :
       {std::tuple{40.0, false, false}, std::tuple{60.0, false, true},
        std::tuple{100.0, true, true}}) {
    SCOPED_TRACE(u);
    const SawResult r = saw(saw_log, single_board(u, 0.0, 20.0, 100.0), {});
    ASSERT_EQ(r.boards.size(), 1u);
    const Board& b = r.boards[0];
    ASSERT_EQ(b.knots.size(), 2u);
    for (const KnotOnSide& k : b.knots) {
      const bool plus = k.side == Side::kFacePlus;
      EXPECT_TRUE(plus || k.side == Side::kFaceMinus);
      const double rr = plus ? u + 10.0 : u - 10.0;
      const double d = 30.0 * std::min(rr, 60.0) / 60.0;
      EXPECT_EQ(k.knot_id, 7);
      EXPECT_EQ(k.kind, KnotKind::kFace);
      EXPECT_NEAR(k.z_mm, 1500.0, 1e-6);
      EXPECT_NEAR(k.along_mm, 1500.0 - b.z_begin, 1e-6);
      EXPECT_NEAR(k.across_mm, 0.0, 1e-6);
      EXPECT_NEAR(k.r_mm, rr, 1e-6);
      EXPECT_NEAR(k.diameter_mm, d, 1e-6);
      EXPECT_NEAR(k.minor_mm, d, 1e-6);
      EXPECT_NEAR(k.major_mm, d, 1e-6);
      EXPECT_NEAR(k.width_mm, d, 1e-6);
      EXPECT_NEAR(k.length_mm, d, 1e-6);
      EXPECT_NEAR(k.angle_deg, 90.0, 1e-6);
      EXPECT_EQ(k.dead, plus ? outer_dead : inner_dead);
    }
    EXPECT_TRUE(b.hidden_knots.empty());
  }
}

TEST(Sawing, KnotAtAnAngleShowsAnElongatedSection) {
  LogModel log = cylinder(200.0);
  Knot k = straight_knot(1, 1500.0, 0.0);
  k.b = 1.0;  // rises 1 mm per mm: 45° to the face
  log.knots.push_back(k);
  const SawResult r = saw(SawLog(log), single_board(50.0, 0.0, 20.0, 100.0), {});
  ASSERT_EQ(r.boards.size(), 1u);
  ASSERT_EQ(r.boards[0].knots.size(), 2u);
  const KnotOnSide& inner = r.boards[0].knots[1];
  ASSERT_EQ(inner.side, Side::kFaceMinus);
  EXPECT_NEAR(inner.z_mm, 1540.0, 1e-6);
  EXPECT_NEAR(inner.diameter_mm, 20.0, 1e-6);
  EXPECT_NEAR(inner.major_mm, 20.0 * std::sqrt(2.0), 1e-6);
  EXPECT_NEAR(inner.width_mm, 20.0, 1e-6);
  EXPECT_NEAR(inner.length_mm, 20.0 * std::sqrt(2.0), 1e-6);
  EXPECT_NEAR(inner.angle_deg, 45.0, 1e-6);
}

TEST(Sawing, EdgeAndArrisKnots) {
  LogModel log = cylinder(200.0);
  log.knots.push_back(
      straight_knot(1, 1000.0, 0.5 * kPi));            // along +v: crosses edges of a kU board
  log.knots.push_back(straight_knot(2, 2000.0, 0.0));  // along +u at v = 0
  // Board 20 thick (u ∈ [−10, 10]), 100 wide (v ∈ [−50, 50]) centred on the pith: knot 1 leaves
  // through edge+ (v = 50), knot 2 through face+ (u = 10); both start inside the board.
  const SawResult r = saw(SawLog(log), single_board(0.0, 0.0, 20.0, 100.0), {});
  ASSERT_EQ(r.boards.size(), 1u);
  int edge = 0, face = 0;
  for (const KnotOnSide& k : r.boards[0].knots) {
    if (k.knot_id == 1) {
      EXPECT_EQ(k.side, Side::kEdgePlus);
      EXPECT_EQ(k.kind, KnotKind::kArris);  // 25 mm across a 20 mm edge
      EXPECT_NEAR(k.r_mm, 50.0, 1e-6);
      ++edge;
    } else {
      EXPECT_EQ(k.side, Side::kFacePlus);
      EXPECT_EQ(k.kind, KnotKind::kFace);
      EXPECT_NEAR(k.diameter_mm, 5.0, 1e-6);
      ++face;
    }
  }
  EXPECT_EQ(edge, 1);
  EXPECT_EQ(face, 1);
}

TEST(Sawing, ClearLogGivesBoardsWithoutKnots) {
  const LogModel log = cylinder(200.0);
  const SawResult r = saw(SawLog(log), two_ex_pattern({}), {});
  ASSERT_EQ(r.boards.size(), 4u);
  for (const Board& b : r.boards) {
    EXPECT_TRUE(b.knots.empty());
    EXPECT_TRUE(b.hidden_knots.empty());
  }
}

TEST(Sawing, TwoExPatternIsSymmetric) {
  const Pattern p = two_ex_pattern({});
  ASSERT_EQ(p.boards.size(), 4u);
  EXPECT_NEAR(p.boards[0].u_mm, -p.boards[1].u_mm, 1e-12);
  EXPECT_NEAR(p.boards[1].u_mm, 26.5, 1e-12);
  EXPECT_NEAR(p.boards[2].u_mm, -p.boards[3].u_mm, 1e-12);
  EXPECT_NEAR(p.boards[3].u_mm, 51.5 + 3.0 + 12.5, 1e-12);  // outer centre face + kerf + half side

  // Two knots mirrored about the plane u = 0 (ω ↦ π − ω), rising through the wood.
  LogModel log = cylinder(170.0);
  for (auto [id, w] : {std::pair{1, 0.2}, std::pair{2, kPi - 0.2}}) {
    Knot k = straight_knot(id, 1200.0, w);
    k.a = 4.0;
    k.b = 0.2;
    k.r_end = 160.0;
    log.knots.push_back(k);
  }
  const SawResult r = saw(SawLog(log), p, {});
  ASSERT_EQ(r.boards.size(), 4u);
  auto mirror = [](Side s) {
    return s == Side::kFacePlus ? Side::kFaceMinus : s == Side::kFaceMinus ? Side::kFacePlus : s;
  };
  for (auto [left, right] : {std::pair{0, 1}, std::pair{2, 3}}) {
    const Board& l = r.boards[left];
    const Board& rt = r.boards[right];
    EXPECT_NEAR(l.volume_m3, rt.volume_m3, 1e-9);
    EXPECT_NEAR(l.width_mm, rt.width_mm, 1e-9);
    EXPECT_NEAR(l.z_begin, rt.z_begin, 1e-9);
    ASSERT_EQ(l.knots.size(), rt.knots.size());
    ASSERT_FALSE(l.knots.empty());
    for (const KnotOnSide& a : l.knots) {
      EXPECT_EQ(a.knot_id, 2);  // the knot along −u
      bool found = false;
      for (const KnotOnSide& b : rt.knots) {
        if (b.side != mirror(a.side)) continue;
        found = true;
        EXPECT_EQ(b.knot_id, 1);
        EXPECT_NEAR(a.z_mm, b.z_mm, 1e-6);
        EXPECT_NEAR(a.across_mm, b.across_mm, 1e-6);
        EXPECT_NEAR(a.r_mm, b.r_mm, 1e-6);
        EXPECT_NEAR(a.minor_mm, b.minor_mm, 1e-6);
        EXPECT_NEAR(a.major_mm, b.major_mm, 1e-6);
        EXPECT_EQ(a.dead, b.dead);
        EXPECT_EQ(a.kind, b.kind);
      }
      EXPECT_TRUE(found) << side_name(a.side);
    }
  }
}

TEST(Sawing, FourExAndThroughAndThroughPresets) {
  const Pattern four = four_ex_pattern({});
  ASSERT_EQ(four.boards.size(), 6u);
  EXPECT_NEAR(four.boards[0].u_mm, -1.5 * 53.0, 1e-12);
  EXPECT_NEAR(four.boards[3].u_mm, 1.5 * 53.0, 1e-12);
  EXPECT_TRUE(four.validate());
  const Pattern tt = through_and_through_pattern(5, 25.0);
  ASSERT_EQ(tt.boards.size(), 5u);
  EXPECT_NEAR(tt.boards[2].u_mm, 0.0, 1e-12);
  EXPECT_NEAR(tt.boards[4].u_mm, 56.0, 1e-12);
  EXPECT_TRUE(tt.validate());
  // Through-and-through boards are edged to standard widths the log allows.
  const SawResult r = saw(SawLog(cylinder(120.0)), tt, {});
  ASSERT_EQ(r.boards.size(), 5u);
  for (const Board& b : r.boards) {
    EXPECT_NE(std::find(tt.standard_widths_mm.begin(), tt.standard_widths_mm.end(), b.width_mm),
              tt.standard_widths_mm.end());
  }
  EXPECT_GT(r.boards[2].width_mm, r.boards[0].width_mm);
  EXPECT_NEAR(r.boards[0].width_mm, r.boards[4].width_mm, 1e-12);
}

TEST(Sawing, PatternTooBigForTheLogIsRefusedNamingTheUsableDiameter) {
  const LogModel log = cylinder(80.0);
  const SawLog saw_log(log);
  EXPECT_NEAR(saw_log.usable_diameter_mm(), 160.0, 1e-9);
  const Pattern p = two_ex_pattern({});  // corners at (51.5, 75): needs 182 mm
  const Status s = check_pattern_fits(p, saw_log.usable_diameter_mm(), log.id);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message().find("usable diameter is 160.0 mm"), std::string::npos)
      << s.error().message();
  EXPECT_NE(s.error().message().find("182.0"), std::string::npos) << s.error().message();
  EXPECT_NE(s.error().message().find("synthetic"), std::string::npos);
  EXPECT_TRUE(check_pattern_fits(p, 200.0, log.id).ok());
}

TEST(Sawing, UsableDiameterIsTheTopEnd) {
  const LogModel log = make_log(3000.0, [](double z) { return 150.0 - 0.02 * z; });
  EXPECT_NEAR(SawLog(log).usable_diameter_mm(), 2 * (150.0 - 0.02 * 2995.0), 1e-9);
}

TEST(Sawing, PatternFileRoundTrip) {
  test::TempDir dir;
  Pattern p = four_ex_pattern({});
  p.kerf_mm = 2.5;
  p.wane.max_face_fraction = 0.3;
  p.wane.length_step_mm = 0;
  p.standard_widths_mm = {100, 150};
  p.boards[1].thickness_axis = ThicknessAxis::kV;
  p.boards[1].thickness_mm = 10;
  p.boards[1].width_mm = 50;
  ASSERT_TRUE(write_pattern_file(dir / "p.json", p).ok());
  const Result<Pattern> q = read_pattern_file(dir / "p.json");
  ASSERT_TRUE(q.ok()) << q.error().message();
  EXPECT_EQ(q.value().name, p.name);
  EXPECT_EQ(q.value().kerf_mm, 2.5);
  EXPECT_EQ(q.value().wane.max_face_fraction, 0.3);
  EXPECT_EQ(q.value().wane.length_step_mm, 0);
  EXPECT_EQ(q.value().standard_widths_mm, p.standard_widths_mm);
  ASSERT_EQ(q.value().boards.size(), p.boards.size());
  for (size_t i = 0; i < p.boards.size(); ++i) {
    EXPECT_EQ(q.value().boards[i].name, p.boards[i].name);
    EXPECT_EQ(q.value().boards[i].u_mm, p.boards[i].u_mm);
    EXPECT_EQ(q.value().boards[i].v_mm, p.boards[i].v_mm);
    EXPECT_EQ(q.value().boards[i].thickness_mm, p.boards[i].thickness_mm);
    EXPECT_EQ(q.value().boards[i].width_mm, p.boards[i].width_mm);
    EXPECT_EQ(q.value().boards[i].thickness_axis, p.boards[i].thickness_axis);
    EXPECT_EQ(q.value().boards[i].edged, p.boards[i].edged);
  }
}

TEST(Sawing, BadPatternFilesGiveOneClearError) {
  test::TempDir dir;
  auto error_of = [&](const std::string& text) {
    test::write_file(dir / "bad.json", text);
    const Result<Pattern> r = read_pattern_file(dir / "bad.json");
    EXPECT_FALSE(r.ok());
    return r.ok() ? std::string() : r.error().message();
  };
  const std::string file = (dir / "bad.json").string();
  auto has = [](const std::string& msg, const std::string& part) {
    return msg.find(part) != std::string::npos;
  };
  std::string m = error_of("{\"format\": \"sawyer-pattern/1\",\n \"boards\": [");
  EXPECT_TRUE(has(m, file) && has(m, "malformed JSON")) << m;
  m = error_of(R"({"format": "sawyer-log/1", "boards": []})");
  EXPECT_TRUE(has(m, file) && has(m, "format")) << m;
  m = error_of(R"({"format": "sawyer-pattern/1"})");
  EXPECT_TRUE(has(m, file) && has(m, "boards: missing")) << m;
  m = error_of(
      R"({"format": "sawyer-pattern/1", "boards": [{"u_mm": 0, "v_mm": 0, "width_mm": 100}]})");
  EXPECT_TRUE(has(m, file) && has(m, "boards[0].thickness_mm: missing")) << m;
  m = error_of(
      R"({"format": "sawyer-pattern/1", "boards": [{"u_mm": 0, "v_mm": 0, "thickness_mm": "50", "width_mm": 100}]})");
  EXPECT_TRUE(has(m, "boards[0].thickness_mm: expected a number")) << m;
  m = error_of(
      R"({"format": "sawyer-pattern/1", "boards": [{"u_mm": 0, "v_mm": 0, "thickness_mm": -5, "width_mm": 100}]})");
  EXPECT_TRUE(has(m, file) && has(m, "board 0") && has(m, "> 0")) << m;
  m = error_of(R"({"format": "sawyer-pattern/1", "boards": [
      {"u_mm": 0, "v_mm": 0, "thickness_mm": 50, "width_mm": 100},
      {"u_mm": 20, "v_mm": 0, "thickness_mm": 50, "width_mm": 100}]})");
  EXPECT_TRUE(has(m, "board 1") && has(m, "overlaps board 0")) << m;
  m = error_of(
      R"({"format": "sawyer-pattern/1", "boards": [{"u_mm": 0, "v_mm": 0, "thickness_mm": 5, "width_mm": 100, "thickness_axis": "x"}]})");
  EXPECT_TRUE(has(m, "boards[0].thickness_axis")) << m;
  const Result<Pattern> missing = read_pattern_file(dir / "nope.json");
  ASSERT_FALSE(missing.ok());
  EXPECT_TRUE(has(missing.error().message(), "nope.json")) << missing.error().message();
}

TEST(Sawing, BoardVolumeInABigCylinderIsTheBox) {
  const SawResult r = saw(SawLog(cylinder(500.0)), single_board(30.0, -20.0, 50.0, 150.0), {});
  ASSERT_EQ(r.boards.size(), 1u);
  const Board& b = r.boards[0];
  EXPECT_NEAR(b.length_mm(), 3000.0, 1e-9);
  EXPECT_NEAR(b.volume_m3, 0.050 * 0.150 * 3.0, 1e-12);
  EXPECT_NEAR(b.box_volume_m3, b.volume_m3, 1e-15);
  for (const SideWane& w : b.wane) EXPECT_EQ(w.max_mm, 0.0);
  EXPECT_NEAR(r.volume_m3, b.volume_m3, 1e-15);
}

TEST(Sawing, WaneWhereABoardLeavesASmallCylinder) {
  // 60 × 150 board about the pith in an R = 80 cylinder: the corners (30, 75) lie outside.
  const SawResult r = saw(SawLog(cylinder(80.0)), single_board(0.0, 0.0, 60.0, 150.0), {});
  ASSERT_EQ(r.boards.size(), 1u);
  const Board& b = r.boards[0];
  const double face = 2 * (75.0 - std::sqrt(80.0 * 80.0 - 30.0 * 30.0));  // both ends of a face
  const double edge = 2 * (30.0 - std::sqrt(80.0 * 80.0 - 75.0 * 75.0));
  EXPECT_NEAR(b.wane[int(Side::kFacePlus)].max_mm, face, 0.05);
  EXPECT_NEAR(b.wane[int(Side::kFaceMinus)].max_mm, face, 0.05);
  EXPECT_NEAR(b.wane[int(Side::kEdgePlus)].max_mm, edge, 0.05);
  EXPECT_NEAR(b.wane[int(Side::kEdgeMinus)].max_mm, edge, 0.05);
  EXPECT_NEAR(b.wane[int(Side::kEdgePlus)].length_mm, 3000.0, 1e-9);
  EXPECT_LT(b.volume_m3, b.box_volume_m3);
  const double missing = 4 * 0.5 * (face / 2) * (edge / 2) * 3000.0 * 1e-9;
  EXPECT_NEAR(b.box_volume_m3 - b.volume_m3, missing, 0.1 * missing);
}

TEST(Sawing, BoardIsTrimmedWhereTheWaneExceedsTheRules) {
  // A cone from R = 100 to R = 55: a 40 × 120 board (corner radius 63.2) gets too much wane near
  // the top and is trimmed to whole 300 mm steps, centred in the run of acceptable wane.
  const LogModel log = make_log(3000.0, [](double z) { return 100.0 - 0.015 * z; });
  Pattern p = single_board(0.0, 0.0, 40.0, 120.0);
  p.wane.length_step_mm = 300.0;
  p.wane.min_length_mm = 900.0;
  const SawResult r = saw(SawLog(log), p, {});
  ASSERT_EQ(r.boards.size(), 1u);
  const Board& b = r.boards[0];
  EXPECT_LT(b.z_end, 3000.0);
  EXPECT_NEAR(std::fmod(b.length_mm() + 1e-6, 300.0), 0.0, 1e-5);
  EXPECT_LE(b.wane[int(Side::kFacePlus)].max_mm, 0.25 * 120.0 + 1e-9);
  EXPECT_LE(b.wane[int(Side::kEdgePlus)].max_mm, 0.5 * 40.0 + 1e-9);
  // Too short a minimum length drops it.
  p.wane.min_length_mm = 2900.0;
  const SawResult none = saw(SawLog(log), p, {});
  EXPECT_TRUE(none.boards.empty());
  ASSERT_EQ(none.dropped.size(), 1u);
  EXPECT_EQ(none.dropped[0].spec, 0);
}

TEST(Sawing, BowDetectionFindsTheHornsFromAConstructedPith) {
  const double L = 3000.0;
  // Middle bulging 20 mm towards −y: horns point +y.
  const LogModel down = make_log(
      L, [](double) { return 150.0; },
      [L](double z) {
        return Vec2{5.0, 3.0 - 20.0 * std::sin(kPi * z / L)};
      });
  BowInfo b = detect_bow(down.stem);
  EXPECT_NEAR(b.horns_azimuth, 0.5 * kPi, 1e-6);
  EXPECT_NEAR(b.height_mm, 20.0, 0.25);  // chord through the end samples, 5 mm in
  // Middle bulging towards (1, 1)/√2: horns at 225°.
  const LogModel diag = make_log(
      L, [](double) { return 150.0; },
      [L](double z) {
        const double s = 10.0 * std::sin(kPi * z / L);
        return Vec2{s, s};
      });
  b = detect_bow(diag.stem);
  EXPECT_NEAR(b.horns_azimuth, 1.25 * kPi, 1e-6);
  // A straight log has no bow and the default horns direction (−y).
  b = detect_bow(cylinder(100.0).stem);
  EXPECT_EQ(b.height_mm, 0.0);
  EXPECT_NEAR(b.horns_azimuth, 1.5 * kPi, 1e-12);
}

TEST(Sawing, RotationZeroPutsTheHornsDown) {
  // Bowed log, horns towards +x; a knot along +x (the horns' side) must come out along −v at
  // rotation 0 and along +u at rotation 90° (counter-clockwise).
  const double L = 3000.0;
  LogModel log = make_log(
      L, [](double) { return 200.0; },
      [L](double z) {
        return Vec2{-15.0 * std::sin(kPi * z / L), 0.0};
      });
  log.knots.push_back(straight_knot(1, 1500.0, 0.0));
  const SawLog saw_log(log);
  EXPECT_NEAR(saw_log.bow().horns_azimuth, 0.0, 1e-6);
  // Horizontal board below the pith (thickness along v): the knot crosses its faces.
  const Pattern below = single_board(0.0, -60.0, 20.0, 100.0, ThicknessAxis::kV);
  SawResult r = saw(saw_log, below, {});
  ASSERT_EQ(r.boards.size(), 1u);
  EXPECT_EQ(r.boards[0].knots.size(), 2u);
  // At rotation 90° the knot points along +u instead and misses that board.
  r = saw(saw_log, below, {.rotation_deg = 90.0});
  ASSERT_EQ(r.boards.size(), 1u);
  EXPECT_TRUE(r.boards[0].knots.empty());
  const Pattern right = single_board(60.0, 0.0, 20.0, 100.0);
  r = saw(saw_log, right, {.rotation_deg = 90.0});
  ASSERT_EQ(r.boards.size(), 1u);
  EXPECT_EQ(r.boards[0].knots.size(), 2u);
  // An offset moves the pattern: the board at u = 60 shifted by x = −60 sits on the pith.
  r = saw(saw_log, right, {.rotation_deg = 90.0, .offset_x_mm = -60.0});
  ASSERT_EQ(r.boards.size(), 1u);
  ASSERT_EQ(r.boards[0].knots.size(), 1u);
  EXPECT_EQ(r.boards[0].knots[0].side, Side::kFacePlus);
}

TEST(Sawing, KnotInsideABoardIsHidden) {
  LogModel log = cylinder(200.0);
  Knot k = straight_knot(3, 1500.0, 0.0);
  k.r_end = 8.0;  // ends inside a 20 mm board centred on the pith
  log.knots.push_back(k);
  const SawResult r = saw(SawLog(log), single_board(0.0, 0.0, 20.0, 100.0), {});
  ASSERT_EQ(r.boards.size(), 1u);
  EXPECT_TRUE(r.boards[0].knots.empty());
  ASSERT_EQ(r.boards[0].hidden_knots.size(), 1u);
  EXPECT_EQ(r.boards[0].hidden_knots[0], 0);
}

TEST(Sawing, Gran1TwoExAtHornsDown) {
  const LogModel& log = test::sample_model("gran1_spruce");
  ASSERT_FALSE(log.knots.empty());
  const SawLog saw_log(log);
  const Pattern p = two_ex_pattern({});
  ASSERT_TRUE(check_pattern_fits(p, saw_log.usable_diameter_mm(), log.id).ok());
  const SawResult r = saw(saw_log, p, {});
  ASSERT_EQ(r.boards.size(), 4u);
  double log_volume = 0;
  for (int i = 0; i < log.stem.slice_count(); ++i)
    log_volume += log.stem.area(i) * log.stem.dz_mm * 1e-9;
  EXPECT_LT(r.volume_m3, log_volume);
  for (const Board& b : r.boards) {
    EXPECT_GE(b.length_mm(), p.wane.min_length_mm);
    EXPECT_LE(b.volume_m3, b.box_volume_m3);
    for (const KnotOnSide& k : b.knots) {
      const Knot& knot = log.knots[k.knot];
      EXPECT_EQ(k.knot_id, knot.id);
      EXPECT_LE(k.r_mm, knot.r_end + 1e-9);
      EXPECT_NEAR(k.diameter_mm, knot.diameter_at(k.r_mm), 1e-9);
      EXPECT_EQ(k.dead, k.r_mm > knot.r_dead);
      EXPECT_GE(k.major_mm, k.minor_mm);
      EXPECT_GT(k.width_mm, 0.0);
      // The crossing lies on the knot's axis: its height matches the knot formula at r.
      EXPECT_NEAR(k.z_mm, knot.height_at(k.r_mm), 1.0);
    }
  }
  EXPECT_FALSE(r.boards[0].knots.empty());
}

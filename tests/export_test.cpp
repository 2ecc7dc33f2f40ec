// sawyer::export and `sawyer export`: the .glb container against the glTF 2.0 layout (and the
// .gltf with its files beside it against the .glb), a board's
// baked atlas read back through the mesh's texture coordinates against the renderer's own
// image of each face, the normal and roughness maps' properties, the boards of a sawing.json by
// number, grade and size, refusals of bad input, and (where installed) the Khronos glTF
// validator and Blender: its importer finds the boards, Cycles renders a face that agrees with
// Sawyer's.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sawyer/export/board_bake.h"
#include "sawyer/export/export_job.h"
#include "sawyer/export/glb_writer.h"
#include "sawyer/render/gl_context.h"
#include "sawyer/render/scene.h"
#include "sawyer/render/views.h"
#include "sawyer/render/wood_renderer.h"
#include "sawyer/test/test_util.h"

namespace sawyer::exporter {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// ---- reading a .glb back ----------------------------------------------------------------------

std::uint32_t u32(const std::vector<std::uint8_t>& b, size_t at) {
  return b[at] | b[at + 1] << 8 | b[at + 2] << 16 | static_cast<std::uint32_t>(b[at + 3]) << 24;
}

struct Glb {
  json j;
  std::vector<std::uint8_t> bin;
};

// Parses the container, checking its header and chunks as the specification states them.
Glb parse_glb(const std::vector<std::uint8_t>& b) {
  Glb g;
  EXPECT_GE(b.size(), 20u);
  if (b.size() < 20) return g;
  EXPECT_EQ(u32(b, 0), 0x46546C67u);  // "glTF"
  EXPECT_EQ(u32(b, 4), 2u);
  EXPECT_EQ(u32(b, 8), b.size());
  const std::uint32_t jlen = u32(b, 12);
  EXPECT_EQ(u32(b, 16), 0x4E4F534Au);  // "JSON"
  EXPECT_EQ(jlen % 4, 0u);
  g.j = json::parse(b.begin() + 20, b.begin() + 20 + jlen);
  const size_t at = 20 + jlen;
  if (at < b.size()) {
    const std::uint32_t blen = u32(b, at);
    EXPECT_EQ(u32(b, at + 4), 0x004E4942u);  // "BIN\0"
    EXPECT_EQ(blen % 4, 0u);
    EXPECT_EQ(at + 8 + blen, b.size());
    g.bin.assign(b.begin() + at + 8, b.begin() + at + 8 + blen);
    EXPECT_EQ(g.j["buffers"][0]["byteLength"].get<size_t>(), blen);
  }
  return g;
}

Glb read_glb(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::vector<std::uint8_t> b((std::istreambuf_iterator<char>(f)),
                              std::istreambuf_iterator<char>());
  return parse_glb(b);
}

std::vector<std::uint8_t> file_bytes(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// A .gltf and the .bin its buffer names, as a Glb (the JSON and the binary buffer).
Glb read_gltf(const fs::path& p) {
  Glb g;
  std::ifstream f(p);
  g.j = json::parse(f);
  EXPECT_EQ(g.j["buffers"].size(), 1u);
  const std::string uri = g.j["buffers"][0]["uri"];
  g.bin = file_bytes(p.parent_path() / uri);
  EXPECT_EQ(g.j["buffers"][0]["byteLength"].get<size_t>(), g.bin.size());
  return g;
}

std::vector<std::uint8_t> view_bytes(const Glb& g, int view) {
  const json& v = g.j["bufferViews"][view];
  const size_t off = v.value("byteOffset", 0), len = v["byteLength"];
  EXPECT_LE(off + len, g.bin.size());
  EXPECT_EQ(off % 4, 0u);
  return {g.bin.begin() + off, g.bin.begin() + off + len};
}

std::vector<float> floats(const Glb& g, int accessor) {
  const json& a = g.j["accessors"][accessor];
  EXPECT_EQ(a["componentType"], 5126);
  const std::vector<std::uint8_t> b = view_bytes(g, a["bufferView"]);
  std::vector<float> out(b.size() / 4);
  std::memcpy(out.data(), b.data(), out.size() * 4);
  return out;
}

render::Image image(const Glb& g, int index, const fs::path& tmp) {
  const std::vector<std::uint8_t> b = view_bytes(g, g.j["images"][index]["bufferView"]);
  EXPECT_EQ(g.j["images"][index]["mimeType"], "image/png");
  test::write_file(tmp, std::string(b.begin(), b.end()));
  Result<render::Image> img = render::read_image(tmp);
  EXPECT_TRUE(img.ok()) << (img.ok() ? "" : img.error().message());
  return img.ok() ? img.value() : render::Image{};
}

const json& node_named(const Glb& g, const std::string& name) {
  for (const json& n : g.j["nodes"])
    if (n["name"] == name) return n;
  static const json none;
  ADD_FAILURE() << "no node " << name;
  return none;
}

// A box's edge lengths (m, longest first): its extent along each of its faces' normals.
std::vector<double> box_edges(const std::vector<float>& pos, const std::vector<float>& nrm) {
  std::vector<Vec3> dirs;
  for (size_t i = 0; i < nrm.size(); i += 3) {
    const Vec3 n{nrm[i], nrm[i + 1], nrm[i + 2]};
    if (std::all_of(dirs.begin(), dirs.end(),
                    [&](const Vec3& d) { return std::abs(dot(n, d)) < 0.999; }))
      dirs.push_back(n);
  }
  std::vector<double> out;
  for (const Vec3& d : dirs) {
    double lo = 1e30, hi = -1e30;
    for (size_t i = 0; i < pos.size(); i += 3) {
      const double s = dot(Vec3{pos[i], pos[i + 1], pos[i + 2]}, d);
      lo = std::min(lo, s);
      hi = std::max(hi, s);
    }
    out.push_back(hi - lo);
  }
  std::sort(out.rbegin(), out.rend());
  return out;
}

// ---- fixtures ---------------------------------------------------------------------------------

const char* kBoard = "0,40,150,50,0,1000,2200";  // x,y,w,t,rot°,z0,z1 from the mean pith

render::Image render_top_face(const BoardBox& scanner_box, int w, int h) {
  render::ShadeOptions s;
  s.lighting = false;
  s.bark = true;
  render::FaceLayout layout;
  layout.stretch = true;
  layout.gap_px = 0;
  layout.supersample = 2;
  auto ctx = render::create_headless_context();
  EXPECT_TRUE(ctx.ok());
  auto r = render::WoodRenderer::create(test::sample_model("gran1_spruce"), {});
  EXPECT_TRUE(r.ok());
  Result<render::Image> img = render::render_board_faces(
      *r.value(), scanner_box, static_cast<unsigned>(render::Face::kTop), {w, h}, s, layout);
  EXPECT_TRUE(img.ok()) << (img.ok() ? "" : img.error().message());
  return img.ok() ? img.value() : render::Image{};
}

// Mean absolute difference of RGB (0..1) between two images of equal size; `flip`: the second
// turned half round (its rows and columns reversed).
double mean_abs_diff(const render::Image& a, const render::Image& b, bool flip = false) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  double sum = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x)
      for (int c = 0; c < 3; ++c) {
        const int bx = flip ? b.width - 1 - x : x, by = flip ? b.height - 1 - y : y;
        sum += std::abs(a.value(x, y, c) - b.value(bx, by, c));
      }
  return sum / (3.0 * a.width * a.height);
}

ExportOptions one_board(const fs::path& out, double px_per_mm) {
  ExportOptions o;
  o.boards.push_back(BoardBox::from_string(kBoard).value());
  o.output = out;
  o.px_per_mm = px_per_mm;
  return o;
}

// ---- the container ----------------------------------------------------------------------------

TEST(GlbWriter, ContainerChunksAccessorsAndImagesFollowTheSpecification) {
  GlbScene s;
  s.name = "one triangle";
  s.extras = {{"log_id", "x"}};
  GlbMesh m;
  m.name = "tri";
  m.translation = {1.0, 2.0, 3.0};
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0.5f};
  m.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1};
  m.uvs = {0, 0, 1, 0, 0, 1};
  m.indices = {0, 1, 2};
  render::Image img;
  img.width = 3;
  img.height = 2;
  img.u8 = std::vector<std::uint8_t>(24, 200);
  Result<std::vector<std::uint8_t>> png = encode_png(img);
  ASSERT_TRUE(png.ok()) << png.error().message();
  s.images.push_back(png.value());
  m.base_color = 0;
  s.meshes.push_back(m);
  const Glb g = parse_glb(glb_bytes(s));
  EXPECT_EQ(g.j["asset"]["version"], "2.0");
  EXPECT_EQ(g.j["scenes"][0]["extras"]["log_id"], "x");
  const json& node = g.j["nodes"][0];
  EXPECT_EQ(node["name"], "tri");
  EXPECT_EQ(node["translation"], json::array({1.0, 2.0, 3.0}));
  const json& prim = g.j["meshes"][node["mesh"].get<int>()]["primitives"][0];
  const int pa = prim["attributes"]["POSITION"];
  EXPECT_EQ(floats(g, pa), m.positions);
  EXPECT_EQ(g.j["accessors"][pa]["min"], json::array({0.0, 0.0, 0.0}));
  EXPECT_EQ(g.j["accessors"][pa]["max"], json::array({1.0, 1.0, 0.5}));
  EXPECT_EQ(floats(g, prim["attributes"]["TEXCOORD_0"]), m.uvs);
  // The image comes back byte for byte and decodes to what was encoded.
  EXPECT_EQ(view_bytes(g, g.j["images"][0]["bufferView"]), png.value());
  test::TempDir dir;
  const render::Image back = image(g, 0, dir / "i.png");
  EXPECT_EQ(back.width, 3);
  EXPECT_EQ(back.height, 2);
  EXPECT_NEAR(back.value(2, 1, 1), 200 / 255.0, 1e-6);
}

// ---- one board --------------------------------------------------------------------------------

// Every texel of the renderer's own image of each long face, looked up in the exported atlas
// through the mesh's texture coordinates (the quad's corners, interpolated), is the same colour:
// the atlas, its placement and the UVs agree. The same lookup turned half round does not.
TEST(ExportJob, AtlasThroughTheMeshUvsIsTheRenderersFaceImage) {
  test::TempDir dir;
  const double k = 0.5;
  Result<ExportSummary> s =
      run_export(test::sample_model("gran1_spruce"), one_board(dir / "b.glb", k));
  ASSERT_TRUE(s.ok()) << s.error().message();
  ASSERT_EQ(s.value().boards.size(), 1u);
  EXPECT_EQ(s.value().boards[0].name, "board 1");
  const BoardBox box = s.value().boards[0].box;  // scanner frame
  const Glb g = read_glb(dir / "b.glb");
  const json& node = node_named(g, "board 1");
  EXPECT_NEAR(node["translation"][0].get<double>(), box.cx * 1e-3, 1e-9);
  EXPECT_NEAR(node["translation"][2].get<double>(), 1.6, 1e-9);
  EXPECT_EQ(g.j["scenes"][0]["extras"]["log_id"], "gran1_spruce");
  const json& prim = g.j["meshes"][node["mesh"].get<int>()]["primitives"][0];
  const std::vector<float> pos = floats(g, prim["attributes"]["POSITION"]);
  const std::vector<float> nrm = floats(g, prim["attributes"]["NORMAL"]);
  const std::vector<float> uv = floats(g, prim["attributes"]["TEXCOORD_0"]);
  const std::vector<double> edges = box_edges(pos, nrm);
  ASSERT_EQ(edges.size(), 3u);
  EXPECT_NEAR(edges[0], 1.2, 1e-6);
  EXPECT_NEAR(edges[1], 0.15, 1e-6);
  EXPECT_NEAR(edges[2], 0.05, 1e-6);
  const json& mat = g.j["materials"][prim["material"].get<int>()];
  const render::Image atlas =
      image(g,
            g.j["textures"][mat["pbrMetallicRoughness"]["baseColorTexture"]["index"].get<int>()]
               ["source"],
            dir / "base.png");

  auto ctx = render::create_headless_context();
  ASSERT_TRUE(ctx.ok());
  auto r = render::WoodRenderer::create(test::sample_model("gran1_spruce"), {});
  ASSERT_TRUE(r.ok());
  render::ShadeOptions sh;
  sh.lighting = false;
  sh.bark = true;
  render::FaceLayout layout;
  layout.stretch = true;
  layout.supersample = 2;
  for (int f = 0; f < 4; ++f) {  // the long faces: top, bottom, left, right
    const render::PlaneRect rect = render::board_face(box, static_cast<render::Face>(1u << f));
    const int w = static_cast<int>(std::lround(rect.width * k));
    const int h = static_cast<int>(std::lround(rect.height * k));
    Result<render::Image> face =
        render::render_board_faces(*r.value(), box, 1u << f, {w, h}, sh, layout);
    ASSERT_TRUE(face.ok()) << face.error().message();
    // The face's quad: vertices 4f .. 4f+3 at rect.at(0,0), (1,0), (1,1), (0,1).
    const float* q = &uv[8 * f];
    double diff = 0, turned = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const double a = (x + 0.5) / w, b = 1.0 - (y + 0.5) / h;
        auto texel = [&](double aa, double bb, int c) {
          const double u = q[0] + aa * (q[2] - q[0]) + bb * (q[6] - q[0]);
          const double v = q[1] + aa * (q[3] - q[1]) + bb * (q[7] - q[1]);
          const int tx = std::clamp(static_cast<int>(u * atlas.width), 0, atlas.width - 1);
          const int ty = std::clamp(static_cast<int>(v * atlas.height), 0, atlas.height - 1);
          return atlas.value(tx, ty, c);
        };
        for (int c = 0; c < 3; ++c) {
          diff += std::abs(texel(a, b, c) - face.value().value(x, y, c));
          turned += std::abs(texel(1 - a, 1 - b, c) - face.value().value(x, y, c));
        }
      }
    diff /= 3.0 * w * h;
    turned /= 3.0 * w * h;
    EXPECT_LT(diff, 0.5 / 255) << "face " << f;
    EXPECT_GT(turned, 0.02) << "face " << f;
  }
}

// The normal map: unit normals facing out of the face everywhere; flat inside knots (as
// wood.frag, which tilts only clear wood); tilted across the rings in much of the clear wood.
// The roughness map: glTF's layout (R 1, B 0 = no metal), roughness within the strip's range.
// One sample per texel, so that the knot mask is the field's at the texel centres.
TEST(BoardBake, NormalAndRoughnessMapsFollowTheRings) {
  auto ctx = render::create_headless_context();
  ASSERT_TRUE(ctx.ok());
  const LogModel& log = test::sample_model("gran1_spruce");
  auto r = render::WoodRenderer::create(log, {});
  ASSERT_TRUE(r.ok());
  BoardBox box = BoardBox::from_string(kBoard).value();
  const Vec3 c = r.value()->pith_point(0.0);
  box.cx += c.x;
  box.cy += c.y;
  BakeOptions o;
  o.px_per_mm = 0.5;
  o.supersample = 1;
  Result<BakedBoard> b = bake_board(*r.value(), box, o);
  ASSERT_TRUE(b.ok()) << b.error().message();
  ASSERT_TRUE(b.value().strips);
  // The knot mask of the top face from the raw field.
  const AtlasRect& rect = b.value().rects[0];
  render::ShadeOptions field;
  field.mode = render::ShadeMode::kTimeField;
  render::FaceLayout layout;
  layout.stretch = true;
  Result<render::Image> f =
      render::render_board_faces(*r.value(), box, 1u, {rect.w, rect.h}, field, layout);
  ASSERT_TRUE(f.ok());
  int knot = 0, knot_flat = 0, clear = 0, clear_tilted = 0;
  const render::Image& nm = b.value().normal;
  const render::Image& rm = b.value().roughness;
  for (int y = 0; y < rect.h; ++y)
    for (int x = 0; x < rect.w; ++x) {
      const int ax = rect.x + x, ay = rect.y + y;
      const double nx = 2 * nm.value(ax, ay, 0) - 1, ny = 2 * nm.value(ax, ay, 1) - 1,
                   nz = 2 * nm.value(ax, ay, 2) - 1;
      EXPECT_NEAR(std::sqrt(nx * nx + ny * ny + nz * nz), 1.0, 0.02);
      EXPECT_GT(nz, 0.0);
      EXPECT_EQ(rm.value(ax, ay, 0), 1.0f);
      EXPECT_EQ(rm.value(ax, ay, 2), 0.0f);
      EXPECT_GE(rm.value(ax, ay, 1), 0.54f);
      EXPECT_LE(rm.value(ax, ay, 1), 0.96f);
      if (f.value().value(x, y, 1) > 1.0f) continue;  // beyond the wood
      const bool in_knot = f.value().value(x, y, 3) >= 0.0f;
      const bool tilted = std::hypot(nx, ny) > 0.05;
      (in_knot ? knot : clear) += 1;
      (in_knot ? knot_flat : clear_tilted) += in_knot ? !tilted : tilted;
    }
  ASSERT_GT(knot, 10) << "the board should cross knots";
  EXPECT_EQ(knot_flat, knot);
  EXPECT_GT(clear_tilted, clear / 4) << clear_tilted << " of " << clear;
}

// Supersampled normal and roughness maps are the mean of the samples: at 2 x 2 samples and
// 0.5 px/mm they match 2 x 2 blocks of the one-sample maps at 1 px/mm (the same sample points),
// averaged and renormalised, up to 8-bit rounding (which renormalising can enlarge a few times
// where the samples' tilts nearly cancel).
TEST(BoardBake, SupersampledMapsAreTheMeanOfTheirSamples) {
  auto ctx = render::create_headless_context();
  ASSERT_TRUE(ctx.ok());
  auto r = render::WoodRenderer::create(test::sample_model("gran1_spruce"), {});
  ASSERT_TRUE(r.ok());
  BoardBox box = BoardBox::from_string(kBoard).value();
  const Vec3 c = r.value()->pith_point(0.0);
  box.cx += c.x;
  box.cy += c.y;
  BakeOptions coarse, fine;
  coarse.px_per_mm = 0.5;
  coarse.supersample = 2;
  fine.px_per_mm = 1.0;
  fine.supersample = 1;
  Result<BakedBoard> a = bake_board(*r.value(), box, coarse);
  Result<BakedBoard> b = bake_board(*r.value(), box, fine);
  ASSERT_TRUE(a.ok() && b.ok());
  for (int f = 0; f < 4; ++f) {
    const AtlasRect& ra = a.value().rects[f];
    const AtlasRect& rb = b.value().rects[f];
    ASSERT_EQ(rb.w, 2 * ra.w);
    ASSERT_EQ(rb.h, 2 * ra.h);
    double worst = 0, sum = 0;
    int tilted = 0;
    for (int y = 0; y < ra.h; ++y)
      for (int x = 0; x < ra.w; ++x) {
        double m[3] = {0, 0, 0}, rough = 0;
        for (int j = 0; j < 2; ++j)
          for (int i = 0; i < 2; ++i) {
            const int bx = rb.x + 2 * x + i, by = rb.y + 2 * y + j;
            for (int k = 0; k < 3; ++k) m[k] += 2 * b.value().normal.value(bx, by, k) - 1;
            rough += 0.25 * b.value().roughness.value(bx, by, 1);
          }
        const double len = std::sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
        for (int k = 0; k < 3; ++k) {
          const double want = 0.5 * m[k] / len + 0.5;
          const double d = std::abs(a.value().normal.value(ra.x + x, ra.y + y, k) - want);
          worst = std::max(worst, d);
          sum += d;
        }
        const double dr = std::abs(a.value().roughness.value(ra.x + x, ra.y + y, 1) - rough);
        worst = std::max(worst, dr);
        tilted += std::abs(m[0] / len) + std::abs(m[1] / len) > 0.05;
      }
    EXPECT_LE(worst, 10.0 / 255) << "face " << f;
    EXPECT_LT(sum / (3.0 * ra.w * ra.h), 1.0 / 255) << "face " << f;
    EXPECT_GT(tilted, ra.w * ra.h / 10) << "face " << f;
  }
}

// ---- the command line -------------------------------------------------------------------------

std::string gran1() { return test::quoted(test::sample_log("gran1_spruce") / "log.json"); }

// gran1 sawn at rotation 30, offset 2 into dir/sawing.json, its boards exported at 0.2 px/mm
// to dir/<name> (boards.glb); `flags` go to the export.
void saw_and_export(const test::TempDir& dir, const std::string& flags, std::string* out,
                    const std::string& name = "boards.glb") {
  ASSERT_EQ(
      test::run_sawyer(
          "saw " + gran1() + " -q --position 30,2 -o " + test::quoted(dir / "sawing.json"), out),
      0)
      << *out;
  ASSERT_EQ(test::run_sawyer("export " + gran1() + " " + flags + "--sawing " +
                                 test::quoted(dir / "sawing.json") + " --px-per-mm 0.2 -o " +
                                 test::quoted(dir / name),
                             out),
            0)
      << *out;
}

std::vector<std::string> listing(const fs::path& dir) {
  std::vector<std::string> v;
  for (const auto& e : fs::directory_iterator(dir)) v.push_back(e.path().filename().string());
  std::sort(v.begin(), v.end());
  return v;
}

// The boards of a sawing.json: one node each, named by number and grade, each box's edges the
// record's length, width and thickness; the scene names the log.
TEST(ExportCli, SawingBoardsByNumberGradeAndSize) {
  test::TempDir dir;
  std::string out;
  ASSERT_NO_FATAL_FAILURE(saw_and_export(dir, "", &out));
  EXPECT_NE(out.find("wrote"), std::string::npos) << out;
  std::ifstream sf(dir / "sawing.json");
  const json saw = json::parse(sf);
  // The boards at the chosen position (a given --position is the chosen one).
  const json& boards = saw["chosen"] == "given" ? saw["given_position"]["boards"] : saw["boards"];
  ASSERT_GT(boards.size(), 1u);
  const Glb g = read_glb(dir / "boards.glb");
  EXPECT_EQ(g.j["nodes"].size(), boards.size());
  EXPECT_EQ(g.j["scenes"][0]["extras"]["log_id"], "gran1_spruce");
  for (size_t i = 0; i < boards.size(); ++i) {
    const std::string name =
        "board " + std::to_string(i + 1) + " (" + boards[i]["grade"].get<std::string>() + ")";
    const json& node = node_named(g, name);
    if (node.is_null()) continue;
    const json& prim = g.j["meshes"][node["mesh"].get<int>()]["primitives"][0];
    const std::vector<double> e = box_edges(floats(g, prim["attributes"]["POSITION"]),
                                            floats(g, prim["attributes"]["NORMAL"]));
    std::vector<double> want = {node["extras"]["length_mm"].get<double>() * 1e-3,
                                boards[i]["width_mm"].get<double>() * 1e-3,
                                boards[i]["thickness_mm"].get<double>() * 1e-3};
    std::sort(want.rbegin(), want.rend());
    ASSERT_EQ(e.size(), 3u) << name;
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(e[k], want[k], 1e-5) << name << " edge " << k;
  }
}

// Issue 44: `-o boards.gltf` was refused. The text form holds the same scene as the .glb: the
// JSON, its geometry in boards.bin and every texture a PNG file beside it, named by board and
// map; nothing else is left in the folder.
TEST(ExportCli, TextGltfHoldsTheSameBoardsWithItsFilesBeside) {
  test::TempDir dir;
  std::string out;
  ASSERT_NO_FATAL_FAILURE(saw_and_export(dir, "", &out));
  ASSERT_NO_FATAL_FAILURE(saw_and_export(dir, "", &out, "boards.gltf"));
  EXPECT_NE(out.find("wrote " + (dir / "boards.gltf").string() + " and "), std::string::npos)
      << out;
  const Glb glb = read_glb(dir / "boards.glb");
  const Glb gltf = read_gltf(dir / "boards.gltf");
  EXPECT_EQ(gltf.j["buffers"][0]["uri"], "boards.bin");
  EXPECT_EQ(gltf.j["asset"]["generator"], "Sawyer export");
  ASSERT_EQ(gltf.j["nodes"], glb.j["nodes"]);
  ASSERT_EQ(gltf.j["meshes"], glb.j["meshes"]);
  ASSERT_EQ(gltf.j["images"].size(), glb.j["images"].size());
  std::vector<std::string> expected = {"boards.bin", "boards.glb", "boards.gltf", "sawing.json"};
  const size_t boards = gltf.j["nodes"].size();
  ASSERT_GT(boards, 1u);
  ASSERT_EQ(gltf.j["images"].size(), 3 * boards);
  for (size_t b = 1; b <= boards; ++b)
    for (const char* map : {"color", "normal", "roughness"})
      expected.push_back("boards_board" + std::to_string(b) + "_" + map + ".png");
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(listing(dir.path()), expected);
  // The same geometry, and the same PNG files as the .glb holds.
  for (size_t m = 0; m < gltf.j["meshes"].size(); ++m) {
    const json& prim = gltf.j["meshes"][m]["primitives"][0];
    for (const char* attr : {"POSITION", "NORMAL", "TEXCOORD_0", "TANGENT"})
      EXPECT_EQ(floats(gltf, prim["attributes"][attr]), floats(glb, prim["attributes"][attr]))
          << attr;
  }
  for (size_t i = 0; i < gltf.j["images"].size(); ++i) {
    const std::string uri = gltf.j["images"][i]["uri"];
    EXPECT_EQ(file_bytes(dir / uri), view_bytes(glb, glb.j["images"][i]["bufferView"])) << uri;
    EXPECT_EQ(gltf.j["images"][i]["name"], glb.j["images"][i]["name"]);
  }
}

// A .gltf's files beside it never replace the user's: a .bin or a PNG of the same name that no
// earlier Sawyer .gltf of that name lists is refused before any work. Its own earlier export is
// replaced, and the files it no longer uses go with it.
TEST(ExportCli, TextGltfNeverReplacesFilesItDidNotWrite) {
  test::TempDir dir;
  std::string out;
  for (const char* theirs : {"b.bin", "b_board1_normal.png"}) {
    test::write_file(dir / theirs, "mine\n");
    const std::vector<std::string> before = listing(dir.path());
    EXPECT_EQ(test::run_sawyer("export " + gran1() + " --board " + kBoard + " -o " +
                                   test::quoted(dir / "b.gltf"),
                               &out),
              1)
        << out;
    EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
    EXPECT_NE(out.find("sawyer: -o: "), std::string::npos) << out;
    EXPECT_NE(out.find(std::string(theirs) + " exists and is not a file of an earlier Sawyer"),
              std::string::npos)
        << out;
    EXPECT_EQ(listing(dir.path()), before);
    fs::remove(dir / theirs);
  }
  // Two boards, then one: the second board's images are the export's own, and go.
  const std::string two = std::string(" --board ") + kBoard + " --board 0,-40,150,50,0,1000,2200";
  ASSERT_EQ(
      test::run_sawyer(
          "export " + gran1() + two + " --px-per-mm 0.2 -o " + test::quoted(dir / "c.gltf"), &out),
      0)
      << out;
  EXPECT_TRUE(fs::exists(dir / "c_board2_roughness.png"));
  test::write_file(dir / "c_notes.png", "mine\n");
  ASSERT_EQ(test::run_sawyer("export " + gran1() + " --board " + kBoard + " --px-per-mm 0.2 -o " +
                                 test::quoted(dir / "c.gltf"),
                             &out),
            0)
      << out;
  EXPECT_EQ(listing(dir.path()), (std::vector<std::string>{
                                     "c.bin", "c.gltf", "c_board1_color.png", "c_board1_normal.png",
                                     "c_board1_roughness.png", "c_notes.png"}));
  EXPECT_EQ(read_gltf(dir / "c.gltf").j["nodes"].size(), 1u);
}

TEST(ExportCli, BadInputOneLineNothingWritten) {
  test::TempDir dir;
  std::string out;
  EXPECT_EQ(
      test::run_sawyer(
          "export " + gran1() + " --board " + kBoard + " -o " + test::quoted(dir / "b.obj"), &out),
      1);
  EXPECT_NE(out.find("-o: "), std::string::npos) << out;
  EXPECT_NE(out.find("not a .glb or .gltf"), std::string::npos) << out;
  EXPECT_EQ(test::run_sawyer("export " + gran1() + " -o " + test::quoted(dir / "b.glb"), &out), 1);
  EXPECT_NE(out.find("sawyer export: no boards"), std::string::npos) << out;
  EXPECT_EQ(test::run_sawyer("export " + gran1() + " --board " + kBoard + " --px-per-mm 20 -o " +
                                 test::quoted(dir / "b.glb"),
                             &out),
            1);
  EXPECT_NE(out.find("--px-per-mm"), std::string::npos) << out;
  EXPECT_EQ(test::run_sawyer("export " + gran1() + " --board 0,0,150,50,0,5000,6000 -o " +
                                 test::quoted(dir / "b.glb"),
                             &out),
            1);
  EXPECT_NE(out.find("misses the log"), std::string::npos) << out;
  // A sawing.json of another log.
  test::write_file(dir / "sawing.json",
                   R"({"format": "sawyer-sawing/1", "log_id": "another", "boards": []})");
  EXPECT_EQ(
      test::run_sawyer("export " + gran1() + " --sawing " + test::quoted(dir / "sawing.json") +
                           " -o " + test::quoted(dir / "b.glb"),
                       &out),
      1);
  EXPECT_NE(out.find("sawing.json"), std::string::npos) << out;
  // An --osl-data path that is a file, or a folder Sawyer did not write, is refused and kept.
  test::write_file(dir / "notes.txt", "keep");
  EXPECT_EQ(
      test::run_sawyer("export " + gran1() + " --board " + kBoard + " --osl-data " +
                           test::quoted(dir / "notes.txt") + " -o " + test::quoted(dir / "b.glb"),
                       &out),
      1);
  EXPECT_NE(out.find("--osl-data: "), std::string::npos) << out;
  fs::create_directories(dir / "theirs");
  test::write_file(dir / "theirs" / "x.txt", "keep");
  EXPECT_EQ(
      test::run_sawyer("export " + gran1() + " --board " + kBoard + " --osl-data " +
                           test::quoted(dir / "theirs") + " -o " + test::quoted(dir / "b.glb"),
                       &out),
      1);
  EXPECT_NE(out.find("did not write"), std::string::npos) << out;
  EXPECT_TRUE(fs::exists(dir / "theirs" / "x.txt"));
  EXPECT_TRUE(fs::exists(dir / "notes.txt"));
  // An output that is a folder is refused and left alone.
  fs::create_directories(dir / "d.glb");
  EXPECT_EQ(
      test::run_sawyer(
          "export " + gran1() + " --board " + kBoard + " -o " + test::quoted(dir / "d.glb"), &out),
      1);
  EXPECT_TRUE(fs::is_directory(dir / "d.glb"));
  EXPECT_FALSE(fs::exists(dir / "b.glb"));
  for (const auto& e : fs::directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

// ---- other tools ------------------------------------------------------------------------------

bool have(const std::string& command) {
  std::string out;
  return test::run_command("command -v " + command + " >/dev/null 2>&1", &out) == 0;
}

// The Khronos glTF validator (tools/gltf: `npm ci --prefix tools/gltf`) finds no error and no
// warning in an export of a sawing position's boards.
TEST(ExportTools, KhronosValidatorFindsNoErrors) {
  const fs::path tools = test::source_dir() / "tools" / "gltf";
  if (!have("node")) GTEST_SKIP() << "node not installed (scripts/install_deps.sh)";
  if (!fs::exists(tools / "node_modules" / "gltf-validator"))
    GTEST_SKIP() << "gltf-validator not installed: npm ci --prefix " << tools.string();
  test::TempDir dir;
  std::string out;
  ASSERT_NO_FATAL_FAILURE(saw_and_export(dir, "-q ", &out));
  ASSERT_NO_FATAL_FAILURE(saw_and_export(dir, "-q ", &out, "boards.gltf"));
  // The .glb, and the .gltf with the .bin and images it names (issue 44).
  for (const char* file : {"boards.glb", "boards.gltf"}) {
    const int rc = test::run_command(
        "node " + test::quoted(tools / "validate.js") + " " + test::quoted(dir / file), &out);
    std::cout << out;
    EXPECT_EQ(rc, 0) << out;
    EXPECT_NE(out.find(": 0 errors, 0 warnings"), std::string::npos) << file << "\n" << out;
  }
}

// Blender's glTF importer finds the board with its size and three textures, and Cycles renders
// its top face (uniform white sky, orthographic) close to Sawyer's own image of that face, and
// clearly closer than to the same image turned half round.
TEST(ExportTools, BlenderImportsAndCyclesRendersTheFace) {
  if (!have("blender")) GTEST_SKIP() << "blender not installed (scripts/install_deps.sh)";
  test::TempDir dir;
  const double k = 0.5;
  Result<ExportSummary> s =
      run_export(test::sample_model("gran1_spruce"), one_board(dir / "b.glb", k));
  ASSERT_TRUE(s.ok()) << s.error().message();
  test::write_file(dir / "expect.json",
                   R"({"log_id": "gran1_spruce", "boards": [{"name": "board 1",
                       "edges_m": [1.2, 0.15, 0.05]}]})");
  const fs::path tools = test::source_dir() / "tools" / "blender";
  const std::string blender = "blender -b --factory-startup --python-exit-code 1 --python ";
  const int w = static_cast<int>(std::lround(1200 * k)), h = static_cast<int>(std::lround(150 * k));
  // Blender imports `file` and checks its board against expect.json, then Cycles renders the
  // board's top face into `png`, which is read back.
  auto import_and_render = [&](const fs::path& file, const fs::path& png) {
    std::string out;
    int rc = test::run_command(blender + test::quoted(tools / "check_glb.py") + " -- " +
                                   test::quoted(file) + " " + test::quoted(dir / "expect.json") +
                                   " 2>&1",
                               &out);
    EXPECT_EQ(rc, 0) << file << "\n" << out;
    EXPECT_NE(out.find("check_glb: OK, 1 boards"), std::string::npos) << file << "\n" << out;
    rc = test::run_command(blender + test::quoted(tools / "render_boards.py") + " -- " +
                               test::quoted(file) + " " + test::quoted(png) + " face \"board 1\" " +
                               std::to_string(w) + " " + std::to_string(h) + " 16 2>&1",
                           &out);
    EXPECT_EQ(rc, 0) << file << "\n" << out;
    return render::read_image(png);
  };
  Result<render::Image> cycles = import_and_render(dir / "b.glb", dir / "face.png");
  ASSERT_TRUE(cycles.ok()) << cycles.error().message();
  const render::Image sawyer = render_top_face(s.value().boards[0].box, w, h);
  const double d = mean_abs_diff(cycles.value(), sawyer);
  const double turned = mean_abs_diff(cycles.value(), sawyer, true);
  std::cout << "Cycles vs Sawyer top face: mean |diff| " << d << " (turned half round: " << turned
            << ")\n";
  EXPECT_LT(d, 0.08);
  EXPECT_LT(d, 0.6 * turned);

  // The same board as text glTF (issue 44): Blender's importer finds it with its size and its
  // three textures read from the files beside it, and Cycles renders the face as from the .glb.
  Result<ExportSummary> t =
      run_export(test::sample_model("gran1_spruce"), one_board(dir / "b.gltf", k));
  ASSERT_TRUE(t.ok()) << t.error().message();
  EXPECT_EQ(t.value().files.size(), 4u) << "b.bin and three images";
  Result<render::Image> cycles_text = import_and_render(dir / "b.gltf", dir / "face2.png");
  ASSERT_TRUE(cycles_text.ok()) << cycles_text.error().message();
  const double same = mean_abs_diff(cycles_text.value(), cycles.value());
  std::cout << "Cycles, .gltf vs .glb: mean |diff| " << same << "\n";
  EXPECT_LT(same, 0.01);
}

}  // namespace
}  // namespace sawyer::exporter

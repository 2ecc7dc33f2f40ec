#include "sawyer/export/export_job.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>

#include "sawyer/core/file_util.h"
#include "sawyer/export/board_bake.h"
#include "sawyer/export/glb_writer.h"
#include "sawyer/export/osl_data.h"
#include "sawyer/render/gl_context.h"
#include "sawyer/render/wood_renderer.h"
#include "sawyer/sawing/placement.h"
#include "sawyer/sawing/sawing.h"
#include "sawyer/sawing/sawing_file.h"

namespace sawyer::exporter {
namespace fs = std::filesystem;

namespace {

std::string mm(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.0f", v);
  return b;
}

struct NamedBoard {
  BoardBox box;
  int number = 0;
  std::string grade;
  nlohmann::json extras = nlohmann::json::object();
};

// The boards of a sawing.json at its chosen position, as boxes in the scanner frame.
Result<std::vector<NamedBoard>> sawing_boards(const LogModel& log, const fs::path& path) {
  Result<sawing::SawingRecord> rec = sawing::read_sawing_file(path);
  if (!rec) return rec.error();
  const sawing::SawingRecord& s = rec.value();
  if (s.log_id != log.id)
    return Error(path.string(),
                 "log '" + s.log_id + "' does not match the log given ('" + log.id + "')");
  if (s.boards.empty()) return Error(path.string(), "boards: none at the chosen position");
  const sawing::SawLog saw_log(log);
  std::vector<NamedBoard> out;
  for (size_t i = 0; i < s.boards.size(); ++i) {
    const sawing::BoardRecord& b = s.boards[i];
    NamedBoard nb;
    nb.box = sawing::board_placement(saw_log, b.board(static_cast<int>(i)), s.chosen.pos);
    nb.number = static_cast<int>(i) + 1;
    nb.grade = b.grade;
    nb.extras = {
        {"sawing_name", b.name},     {"grade", b.grade},           {"thickness_mm", b.thickness_mm},
        {"width_mm", b.width_mm},    {"length_mm", b.length_mm()}, {"volume_m3", b.volume_m3},
        {"value", b.value},          {"currency", s.currency},     {"knots", b.knots},
        {"dead_knots", b.dead_knots}};
    if (Status st = nb.box.validate(); !st)
      return st.error().with_context(path.string() + ": board " + std::to_string(nb.number));
    out.push_back(std::move(nb));
  }
  return out;
}

// The three maps' names of boards 1..n, in the order they are baked: "board3_color", ...
std::vector<std::string> image_names(size_t n) {
  std::vector<std::string> names;
  for (size_t b = 1; b <= n; ++b)
    for (const char* map : {"color", "normal", "roughness"})
      names.push_back("board" + std::to_string(b) + "_" + map);
  return names;
}

std::string board_name(const NamedBoard& b) {
  return "board " + std::to_string(b.number) + (b.grade.empty() ? "" : " (" + b.grade + ")");
}

// One board's box as a mesh of six quads (metres, relative to the box's centre) with its
// baked atlas's texture coordinates.
GlbMesh board_mesh(const BakedBoard& baked, int atlas_w, int atlas_h) {
  GlbMesh m;
  const BoardBox& b = baked.box;
  const Vec3 centre{b.cx, b.cy, 0.5 * (b.z0 + b.z1)};
  m.translation = {centre.x * 1e-3, centre.y * 1e-3, centre.z * 1e-3};
  const double corners[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (int f = 0; f < kBoardFaces; ++f) {
    const render::PlaneRect& r = baked.faces[f];
    const AtlasRect& a = baked.rects[f];
    const Vec3 n = cross(r.u, r.v).normalized(), u = r.u.normalized();
    const auto base = static_cast<std::uint32_t>(m.positions.size() / 3);
    for (const auto& c : corners) {
      const Vec3 p = r.at(c[0], c[1]) - centre;
      for (double v : {p.x, p.y, p.z}) m.positions.push_back(static_cast<float>(v * 1e-3));
      for (double v : {n.x, n.y, n.z}) m.normals.push_back(static_cast<float>(v));
      for (double v : {u.x, u.y, u.z, 1.0}) m.tangents.push_back(static_cast<float>(v));
      m.uvs.push_back(static_cast<float>((a.x + c[0] * a.w) / atlas_w));
      m.uvs.push_back(static_cast<float>((a.y + (1.0 - c[1]) * a.h) / atlas_h));
    }
    for (std::uint32_t k : {0u, 1u, 2u, 0u, 2u, 3u}) m.indices.push_back(base + k);
  }
  return m;
}

}  // namespace

Status check_export(const ExportOptions& o) {
  if (o.output.empty()) return Error("ExportOptions::output", "no output file given");
  if (o.output.extension() != ".glb" && o.output.extension() != ".gltf")
    return Error(
        "ExportOptions::output",
        o.output.string() +
            ": not a .glb or .gltf file (glTF 2.0, binary or text with its files beside it)");
  if (o.sawing.empty() == o.boards.empty())
    return Error("ExportOptions", o.sawing.empty() ? "no boards: give a sawing file or boards"
                                                   : "give a sawing file or boards, not both");
  if (!o.sawing.empty() && o.boards_in_scanner_frame)
    return Error("ExportOptions::boards_in_scanner_frame",
                 "applies to given boards only (a sawing file's are placed by its position)");
  for (const BoardBox& b : o.boards)
    if (Status st = b.validate(); !st) return st.error().with_context("ExportOptions::boards");
  BakeOptions bake;
  bake.px_per_mm = o.px_per_mm;
  bake.supersample = o.supersample;
  if (Status st = bake.validate(); !st) return st;
  if (!o.osl_data.empty()) {
    if (o.osl_data == o.output)
      return Error("ExportOptions::osl_data", "the same path as the .glb");
    if (Status st = check_osl_data_dir(o.osl_data, "ExportOptions::osl_data"); !st) return st;
  }
  return Status::Ok();
}

std::string ExportSummary::brief(const fs::path& output, double px_per_mm) const {
  std::ostringstream s;
  s.precision(3);
  s << "wrote " << output.string();
  if (!files.empty()) s << " and " << files.size() << " files beside it";
  s << ": " << boards.size() << " board" << (boards.size() == 1 ? "" : "s") << " of log " << log_id
    << ", " << byte_size_text(bytes) << ", " << px_per_mm << " px/mm, " << seconds << " s ("
    << context << ")";
  return s.str();
}

Result<ExportSummary> run_export(const LogModel& log, const ExportOptions& o) {
  if (Status st = check_export(o); !st) return st.error();
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<NamedBoard> boards;
  if (!o.sawing.empty()) {
    Result<std::vector<NamedBoard>> r = sawing_boards(log, o.sawing);
    if (!r) return r.error();
    boards = std::move(r).value();
  }

  // A .gltf keeps its .bin and images beside it: those names must be free, or an earlier
  // export's of the same name, before any work (nothing of the user's is replaced).
  const bool text_gltf = o.output.extension() == ".gltf";
  if (text_gltf) {
    GlbScene names;
    const size_t n = o.sawing.empty() ? o.boards.size() : boards.size();
    names.images.resize(3 * n);
    names.image_names = image_names(n);
    if (Status st = check_gltf_sidecars(o.output, gltf_sidecars(o.output, names),
                                        {o.sawing, o.color_maps}, "ExportOptions::output");
        !st)
      return st.error();
  }

  Result<std::unique_ptr<render::GlContext>> ctx = render::create_headless_context();
  if (!ctx) return ctx.error();
  render::RenderOptions ro;
  ro.color_maps = o.color_maps;
  ro.species = o.species;
  Result<std::unique_ptr<render::WoodRenderer>> r = render::WoodRenderer::create(log, ro);
  if (!r) return r.error();
  render::WoodRenderer& renderer = *r.value();

  if (boards.empty()) {
    const Vec3 c = renderer.pith_point(0.0);
    for (size_t i = 0; i < o.boards.size(); ++i) {
      NamedBoard nb;
      nb.box = o.boards[i];
      if (!o.boards_in_scanner_frame) {
        nb.box.cx += c.x;
        nb.box.cy += c.y;
      }
      nb.number = static_cast<int>(i) + 1;
      boards.push_back(nb);
    }
  }
  const double z0 = log.stem.z_begin(), z1 = log.stem.z_end();
  for (const NamedBoard& b : boards)
    if (b.box.z1 <= z0 || b.box.z0 >= z1)
      return Error("ExportOptions::boards", board_name(b) + ": z " + mm(b.box.z0) + " to " +
                                                mm(b.box.z1) +
                                                " mm misses the log, which runs "
                                                "from " +
                                                mm(z0) + " to " + mm(z1) + " mm");

  BakeOptions bake;
  bake.px_per_mm = o.px_per_mm;
  bake.supersample = o.supersample;
  bake.color_maps = o.color_maps;
  GlbScene scene;
  scene.image_names = image_names(boards.size());
  scene.name = "log " + log.id;
  scene.generator = "Sawyer export";
  scene.extras = {{"log_id", log.id},
                  {"species", renderer.look().name},
                  {"units", "metres; Sawyer's scanner frame, x and y across the log, z along it"},
                  {"px_per_mm", o.px_per_mm}};
  if (!o.sawing.empty()) scene.extras["sawing"] = o.sawing.filename().string();
  ExportSummary summary;
  summary.log_id = log.id;
  summary.context = ctx.value()->description();
  for (const NamedBoard& b : boards) {
    Result<BakedBoard> baked = bake_board(renderer, b.box, bake);
    if (!baked) return baked.error().with_context(board_name(b));
    const BakedBoard& bb = baked.value();
    GlbMesh mesh = board_mesh(bb, bb.base_color.width, bb.base_color.height);
    mesh.name = board_name(b);
    mesh.extras = b.extras;
    mesh.extras["number"] = b.number;
    mesh.extras["box_mm"] = {{"cx", b.box.cx},
                             {"cy", b.box.cy},
                             {"width", b.box.width},
                             {"thickness", b.box.thickness},
                             {"rotation_deg", b.box.rotation * 180.0 / kPi},
                             {"z0", b.box.z0},
                             {"z1", b.box.z1}};
    for (const render::Image* img : {&bb.base_color, &bb.normal, &bb.roughness}) {
      Result<std::vector<std::uint8_t>> png = encode_png(*img);
      if (!png) return png.error().with_context(board_name(b));
      scene.images.push_back(std::move(png).value());
    }
    const int first = static_cast<int>(scene.images.size()) - 3;
    mesh.base_color = first;
    mesh.normal = first + 1;
    mesh.metallic_roughness = first + 2;
    scene.meshes.push_back(std::move(mesh));
    summary.boards.push_back(
        {board_name(b), b.number, b.grade, b.box, bb.base_color.width, bb.base_color.height});
  }
  if (!o.osl_data.empty())
    if (Status st = write_osl_data(o.osl_data, log, ro); !st) return st.error();
  if (Status st = text_gltf ? write_gltf(o.output, scene) : write_glb(o.output, scene); !st)
    return st.error();
  std::error_code ec;
  summary.bytes = fs::file_size(o.output, ec);
  if (text_gltf) {
    summary.files = gltf_sidecars(o.output, scene);
    for (const fs::path& f : summary.files) summary.bytes += fs::file_size(f, ec);
  }
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return summary;
}

}  // namespace sawyer::exporter

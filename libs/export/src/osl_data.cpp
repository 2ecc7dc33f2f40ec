#include "sawyer/export/osl_data.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <system_error>
#include <vector>

#include <nlohmann/json.hpp>

#include "sawyer/core/file_util.h"
#include "sawyer/render/field_tables.h"
#include "sawyer/render/image.h"

namespace sawyer::exporter {
namespace fs = std::filesystem;

namespace {

render::Image float_table(int w, int h) {
  render::Image im;
  im.width = w;
  im.height = h;
  im.channels = 4;
  im.f32.assign(static_cast<size_t>(w) * h * 4, 0.0f);
  return im;
}

float* texel(render::Image& im, int x, int y) {
  return &im.f32[(static_cast<size_t>(y) * im.width + x) * 4];
}

// Integers one a texel (R), kOslTrackRow texels to a row.
render::Image int_table(const std::vector<std::int32_t>& v) {
  const int n = static_cast<int>(v.size());
  render::Image im = float_table(kOslTrackRow, std::max(1, (n + kOslTrackRow - 1) / kOslTrackRow));
  for (int i = 0; i < n; ++i)
    texel(im, i % kOslTrackRow, i / kOslTrackRow)[0] =
        static_cast<float>(v[static_cast<size_t>(i)]);
  return im;
}

fs::path strip_folder(const render::RenderOptions& o) {
  if (!o.color_maps.empty()) return o.color_maps;
#ifdef SAWYER_EXPORT_DATA_DIR
  return SAWYER_EXPORT_DATA_DIR;
#else
  return {};
#endif
}

}  // namespace

Status check_osl_data_dir(const fs::path& dir, const std::string& option) {
  std::error_code ec;
  const fs::file_status st = fs::symlink_status(dir, ec);
  if (!fs::exists(st)) return Status::Ok();
  if (!fs::is_directory(st))
    return Error(option, dir.string() + ": exists and is not a folder (not replaced)");
  if (fs::is_empty(dir, ec) || fs::is_regular_file(dir / "sawyer_osl.json", ec))
    return Status::Ok();
  return Error(option, dir.string() +
                           ": a folder that Sawyer did not write (no sawyer_osl.json); not "
                           "replaced");
}

Status write_osl_data(const fs::path& dir, const LogModel& log,
                      const render::RenderOptions& options) {
  if (Status st = check_osl_data_dir(dir, "ExportOptions::osl_data"); !st) return st;
  const render::FieldTables t = render::field_tables(log, options);
  const int pith_count = static_cast<int>(t.pith.size() / 2);
  render::Image pith = float_table(pith_count, 1);
  for (int i = 0; i < pith_count; ++i) {
    texel(pith, i, 0)[0] = t.pith[2 * i];
    texel(pith, i, 0)[1] = t.pith[2 * i + 1];
  }
  render::Image stem = float_table(t.stem_cols, t.stem_rows);
  for (int y = 0; y < t.stem_rows; ++y)
    for (int x = 0; x < t.stem_cols; ++x) {
      const size_t i = (static_cast<size_t>(y) * t.stem_cols + x) * 2;
      texel(stem, x, y)[0] = t.stem[i];
      texel(stem, x, y)[1] = t.stem[i + 1];
    }
  const int knot_count = static_cast<int>(t.knots.size());
  render::Image knots = float_table(3, std::max(1, knot_count));
  for (int k = 0; k < knot_count; ++k) {
    const render::FieldKnot& fk = t.knots[k];
    float* a = texel(knots, 0, k);
    a[0] = fk.r_dead;
    a[1] = fk.r_end;
    a[2] = fk.d_dead;
    a[3] = fk.d_exp;
    float* b = texel(knots, 1, k);
    b[0] = fk.half_dmax;
    b[1] = static_cast<float>(fk.track_offset);
    b[2] = static_cast<float>(fk.track_count);
    b[3] = static_cast<float>(fk.seed & 0xffffu);
    texel(knots, 2, k)[0] = static_cast<float>(fk.seed >> 16);
  }
  const int track_count = static_cast<int>(t.tracks.size() / 4);
  const int track_rows = std::max(1, (track_count + kOslTrackRow - 1) / kOslTrackRow);
  render::Image tracks = float_table(kOslTrackRow, track_rows);
  std::copy(t.tracks.begin(), t.tracks.end(), tracks.f32.begin());
  // The knot index: one integer a texel (R), exact in a float up to 2^24.
  for (const std::vector<std::int32_t>* v : {&t.cell_start, &t.cell_knots})
    for (std::int32_t x : *v)
      if (x < 0 || x > (1 << 24))
        return Error("ExportOptions::osl_data",
                     "the knot index has " + std::to_string(t.cell_knots.size()) +
                         " entries, more than a float table holds exactly (2^24)");
  const render::Image cell_start = int_table(t.cell_start);
  const render::Image cell_knots = int_table(t.cell_knots);
  // The look of wood.frag: the species' knot, bark-ring and heartwood colours, the strip's
  // luminance; the renderer's default shading (knots darkened and dead knots ringed fully).
  const render::WoodLook look =
      render::wood_look(options.species.empty() ? log.species : options.species);
  Result<render::ColorStripStats> strip = render::color_strip_stats(options);
  if (!strip) return strip.error();
  const render::ShadeOptions shade;
  auto rgb = [](const std::array<float, 3>& c) {
    return nlohmann::json::array({c[0], c[1], c[2]});
  };
  // The scalars by the shader's parameter names (shaders/osl/sawyer_wood.osl).
  const nlohmann::ordered_json params = {
      {"PithZ0", t.pith_z0},
      {"PithStep", t.pith_step},
      {"PithCount", pith_count},
      {"StemZ0", t.stem_z0},
      {"StemStep", t.stem_step},
      {"StemCols", t.stem_cols},
      {"StemRows", t.stem_rows},
      {"KnotCount", knot_count},
      {"TrackRows", track_rows},
      {"TrackStep", t.track_step},
      {"RRef", t.r_ref},
      {"KnotNoise", t.knot_noise},
      {"CellZ0", t.cell_z0},
      {"CellDz", t.cell_dz},
      {"CellNz", t.cell_nz},
      {"CellDr", t.cell_dr},
      {"CellNr", t.cell_nr},
      {"CellNs", t.cell_ns},
      {"CellStartRows", cell_start.height},
      {"CellKnotRows", cell_knots.height},
      {"KnotSound", rgb(look.knot_sound)},
      {"KnotDead", rgb(look.knot_dead)},
      {"BarkRing", rgb(look.bark_ring)},
      {"HeartTint", rgb(look.heart_tint)},
      {"KnotRings", look.knot_rings},
      {"StripLuma", strip.value().luma},
      {"HeartwoodTint",
       shade.heartwood_tint && look.heartwood_visible && log.stem.has_heartwood() ? 1 : 0},
      {"KnotDarkening", shade.knot_darkening},
      {"DeadOutline", shade.dead_outline}};
  nlohmann::ordered_json j = {{"format", kOslFormatTag},
                              {"log_id", log.id},
                              {"shader", "shaders/osl/sawyer_wood.osl"},
                              {"frame",
                               "Blender world metres: Sawyer (x, y, z) mm = "
                               "1000 (x, z, -y)"},
                              {"parameters", params}};
  const fs::path strips = strip_folder(options);
  return write_dir_atomic(dir, [&](const fs::path& tmp) -> Status {
    for (const auto& [name, img] : {std::pair<const char*, const render::Image*>{"pith.exr", &pith},
                                    {"stem.exr", &stem},
                                    {"knots.exr", &knots},
                                    {"tracks.exr", &tracks},
                                    {"cell_start.exr", &cell_start},
                                    {"cell_knots.exr", &cell_knots}})
      if (Status st = render::write_image(tmp / name, *img); !st) return st;
    std::error_code ec;
    if (!strips.empty() && fs::is_regular_file(strips / "wood_bar_color.bmp", ec)) {
      fs::copy_file(strips / "wood_bar_color.bmp", tmp / "wood_bar_color.bmp", ec);
      if (ec) return Error((tmp / "wood_bar_color.bmp").string(), ec.message());
    }
    return write_text_file_atomic(tmp / "sawyer_osl.json", j.dump(1) + "\n");
  });
}

}  // namespace sawyer::exporter

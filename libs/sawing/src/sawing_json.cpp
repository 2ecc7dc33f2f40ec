// The JSON of a sawn position (see sawing_json.h).
#include "sawyer/sawing/sawing_json.h"

namespace sawyer::sawing {

using Json = nlohmann::ordered_json;

Json position_json(const LogPosition& p) {
  return {{"rotation_deg", p.rotation_deg},
          {"offset_x_mm", p.offset_x_mm},
          {"offset_y_mm", p.offset_y_mm}};
}

Json boards_json(const SawResult& sawn, const LogValue& v, const GradingRules& rules,
                 bool details) {
  Json out = Json::array();
  for (size_t i = 0; i < sawn.boards.size(); ++i) {
    const Board& b = sawn.boards[i];
    const BoardValue& bv = v.boards[i];
    Json board = {{"name", b.name},
                  {"thickness_mm", b.thickness_mm},
                  {"width_mm", b.width_mm},
                  {"thickness_axis", b.thickness_axis == ThicknessAxis::kU ? "u" : "v"},
                  {"u_mm", b.u_mm},
                  {"v_mm", b.v_mm},
                  {"z_begin_mm", b.z_begin},
                  {"z_end_mm", b.z_end},
                  {"volume_m3", b.volume_m3},
                  {"grade", rules.grade_name(bv.grade.grade)},
                  {"limited_by", describe(bv.grade.limit, rules)},
                  {"price_per_m3", bv.price_per_m3},
                  {"value", bv.value}};
    if (b.trimmed()) {
      // Cross-cut to value (trim_to_value): the sawn length and the offcuts at either end.
      board["sawn_begin_mm"] = b.sawn_begin;
      board["sawn_end_mm"] = b.sawn_end;
      board["offcuts_mm"] = {b.z_begin - b.sawn_begin, b.sawn_end - b.z_end};
    }
    if (details) {
      Json wane = Json::array();
      for (const SideWane& w : b.wane)
        wane.push_back({{"max_mm", w.max_mm}, {"length_mm", w.length_mm}});
      Json knots = Json::array();
      for (const KnotOnSide& k : b.knots)
        knots.push_back({{"knot_id", k.knot_id},
                         {"side", side_name(k.side)},
                         {"kind", knot_kind_name(k.kind)},
                         {"along_mm", k.along_mm},
                         {"across_mm", k.across_mm},
                         {"width_mm", k.width_mm},
                         {"minor_mm", k.minor_mm},
                         {"major_mm", k.major_mm},
                         {"dead", k.dead}});
      board["wane"] = std::move(wane);
      board["knots"] = std::move(knots);
    }
    out.push_back(std::move(board));
  }
  return out;
}

}  // namespace sawyer::sawing

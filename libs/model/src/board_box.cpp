// BoardBox: the board's box, its checks and its text form (board_box.h).
#include "sawyer/model/board_box.h"

#include <cmath>
#include <sstream>
#include <vector>

#include "sawyer/model/log_json.h"

namespace sawyer {

Vec3 BoardBox::u() const { return {std::cos(rotation), std::sin(rotation), 0}; }
Vec3 BoardBox::v() const { return {-std::sin(rotation), std::cos(rotation), 0}; }

namespace {

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace

Status BoardBox::validate() const {
  for (double x : {cx, cy, width, thickness, rotation, z0, z1})
    if (!std::isfinite(x)) return Error("board", "values must be finite numbers");
  if (!(width > 0)) return Error("board", "width must be > 0 mm");
  if (!(thickness > 0)) return Error("board", "thickness must be > 0 mm");
  if (!(z1 > z0)) return Error("board", "z1 must be greater than z0");
  // The log model's own limits (log_json.h): a board lies within the largest log's reach.
  struct Bound {
    const char* what;
    double v, lo, hi;
  };
  const double reach = log_limits::kMaxAbsPithMm + log_limits::kMaxRadiusMm;
  const double side = 2 * log_limits::kMaxRadiusMm;
  const Bound bounds[] = {{"centre x", cx, -reach, reach},
                          {"centre y", cy, -reach, reach},
                          {"width", width, 0, side},
                          {"thickness", thickness, 0, side},
                          {"rotation (radians)", rotation, -4 * kPi, 4 * kPi},
                          {"z0", z0, -log_limits::kMaxAbsZMm, log_limits::kMaxAbsZMm},
                          {"z1", z1, -log_limits::kMaxAbsZMm, log_limits::kMaxAbsZMm}};
  for (const Bound& b : bounds)
    if (b.v < b.lo || b.v > b.hi)
      return Error("board", std::string(b.what) + " " + num(b.v) + " is outside " + num(b.lo) +
                                (b.lo < 0 ? " to " : "-") + num(b.hi) +
                                (b.what[0] == 'r' ? "" : " mm"));
  return Status::Ok();
}

Result<BoardBox> BoardBox::from_string(const std::string& text) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      size_t used = 0;
      const double x = std::stod(item, &used);
      while (used < item.size() && item[used] == ' ') ++used;
      if (used != item.size()) throw std::invalid_argument(item);
      v.push_back(x);
    } catch (const std::exception&) {
      return Error("BoardBox::from_string",
                   "'" + item + "' is not a number (expected x,y,w,t,rot,z0,z1)");
    }
  }
  if (v.size() != 7)
    return Error(
        "BoardBox::from_string",
        "expected 7 numbers x,y,w,t,rot,z0,z1 (mm, degrees), got " + std::to_string(v.size()));
  BoardBox b;
  b.cx = v[0];
  b.cy = v[1];
  b.width = v[2];
  b.thickness = v[3];
  if (!(std::abs(v[4]) <= 360))
    return Error("BoardBox::from_string", "rotation " + num(v[4]) + "° is outside -360 to 360°");
  b.rotation = v[4] * kPi / 180.0;
  b.z0 = v[5];
  b.z1 = v[6];
  if (Status st = b.validate(); !st) return Error("BoardBox::from_string", st.error().message());
  return b;
}

}  // namespace sawyer

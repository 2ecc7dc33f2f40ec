#include "sawyer/render/scene.h"

#include <cmath>

namespace sawyer::render {

const char* face_name(Face f) {
  switch (f) {
    case Face::kTop:
      return "top";
    case Face::kBottom:
      return "bottom";
    case Face::kLeft:
      return "left";
    case Face::kRight:
      return "right";
    case Face::kButt:
      return "butt";
    case Face::kTopEnd:
      return "end";
  }
  return "?";
}

PlaneRect board_face(const BoardBox& b, Face f) {
  const Vec3 c{b.cx, b.cy, b.z0}, U = b.u(), V = b.v(), Z{0, 0, 1};
  const double hw = 0.5 * b.width, ht = 0.5 * b.thickness, len = b.z1 - b.z0;
  const double width = b.width, thickness = b.thickness;
  PlaneRect r;
  switch (f) {
    case Face::kTop:  // normal +v
      r = {c + ht * V - hw * U, Z, U, len, width};
      break;
    case Face::kBottom:  // normal -v
      r = {c - ht * V + hw * U, Z, -1.0 * U, len, width};
      break;
    case Face::kRight:  // normal +u
      r = {c + hw * U + ht * V, Z, -1.0 * V, len, thickness};
      break;
    case Face::kLeft:  // normal -u
      r = {c - hw * U - ht * V, Z, V, len, thickness};
      break;
    case Face::kButt:  // normal -z
      r = {c - hw * U + ht * V, U, -1.0 * V, width, thickness};
      break;
    case Face::kTopEnd:  // normal +z
      r = {c - hw * U - ht * V + len * Z, U, V, width, thickness};
      break;
  }
  return r;
}

}  // namespace sawyer::render

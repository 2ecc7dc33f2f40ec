#include "sawyer/render/mesh.h"

#include <algorithm>
#include <cmath>

namespace sawyer::render {
namespace {

MeshVertex vertex(const Vec3& p, const Vec3& n, const Rgb& c) {
  return {{static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)},
          {static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z)},
          {c[0], c[1], c[2]}};
}

// Two unit vectors perpendicular to `t` and to each other.
void frame_around(const Vec3& t, Vec3* e1, Vec3* e2) {
  const Vec3 helper = std::abs(t.z) < 0.9 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
  *e1 = cross(helper, t).normalized();
  *e2 = cross(t, *e1);
}

struct Ring {
  std::vector<Vec3> points, normals;
  Rgb color;
};

Ring make_ring(const Knot& k, const Stem& stem, double r, int sides, double min_d, const Rgb& c) {
  Ring ring;
  ring.color = c;
  const Vec3 centre = k.axis_point(r, stem);
  const Vec3 t = k.axis_direction(r, stem);
  Vec3 e1, e2;
  frame_around(t, &e1, &e2);
  const double half = 0.5 * std::max(k.diameter_at(r), min_d);
  for (int s = 0; s < sides; ++s) {
    const double a = kTwoPi * s / sides;
    const Vec3 n = std::cos(a) * e1 + std::sin(a) * e2;
    ring.points.push_back(centre + half * n);
    ring.normals.push_back(n);
  }
  return ring;
}

void connect(const Ring& a, const Ring& b, std::vector<MeshVertex>& out) {
  const int n = static_cast<int>(a.points.size());
  for (int s = 0; s < n; ++s) {
    const int s1 = (s + 1) % n;
    const MeshVertex a0 = vertex(a.points[s], a.normals[s], a.color);
    const MeshVertex a1 = vertex(a.points[s1], a.normals[s1], a.color);
    const MeshVertex b0 = vertex(b.points[s], b.normals[s], b.color);
    const MeshVertex b1 = vertex(b.points[s1], b.normals[s1], b.color);
    out.insert(out.end(), {a0, a1, b1, a0, b1, b0});
  }
}

void cap(const Ring& ring, const Vec3& centre, const Vec3& normal, std::vector<MeshVertex>& out) {
  const int n = static_cast<int>(ring.points.size());
  for (int s = 0; s < n; ++s)
    out.insert(out.end(),
               {vertex(centre, normal, ring.color), vertex(ring.points[s], normal, ring.color),
                vertex(ring.points[(s + 1) % n], normal, ring.color)});
}

void line(const Vec3& a, const Vec3& b, const Rgb& c, std::vector<MeshVertex>& out) {
  const Vec3 n{0, 0, 1};
  out.push_back(vertex(a, n, c));
  out.push_back(vertex(b, n, c));
}

}  // namespace

Mesh knot_tubes(const LogModel& log, const KnotTubeOptions& o) {
  Mesh mesh;
  const int rings = std::max(2, o.rings), sides = std::max(3, o.sides);
  for (const Knot& k : log.knots) {
    if (!(k.r_end > 0)) continue;
    // Pith distances: denser near the pith, where the √r term bends the axis; r_dead exactly,
    // once in each colour, so the dead part starts with a sharp border.
    std::vector<double> rs;
    for (int i = 0; i <= rings; ++i) {
      const double f = static_cast<double>(i) / rings;
      rs.push_back(k.r_end * f * f);
    }
    const bool has_dead = k.r_dead > 0 && k.r_dead < k.r_end;
    if (has_dead) {
      rs.push_back(k.r_dead);
      std::sort(rs.begin(), rs.end());
    }
    Ring prev = make_ring(k, log.stem, rs[0], sides, o.min_diameter_mm, o.sound_color);
    for (size_t i = 1; i < rs.size(); ++i) {
      const double r = rs[i];
      if (r - rs[i - 1] < 1e-9) continue;
      const bool dead = k.dead_at(0.5 * (rs[i - 1] + r));
      const Rgb& c = dead ? o.dead_color : o.sound_color;
      if (prev.color != c) prev = make_ring(k, log.stem, rs[i - 1], sides, o.min_diameter_mm, c);
      Ring ring = make_ring(k, log.stem, r, sides, o.min_diameter_mm, c);
      connect(prev, ring, mesh.vertices);
      prev = std::move(ring);
    }
    cap(prev, k.axis_point(k.r_end, log.stem), k.axis_direction(k.r_end, log.stem), mesh.vertices);
  }
  return mesh;
}

Mesh board_outline(const BoardBox& b, const Rgb& color) {
  Mesh mesh;
  mesh.lines = true;
  const Vec3 u = b.u(), v = b.v(), c{b.cx, b.cy, 0};
  Vec3 corners[2][4];
  for (int e = 0; e < 2; ++e) {
    const Vec3 z{0, 0, e == 0 ? b.z0 : b.z1};
    const double hw = 0.5 * b.width, ht = 0.5 * b.thickness;
    corners[e][0] = c + z - hw * u - ht * v;
    corners[e][1] = c + z + hw * u - ht * v;
    corners[e][2] = c + z + hw * u + ht * v;
    corners[e][3] = c + z - hw * u + ht * v;
  }
  for (int e = 0; e < 2; ++e)
    for (int i = 0; i < 4; ++i) line(corners[e][i], corners[e][(i + 1) % 4], color, mesh.vertices);
  for (int i = 0; i < 4; ++i) line(corners[0][i], corners[1][i], color, mesh.vertices);
  return mesh;
}

namespace {

// The triangles of a tube given as rows x angles points (row by row, closed around), each
// vertex's normal from its neighbours along and around.
void push_tube(const std::vector<Vec3>& p, int rows, int angles, const Rgb& color, Mesh& mesh) {
  auto at = [&](int i, int k) -> const Vec3& {
    i = std::clamp(i, 0, rows - 1);
    k = ((k % angles) + angles) % angles;
    return p[static_cast<size_t>(i) * angles + k];
  };
  auto normal = [&](int i, int k) {
    return cross(at(i, k + 1) - at(i, k - 1), at(i + 1, k) - at(i - 1, k)).normalized();
  };
  for (int i = 0; i + 1 < rows; ++i)
    for (int k = 0; k < angles; ++k) {
      const MeshVertex a = vertex(at(i, k), normal(i, k), color);
      const MeshVertex b = vertex(at(i, k + 1), normal(i, k + 1), color);
      const MeshVertex c = vertex(at(i + 1, k + 1), normal(i + 1, k + 1), color);
      const MeshVertex d = vertex(at(i + 1, k), normal(i + 1, k), color);
      mesh.vertices.insert(mesh.vertices.end(), {a, b, c, a, c, d});
    }
}

}  // namespace

Mesh log_surface(const Stem& stem, const Rgb& color, int angles, double step_mm) {
  Mesh mesh;
  angles = std::max(3, angles);
  const double z0 = stem.z_begin(), z1 = stem.z_end();
  const int rows = std::max(2, static_cast<int>(std::ceil((z1 - z0) / std::max(step_mm, 0.1))) + 1);
  std::vector<Vec3> p(static_cast<size_t>(rows) * angles);
  for (int i = 0; i < rows; ++i) {
    const double z = z0 + (z1 - z0) * i / (rows - 1);
    const Vec2 c = stem.pith_at(z);
    for (int k = 0; k < angles; ++k) {
      const double w = kTwoPi * k / angles, r = stem.radius_at(w, z);
      p[static_cast<size_t>(i) * angles + k] = {c.x + r * std::cos(w), c.y + r * std::sin(w), z};
    }
  }
  push_tube(p, rows, angles, color, mesh);
  return mesh;
}

namespace {

// Bark thickness at height z: Stem::bark_mm linear between samples, clamped at the ends.
double bark_at(const Stem& stem, double z, double default_mm) {
  const int n = static_cast<int>(stem.bark_mm.size());
  if (n == 0 || n != stem.slice_count()) return default_mm;
  const double f = std::clamp((z - stem.z0_mm) / stem.dz_mm, 0.0, n - 1.0);
  const int i = std::min(n - 2, static_cast<int>(f));
  if (n == 1) return stem.bark_mm[0];
  const double t = f - i;
  return std::max(0.0, (1 - t) * stem.bark_mm[i] + t * stem.bark_mm[i + 1]);
}

}  // namespace

Mesh bark_surface(const Stem& stem, double default_bark_mm, const Rgb& color, int angles,
                  double step_mm) {
  Mesh mesh;
  if (stem.slice_count() == 0) return mesh;
  angles = std::max(3, angles);
  const double z0 = stem.z_begin(), z1 = stem.z_end();
  const int rows = std::max(2, static_cast<int>(std::ceil((z1 - z0) / std::max(step_mm, 0.1))) + 1);
  // Outside of the bark and the wood's outline under it, per row and angle.
  std::vector<Vec3> p(static_cast<size_t>(rows) * angles), w(p.size());
  for (int i = 0; i < rows; ++i) {
    const double z = z0 + (z1 - z0) * i / (rows - 1);
    const Vec2 c = stem.pith_at(z);
    const double bark = bark_at(stem, z, default_bark_mm);
    for (int k = 0; k < angles; ++k) {
      const double a = kTwoPi * k / angles, r = stem.radius_at(a, z);
      const Vec2 d{std::cos(a), std::sin(a)};
      p[static_cast<size_t>(i) * angles + k] = {c.x + (r + bark) * d.x, c.y + (r + bark) * d.y, z};
      w[static_cast<size_t>(i) * angles + k] = {c.x + r * d.x, c.y + r * d.y, z};
    }
  }
  push_tube(p, rows, angles, color, mesh);
  // The bark's ring at each end, facing out along the log.
  for (int e = 0; e < 2; ++e) {
    const int i = e == 0 ? 0 : rows - 1;
    const Vec3 n{0, 0, e == 0 ? -1.0 : 1.0};
    for (int k = 0; k < angles; ++k) {
      const int k1 = (k + 1) % angles;
      const size_t a = static_cast<size_t>(i) * angles + k,
                   b = static_cast<size_t>(i) * angles + k1;
      mesh.vertices.insert(mesh.vertices.end(), {vertex(w[a], n, color), vertex(p[a], n, color),
                                                 vertex(p[b], n, color), vertex(w[a], n, color),
                                                 vertex(p[b], n, color), vertex(w[b], n, color)});
    }
  }
  return mesh;
}

Mesh board_block(const BoardBox& b, const Rgb& color) {
  Mesh mesh;
  const Vec3 u = b.u(), v = b.v(), zc{0, 0, 1};
  const Vec3 c{b.cx, b.cy, 0.5 * (b.z0 + b.z1)};
  const double hu = 0.5 * b.width, hv = 0.5 * b.thickness, hz = 0.5 * (b.z1 - b.z0);
  // Each face: its outward normal n and two in-plane half axes s, t with s × t = n.
  struct FaceAxes {
    Vec3 n, s, t;
    double hn, hs, ht;
  };
  const FaceAxes faces[] = {{u, v, zc, hu, hv, hz}, {-1.0 * u, zc, v, hu, hz, hv},
                            {v, zc, u, hv, hz, hu}, {-1.0 * v, u, zc, hv, hu, hz},
                            {zc, u, v, hz, hu, hv}, {-1.0 * zc, v, u, hz, hv, hu}};
  for (const FaceAxes& f : faces) {
    const Vec3 o = c + f.hn * f.n;
    const Vec3 a = o - f.hs * f.s - f.ht * f.t, bb = o + f.hs * f.s - f.ht * f.t;
    const Vec3 cc = o + f.hs * f.s + f.ht * f.t, d = o - f.hs * f.s + f.ht * f.t;
    mesh.vertices.insert(mesh.vertices.end(),
                         {vertex(a, f.n, color), vertex(bb, f.n, color), vertex(cc, f.n, color),
                          vertex(a, f.n, color), vertex(cc, f.n, color), vertex(d, f.n, color)});
  }
  return mesh;
}

Mesh pith_line(const Stem& stem, const Rgb& color) {
  Mesh mesh;
  mesh.lines = true;
  for (int i = 0; i + 1 < stem.slice_count(); ++i) {
    const Vec2 a = stem.pith[i], b = stem.pith[i + 1];
    line({a.x, a.y, stem.z_at(i)}, {b.x, b.y, stem.z_at(i + 1)}, color, mesh.vertices);
  }
  return mesh;
}

}  // namespace sawyer::render

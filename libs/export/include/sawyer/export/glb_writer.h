// Binary glTF 2.0 (.glb, Khronos glTF 2.0 specification, section "GLB File Format
// Specification"): a scene of textured triangle meshes, one node per mesh, with every buffer and
// image inside the file. Built as bytes in memory, written atomically.
//
//   GlbScene s;
//   s.meshes.push_back(mesh);                 // positions in metres, relative to `translation`
//   s.images.push_back(encode_png(img).value());
//   Status st = write_glb("boards.glb", s);   // temporary file beside it, then a rename
//
// Axes are written as given: glTF's +y is up, so a caller with another convention turns its
// points first. Thread safe (no shared state).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sawyer/core/result.h"
#include "sawyer/render/image.h"

namespace sawyer::exporter {

struct GlbMesh {
  std::string name;                     // the node's and the mesh's name
  std::array<double, 3> translation{};  // the node's, metres
  std::vector<float> positions;         // x, y, z per vertex, metres (relative to translation)
  std::vector<float> normals;           // unit x, y, z per vertex
  std::vector<float> tangents;          // unit x, y, z and handedness ±1 per vertex
  std::vector<float> uvs;               // u, v per vertex (v = 0 at the image's top row)
  std::vector<std::uint32_t> indices;   // triangles, counter-clockwise seen from outside
  // PBR textures: indices into GlbScene::images (-1: none).
  int base_color = -1, normal = -1, metallic_roughness = -1;
  nlohmann::json extras = nlohmann::json::object();  // the node's extras
};

struct GlbScene {
  std::string name;
  std::string generator = "Sawyer";
  std::vector<GlbMesh> meshes;
  std::vector<std::vector<std::uint8_t>> images;     // encoded PNG files
  nlohmann::json extras = nlohmann::json::object();  // the scene's extras
};

// The scene as a .glb file's bytes. Asserts on inconsistent meshes (a programmer's mistake).
std::vector<std::uint8_t> glb_bytes(const GlbScene& scene);

// Writes glb_bytes(scene) atomically; the error names the file.
Status write_glb(const std::filesystem::path& path, const GlbScene& scene);

// An 8-bit image as the bytes of a PNG file (OpenImageIO), RGB when `alpha` is false.
Result<std::vector<std::uint8_t>> encode_png(const render::Image& image, bool alpha = false);

}  // namespace sawyer::exporter

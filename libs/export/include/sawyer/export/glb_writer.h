// glTF 2.0 (Khronos glTF 2.0 specification): a scene of textured triangle meshes, one node per
// mesh, written as binary glTF (.glb, section "GLB File Format Specification": every buffer and
// image inside the file) or as text glTF (.gltf: the JSON, its geometry in "<stem>.bin" and each
// image in "<stem>_<name>.png" beside it). Built in memory, written atomically.
//
//   GlbScene s;
//   s.meshes.push_back(mesh);                 // positions in metres, relative to `translation`
//   s.images.push_back(encode_png(img).value());
//   Status st = write_glb("boards.glb", s);   // temporary file beside it, then a rename
//   Status t = write_gltf("boards.gltf", s);  // boards.gltf, boards.bin, boards_<name>.png
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
  std::vector<std::vector<std::uint8_t>> images;  // encoded PNG files
  // Optional, one per image: its name in the file ("board1_color"); in a .gltf also its file's,
  // "<stem>_<name>.png" (letters, digits, '_' and '-' only). Empty: "image<i>".
  std::vector<std::string> image_names;
  nlohmann::json extras = nlohmann::json::object();  // the scene's extras
};

// The scene as a .glb file's bytes. Asserts on inconsistent meshes (a programmer's mistake).
std::vector<std::uint8_t> glb_bytes(const GlbScene& scene);

// Writes glb_bytes(scene) atomically; the error names the file.
Status write_glb(const std::filesystem::path& path, const GlbScene& scene);

// The files a .gltf at `path` keeps beside it for `scene`: "<stem>.bin" (when the scene has any
// geometry) and "<stem>_<name>.png" per image, in the .gltf's folder.
std::vector<std::filesystem::path> gltf_sidecars(const std::filesystem::path& path,
                                                 const GlbScene& scene);

// Whether the .gltf at `path` may be written with `sidecars` beside it: each of them absent, or a
// regular file that an earlier Sawyer .gltf at `path` lists (its buffer or image URIs), and none
// of them one of `inputs`. The error names `option`, the .gltf and the file: Sawyer never
// replaces a file it did not write there (docs/reliability.md, rule 1).
Status check_gltf_sidecars(const std::filesystem::path& path,
                           const std::vector<std::filesystem::path>& sidecars,
                           const std::vector<std::filesystem::path>& inputs,
                           const std::string& option);

// Writes the scene as text glTF: every file to a temporary beside its final name first, then the
// sidecars renamed into place and the .gltf last; a failure before the renames leaves nothing.
// The files of an earlier Sawyer .gltf at `path` that this one no longer uses are removed. The
// error names the file. Call check_gltf_sidecars first.
Status write_gltf(const std::filesystem::path& path, const GlbScene& scene);

// An 8-bit image as the bytes of a PNG file (OpenImageIO), RGB when `alpha` is false.
Result<std::vector<std::uint8_t>> encode_png(const render::Image& image, bool alpha = false);

}  // namespace sawyer::exporter

#include "sawyer/export/glb_writer.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cassert>
#include <cstring>
#include <fstream>
#include <limits>

#include "sawyer/core/file_util.h"

namespace sawyer::exporter {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr int kFloat = 5126, kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

// The binary chunk as it grows: each view starts on a 4-byte boundary.
struct Bin {
  std::vector<std::uint8_t> bytes;
  json views = json::array();
  int add(const void* data, size_t n, int target) {
    while (bytes.size() % 4) bytes.push_back(0);
    json v = {{"buffer", 0}, {"byteOffset", bytes.size()}, {"byteLength", n}};
    if (target) v["target"] = target;
    const auto* p = static_cast<const std::uint8_t*>(data);
    bytes.insert(bytes.end(), p, p + n);
    views.push_back(v);
    return static_cast<int>(views.size()) - 1;
  }
};

void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

}  // namespace

std::vector<std::uint8_t> glb_bytes(const GlbScene& scene) {
  Bin bin;
  json accessors = json::array(), meshes = json::array(), nodes = json::array(),
       materials = json::array(), textures = json::array(), images = json::array();
  auto accessor = [&](const std::vector<float>& v, int comps, const char* type, bool bounds) {
    const int view = bin.add(v.data(), v.size() * sizeof(float), kArrayBuffer);
    json a = {{"bufferView", view},
              {"componentType", kFloat},
              {"count", v.size() / comps},
              {"type", type}};
    if (bounds) {
      std::vector<float> lo(comps, std::numeric_limits<float>::max()),
          hi(comps, std::numeric_limits<float>::lowest());
      for (size_t i = 0; i < v.size(); ++i) {
        lo[i % comps] = std::min(lo[i % comps], v[i]);
        hi[i % comps] = std::max(hi[i % comps], v[i]);
      }
      a["min"] = lo;
      a["max"] = hi;
    }
    accessors.push_back(a);
    return static_cast<int>(accessors.size()) - 1;
  };

  for (const auto& png : scene.images) {
    const int view = bin.add(png.data(), png.size(), 0);
    images.push_back({{"bufferView", view}, {"mimeType", "image/png"}});
    textures.push_back({{"sampler", 0}, {"source", images.size() - 1}});
  }
  std::vector<int> scene_nodes;
  for (const GlbMesh& m : scene.meshes) {
    [[maybe_unused]] const size_t n = m.positions.size() / 3;
    assert(m.positions.size() == 3 * n && m.normals.size() == 3 * n && m.uvs.size() == 2 * n);
    assert(m.tangents.empty() || m.tangents.size() == 4 * n);
    json attrs = {{"POSITION", accessor(m.positions, 3, "VEC3", true)},
                  {"NORMAL", accessor(m.normals, 3, "VEC3", false)},
                  {"TEXCOORD_0", accessor(m.uvs, 2, "VEC2", false)}};
    if (!m.tangents.empty()) attrs["TANGENT"] = accessor(m.tangents, 4, "VEC4", false);
    const int iview =
        bin.add(m.indices.data(), m.indices.size() * sizeof(std::uint32_t), kElementArrayBuffer);
    accessors.push_back({{"bufferView", iview},
                         {"componentType", kUnsignedInt},
                         {"count", m.indices.size()},
                         {"type", "SCALAR"}});
    json prim = {{"attributes", attrs}, {"indices", accessors.size() - 1}, {"mode", 4}};
    if (m.base_color >= 0 || m.normal >= 0 || m.metallic_roughness >= 0) {
      json pbr = {{"metallicFactor", m.metallic_roughness >= 0 ? 1.0 : 0.0},
                  {"roughnessFactor", 1.0}};
      if (m.base_color >= 0) pbr["baseColorTexture"] = {{"index", m.base_color}};
      if (m.metallic_roughness >= 0)
        pbr["metallicRoughnessTexture"] = {{"index", m.metallic_roughness}};
      json mat = {{"name", m.name}, {"pbrMetallicRoughness", pbr}};
      if (m.normal >= 0) mat["normalTexture"] = {{"index", m.normal}};
      materials.push_back(mat);
      prim["material"] = materials.size() - 1;
    }
    meshes.push_back({{"name", m.name}, {"primitives", json::array({prim})}});
    json node = {{"name", m.name}, {"mesh", meshes.size() - 1}};
    if (m.translation != std::array<double, 3>{}) node["translation"] = m.translation;
    if (!m.extras.empty()) node["extras"] = m.extras;
    nodes.push_back(node);
    scene_nodes.push_back(static_cast<int>(nodes.size()) - 1);
  }
  while (bin.bytes.size() % 4) bin.bytes.push_back(0);

  json gltf = {{"asset", {{"version", "2.0"}, {"generator", scene.generator}}}};
  json sc = {{"nodes", scene_nodes}};
  if (!scene.name.empty()) sc["name"] = scene.name;
  if (!scene.extras.empty()) sc["extras"] = scene.extras;
  gltf["scene"] = 0;
  gltf["scenes"] = json::array({sc});
  gltf["nodes"] = nodes;
  if (!meshes.empty()) gltf["meshes"] = meshes;
  if (!materials.empty()) gltf["materials"] = materials;
  if (!textures.empty()) {
    gltf["textures"] = textures;
    gltf["images"] = images;
    // Linear filtering with mipmaps, clamped: each face's texels end at its rectangle's padding.
    gltf["samplers"] = json::array(
        {{{"magFilter", 9729}, {"minFilter", 9987}, {"wrapS", 33071}, {"wrapT", 33071}}});
  }
  if (!accessors.empty()) gltf["accessors"] = accessors;
  if (!bin.views.empty()) gltf["bufferViews"] = bin.views;
  if (!bin.bytes.empty()) gltf["buffers"] = json::array({{{"byteLength", bin.bytes.size()}}});

  std::string text = gltf.dump();
  while (text.size() % 4) text.push_back(' ');  // the JSON chunk is padded with spaces
  std::vector<std::uint8_t> out;
  const size_t total = 12 + 8 + text.size() + (bin.bytes.empty() ? 0 : 8 + bin.bytes.size());
  out.reserve(total);
  put_u32(out, 0x46546C67);  // "glTF"
  put_u32(out, 2);
  put_u32(out, static_cast<std::uint32_t>(total));
  put_u32(out, static_cast<std::uint32_t>(text.size()));
  put_u32(out, 0x4E4F534A);  // "JSON"
  out.insert(out.end(), text.begin(), text.end());
  if (!bin.bytes.empty()) {
    put_u32(out, static_cast<std::uint32_t>(bin.bytes.size()));
    put_u32(out, 0x004E4942);  // "BIN\0"
    out.insert(out.end(), bin.bytes.begin(), bin.bytes.end());
  }
  assert(out.size() == total);
  return out;
}

Status write_glb(const fs::path& path, const GlbScene& scene) {
  const std::vector<std::uint8_t> bytes = glb_bytes(scene);
  if (bytes.size() > std::numeric_limits<std::uint32_t>::max())
    return Error(path.string(), "the scene is larger than a .glb file can hold (4 GiB)");
  return write_file_atomic(path, [&](const fs::path& tmp) -> Status {
    std::ofstream f(tmp, std::ios::binary);
    f.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
    f.close();
    if (!f) return Error(path.string(), "cannot write");
    return Status::Ok();
  });
}

Result<std::vector<std::uint8_t>> encode_png(const render::Image& image, bool alpha) {
  assert(!image.is_float() && image.channels == 4);
  const int channels = alpha ? 4 : 3;
  std::vector<std::uint8_t> pixels(static_cast<size_t>(image.width) * image.height * channels);
  for (size_t p = 0; p < static_cast<size_t>(image.width) * image.height; ++p)
    for (int c = 0; c < channels; ++c) pixels[p * channels + c] = image.u8[p * 4 + c];
  std::vector<unsigned char> buf;
  OIIO::Filesystem::IOVecOutput vec(buf);
  auto out = OIIO::ImageOutput::create("png");
  if (!out) return Error("PNG", "OpenImageIO has no PNG writer");
  OIIO::ImageSpec spec(image.width, image.height, channels, OIIO::TypeDesc::UINT8);
  OIIO::Filesystem::IOProxy* proxy = &vec;
  spec.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy);
  spec.attribute("png:compressionLevel", 6);
  if (!out->open("memory.png", spec) || !out->write_image(OIIO::TypeDesc::UINT8, pixels.data()) ||
      !out->close())
    return Error("PNG", "encoding failed: " + out->geterror());
  return std::vector<std::uint8_t>(buf.begin(), buf.end());
}

}  // namespace sawyer::exporter

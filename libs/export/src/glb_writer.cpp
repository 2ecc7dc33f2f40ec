#include "sawyer/export/glb_writer.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cassert>
#include <cctype>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <string>

#include "sawyer/core/file_util.h"
#include "sawyer/core/interrupt.h"

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

// Image i's name: the scene's, kept to letters, digits, '_' and '-', or "image<i>".
std::string image_name(const GlbScene& scene, size_t i) {
  std::string n = i < scene.image_names.size() ? scene.image_names[i] : "";
  for (char& c : n)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') c = '_';
  return n.empty() ? "image" + std::to_string(i) : n;
}

// A file name as a relative URI (RFC 3986): every byte but the unreserved ones percent-encoded.
std::string uri_of(const std::string& name) {
  static const char* hex = "0123456789ABCDEF";
  std::string u;
  for (unsigned char c : name) {
    if (std::isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~') {
      u += static_cast<char>(c);
    } else {
      u += '%';
      u += hex[c >> 4];
      u += hex[c & 15];
    }
  }
  return u;
}

// The scene's JSON and its binary buffer. `embed`: the images are buffer views (.glb); else
// image i refers to image_uris[i] and the buffer to bin_uri (.gltf).
struct Built {
  json gltf;
  std::vector<std::uint8_t> bin;
};

Built build(const GlbScene& scene, bool embed, const std::string& bin_uri,
            const std::vector<std::string>& image_uris) {
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

  for (size_t i = 0; i < scene.images.size(); ++i) {
    const auto& png = scene.images[i];
    json image = {{"name", image_name(scene, i)}};
    if (embed) {
      image["bufferView"] = bin.add(png.data(), png.size(), 0);
      image["mimeType"] = "image/png";
    } else {
      image["uri"] = image_uris[i];
    }
    images.push_back(image);
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
  if (!bin.bytes.empty()) {
    json buffer = {{"byteLength", bin.bytes.size()}};
    if (!embed) buffer["uri"] = bin_uri;
    gltf["buffers"] = json::array({buffer});
  }
  return {std::move(gltf), std::move(bin.bytes)};
}

// The names of a .gltf's sidecars: the .bin first, then the images.
std::vector<std::string> sidecar_names(const fs::path& path, const GlbScene& scene) {
  const std::string stem = path.stem().string();
  std::vector<std::string> names = {stem + ".bin"};
  for (size_t i = 0; i < scene.images.size(); ++i)
    names.push_back(stem + "_" + image_name(scene, i) + ".png");
  return names;
}

// The plain file names an earlier Sawyer .gltf at `path` lists as its buffers' and images' URIs
// (nothing when it is not one, or cannot be read).
std::vector<std::string> earlier_sidecars(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return {};
  Result<std::string> text = read_text_file(path, 64u << 20);
  if (!text) return {};
  const json j = json::parse(text.value(), nullptr, false);
  if (!j.is_object() || !j.contains("asset") || !j["asset"].is_object()) return {};
  const json& gen = j["asset"].value("generator", json());
  if (!gen.is_string() || gen.get<std::string>().rfind("Sawyer", 0) != 0) return {};
  std::vector<std::string> names;
  for (const char* key : {"buffers", "images"}) {
    if (!j.contains(key) || !j[key].is_array()) continue;
    for (const json& e : j[key]) {
      if (!e.is_object() || !e.contains("uri") || !e["uri"].is_string()) continue;
      std::string uri = e["uri"];
      // Percent-decoded; only a plain name in the .gltf's own folder counts.
      std::string name;
      for (size_t i = 0; i < uri.size(); ++i) {
        if (uri[i] == '%' && i + 2 < uri.size() &&
            std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
            std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
          name += static_cast<char>(std::stoi(uri.substr(i + 1, 2), nullptr, 16));
          i += 2;
        } else {
          name += uri[i];
        }
      }
      if (name.empty() || name.find('/') != std::string::npos || name == "." || name == ".." ||
          name.find(':') != std::string::npos)
        continue;
      names.push_back(name);
    }
  }
  return names;
}

Status write_bytes(const fs::path& file, const fs::path& name, const void* data, size_t n) {
  std::ofstream f(file, std::ios::binary);
  f.write(static_cast<const char*>(data), static_cast<std::streamsize>(n));
  f.close();
  if (!f) return Error(name.string(), "cannot write");
  return Status::Ok();
}

}  // namespace

std::vector<std::uint8_t> glb_bytes(const GlbScene& scene) {
  const Built built = build(scene, true, "", {});
  const json& gltf = built.gltf;
  const std::vector<std::uint8_t>& bin = built.bin;
  std::string text = gltf.dump();
  while (text.size() % 4) text.push_back(' ');  // the JSON chunk is padded with spaces
  std::vector<std::uint8_t> out;
  const size_t total = 12 + 8 + text.size() + (bin.empty() ? 0 : 8 + bin.size());
  out.reserve(total);
  put_u32(out, 0x46546C67);  // "glTF"
  put_u32(out, 2);
  put_u32(out, static_cast<std::uint32_t>(total));
  put_u32(out, static_cast<std::uint32_t>(text.size()));
  put_u32(out, 0x4E4F534A);  // "JSON"
  out.insert(out.end(), text.begin(), text.end());
  if (!bin.empty()) {
    put_u32(out, static_cast<std::uint32_t>(bin.size()));
    put_u32(out, 0x004E4942);  // "BIN\0"
    out.insert(out.end(), bin.begin(), bin.end());
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

std::vector<fs::path> gltf_sidecars(const fs::path& path, const GlbScene& scene) {
  std::vector<fs::path> out;
  for (const std::string& n : sidecar_names(path, scene)) out.push_back(path.parent_path() / n);
  return out;
}

Status check_gltf_sidecars(const fs::path& path, const std::vector<fs::path>& sidecars,
                           const std::vector<fs::path>& inputs, const std::string& option) {
  const std::vector<std::string> earlier = earlier_sidecars(path);
  std::error_code ec;
  for (const fs::path& f : sidecars) {
    for (const fs::path& in : inputs)
      if (!in.empty() && fs::exists(in, ec) && fs::exists(f, ec) && fs::equivalent(in, f, ec))
        return Error(option, path.string() + ": its " + f.filename().string() +
                                 " would replace the input " + in.string());
    const fs::file_status st = fs::symlink_status(f, ec);
    if (!fs::exists(st)) continue;
    const bool ours = fs::is_regular_file(st) && std::find(earlier.begin(), earlier.end(),
                                                           f.filename().string()) != earlier.end();
    if (!ours)
      return Error(option, path.string() + ": " + f.string() +
                               " exists and is not a file of an earlier Sawyer .gltf of that name; "
                               "not replaced (a .gltf keeps its .bin and images beside it: give "
                               "another name or folder)");
  }
  return Status::Ok();
}

Status write_gltf(const fs::path& path, const GlbScene& scene) {
  const std::vector<std::string> names = sidecar_names(path, scene);
  std::vector<std::string> image_uris;
  for (size_t i = 1; i < names.size(); ++i) image_uris.push_back(uri_of(names[i]));
  const Built built = build(scene, false, uri_of(names[0]), image_uris);
  const fs::path dir = path.parent_path();
  // Every file staged under a temporary name (removed if a signal arrives meanwhile), then moved
  // into place: the sidecars first, the .gltf that refers to them last.
  struct Staged {
    fs::path final, tmp;
  };
  std::vector<Staged> staged;
  std::vector<std::unique_ptr<TrackedTemp>> tracked;
  auto remove_staged = [&]() {
    std::error_code ec;
    for (const Staged& s : staged) fs::remove(s.tmp, ec);
  };
  auto stage = [&](const fs::path& final, const void* data, size_t n) -> Status {
    const fs::path tmp = temp_sibling(final);
    tracked.push_back(std::make_unique<TrackedTemp>(tmp));
    staged.push_back({final, tmp});
    return write_bytes(tmp, final, data, n);
  };
  Status st = Status::Ok();
  if (!built.bin.empty()) st = stage(dir / names[0], built.bin.data(), built.bin.size());
  for (size_t i = 0; st && i < scene.images.size(); ++i)
    st = stage(dir / names[i + 1], scene.images[i].data(), scene.images[i].size());
  const std::string text = built.gltf.dump(1) + "\n";
  if (st) st = stage(path, text.data(), text.size());
  if (!st) {
    remove_staged();
    return st;
  }
  const std::vector<std::string> earlier = earlier_sidecars(path);
  std::error_code ec;
  for (size_t i = 0; i < staged.size(); ++i) {
    fs::rename(staged[i].tmp, staged[i].final, ec);
    if (ec) {
      for (size_t j = i; j < staged.size(); ++j) fs::remove(staged[j].tmp, ec);
      return Error(staged[i].final.string(), "cannot move the written file into place");
    }
  }
  // An earlier export's files that this one does not use (it had more boards) go with it.
  for (const std::string& old : earlier)
    if (std::find(names.begin(), names.end(), old) == names.end()) fs::remove(dir / old, ec);
  return Status::Ok();
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

#include "sawyer/render/image.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <exception>
#include <string>

#include "sawyer/core/file_util.h"

namespace sawyer::render {
namespace fs = std::filesystem;

namespace {

std::string lower_ext(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e;
}

std::string one_line(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// OpenImageIO's message without its own mention of the file (ours leads the message).
std::string without_path(std::string s, const fs::path& path) {
  const std::string name = path.string();
  std::string quoted;
  quoted.append(1, '"').append(name).append(1, '"');
  std::string quoted_colon = quoted;
  quoted_colon.append(": ");
  std::string name_colon = name;
  name_colon.append(": ");
  for (const std::string* p : {&quoted_colon, &quoted, &name_colon})
    for (size_t at = s.find(*p); at != std::string::npos; at = s.find(*p)) s.erase(at, p->size());
  return one_line(s);
}

}  // namespace

float Image::value(int x, int y, int c) const {
  const size_t i = (static_cast<size_t>(y) * width + x) * channels + c;
  return is_float() ? f32[i] : u8[i] / 255.0f;
}

bool is_image_extension(const fs::path& path) {
  const std::string e = lower_ext(path);
  return e == ".png" || e == ".tif" || e == ".tiff" || e == ".exr" || e == ".jpg" || e == ".jpeg";
}

Status write_image(const fs::path& path, const Image& image) {
  if (!is_image_extension(path))
    return Error(path.string(), "unknown image type '" + path.extension().string() +
                                    "' (use .png, .tif, .exr or .jpg)");
  const size_t n = static_cast<size_t>(image.width) * image.height * image.channels;
  if (image.width <= 0 || image.height <= 0 || (image.u8.size() != n && image.f32.size() != n))
    return Error(path.string(), "empty or inconsistent image");
  const std::string ext = lower_ext(path);
  const bool want_float = ext == ".exr" && image.is_float();
  const bool jpeg = ext == ".jpg" || ext == ".jpeg";
  const int channels = jpeg ? 3 : image.channels;
  // 8-bit pixels for every format but a float EXR.
  std::vector<std::uint8_t> bytes;
  std::vector<float> floats;
  if (want_float) {
    floats = image.f32;
  } else {
    bytes.resize(static_cast<size_t>(image.width) * image.height * channels);
    for (size_t p = 0; p < static_cast<size_t>(image.width) * image.height; ++p)
      for (int c = 0; c < channels; ++c) {
        const size_t i = p * image.channels + c;
        const float v = image.is_float() ? image.f32[i] : image.u8[i] / 255.0f;
        bytes[p * channels + c] =
            static_cast<std::uint8_t>(std::clamp(v, 0.0f, 1.0f) * 255.0f + 0.5f);
      }
  }
  return write_file_atomic(path, [&](const fs::path& tmp) -> Status {
    try {
      // The writer is chosen by the final name; the pixels go to the temporary one.
      std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(path.string());
      if (!out) return Error(path.string(), "no image writer for this format");
      OIIO::ImageSpec spec(image.width, image.height, channels,
                           want_float ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8);
      if (channels == 4) spec.alpha_channel = 3;
      if (ext == ".exr") spec.attribute("compression", "zip");
      if (!out->open(tmp.string(), spec))
        return Error(path.string(), "cannot open for writing (" + one_line(out->geterror()) + ")");
      const bool ok = want_float ? out->write_image(OIIO::TypeDesc::FLOAT, floats.data())
                                 : out->write_image(OIIO::TypeDesc::UINT8, bytes.data());
      if (!ok) {
        const std::string msg = one_line(out->geterror());
        out->close();
        return Error(path.string(), "write failed (" + msg + ")");
      }
      if (!out->close())
        return Error(path.string(), "write failed (" + one_line(out->geterror()) + ")");
      return Status::Ok();
    } catch (const std::exception& e) {
      return Error(path.string(), std::string("write failed (") + e.what() + ")");
    }
  });
}

Result<Image> read_image(const fs::path& path, bool as_float) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return Error(path.string(), "no such file");
  try {
    std::unique_ptr<OIIO::ImageInput> in = OIIO::ImageInput::open(path.string());
    if (!in)
      return Error(path.string(),
                   "cannot read as an image (" + without_path(OIIO::geterror(), path) + ")");
    const OIIO::ImageSpec& spec = in->spec();
    if (spec.width <= 0 || spec.height <= 0 ||
        static_cast<long long>(spec.width) * spec.height > (1LL << 28))
      return Error(path.string(), "implausible image size");
    const int nc = spec.nchannels;
    std::vector<float> all(static_cast<size_t>(spec.width) * spec.height * nc);
    if (!in->read_image(0, 0, 0, nc, OIIO::TypeDesc::FLOAT, all.data()))
      return Error(path.string(), "corrupt or truncated image (" + one_line(in->geterror()) + ")");
    in->close();
    Image img;
    img.width = spec.width;
    img.height = spec.height;
    img.channels = 4;
    const size_t n = static_cast<size_t>(spec.width) * spec.height;
    std::vector<float> rgba(n * 4);
    for (size_t p = 0; p < n; ++p) {
      for (int c = 0; c < 3; ++c) rgba[p * 4 + c] = all[p * nc + std::min(c, nc - 1)];
      rgba[p * 4 + 3] = nc >= 4 ? all[p * nc + 3] : 1.0f;
    }
    if (as_float) {
      img.f32 = std::move(rgba);
    } else {
      img.u8.resize(rgba.size());
      for (size_t i = 0; i < rgba.size(); ++i)
        img.u8[i] = static_cast<std::uint8_t>(std::clamp(rgba[i], 0.0f, 1.0f) * 255.0f + 0.5f);
    }
    return img;
  } catch (const std::exception& e) {
    return Error(path.string(), std::string("cannot read the image (") + e.what() + ")");
  }
}

Image downsample(const Image& big, int n) {
  if (n == 1) return big;
  Image out;
  out.width = big.width / n;
  out.height = big.height / n;
  out.channels = big.channels;
  out.u8.resize(static_cast<size_t>(out.width) * out.height * out.channels);
  const int c = big.channels;
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x)
      for (int k = 0; k < c; ++k) {
        int sum = 0;
        for (int dy = 0; dy < n; ++dy) {
          const std::uint8_t* row = &big.u8[(static_cast<size_t>(y * n + dy) * big.width) * c];
          for (int dx = 0; dx < n; ++dx) sum += row[(x * n + dx) * c + k];
        }
        out.u8[(static_cast<size_t>(y) * out.width + x) * c + k] =
            static_cast<std::uint8_t>((sum + n * n / 2) / (n * n));
      }
  return out;
}

}  // namespace sawyer::render

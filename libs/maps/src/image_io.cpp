#include "image_io.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <exception>
#include <system_error>

namespace sawyer::maps_detail {
namespace fs = std::filesystem;

namespace {

// OpenImageIO messages may span lines; ours are one line.
std::string one_line(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// Drops OpenImageIO's own mention of the file (ours already leads the message).
std::string strip_path(std::string s, const std::string& path) {
  for (const std::string& p : {"\"" + path + "\": ", "\"" + path + "\"", path + ": ", path}) {
    for (size_t at = s.find(p); !p.empty() && at != std::string::npos; at = s.find(p))
      s.erase(at, p.size());
  }
  for (const char* gap : {" .", "  "})
    for (size_t at = s.find(gap); at != std::string::npos; at = s.find(gap)) s.erase(at, 1);
  return s;
}

std::string with_detail(const std::string& what, const std::string& detail) {
  const std::string d = one_line(detail);
  return d.empty() ? what : what + " (" + d + ")";
}

// Checks that `path` names a readable regular file before OpenImageIO guesses at it.
Status check_input_file(const fs::path& path, const char* kind) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) return Error(path.string(), "no such file");
  if (fs::is_directory(st))
    return Error(path.string(), std::string("is a folder, expected ") + kind);
  // A FIFO would block the image reader and a device never ends.
  if (!fs::is_regular_file(st))
    return Error(path.string(), std::string("is not a regular file, expected ") + kind);
  return Status::Ok();
}

// Opens `path`, checks its size is sane, and reads channels [chbegin, chend) as `type`.
template <typename T>
Status read_pixels(OIIO::ImageInput& in, const fs::path& path, int chbegin, int chend,
                   OIIO::TypeDesc type, std::vector<T>* out) {
  const OIIO::ImageSpec& spec = in.spec();
  out->assign(static_cast<size_t>(spec.width) * spec.height * (chend - chbegin), T{});
  if (!in.read_image(0, 0, chbegin, chend, type, out->data()))
    return Error(path.string(), with_detail("corrupt or truncated image data",
                                            strip_path(in.geterror(), path.string())));
  return Status::Ok();
}

Result<std::unique_ptr<OIIO::ImageInput>> open_input(const fs::path& path, const char* kind) {
  if (Status st = check_input_file(path, kind); !st) return st.error();
  std::unique_ptr<OIIO::ImageInput> in = OIIO::ImageInput::open(path.string());
  if (!in) {
    return Error(path.string(), with_detail(std::string("cannot read as ") + kind,
                                            strip_path(OIIO::geterror(), path.string())));
  }
  const OIIO::ImageSpec& spec = in->spec();
  // Guard against absurd headers before allocating (a corrupt header can claim any size).
  constexpr long long kMaxPixels = 1LL << 28;
  if (spec.width <= 0 || spec.height <= 0 ||
      static_cast<long long>(spec.width) * spec.height > kMaxPixels)
    return Error(path.string(), "implausible image size " + std::to_string(spec.width) + " x " +
                                    std::to_string(spec.height));
  return in;
}

}  // namespace

Result<Rgb8Image> read_rgb8(const fs::path& path) {
  try {
    Result<std::unique_ptr<OIIO::ImageInput>> opened = open_input(path, "a BMP image");
    if (!opened) return opened.error();
    OIIO::ImageInput& in = *opened.value();
    const OIIO::ImageSpec& spec = in.spec();
    if (spec.nchannels < 3)
      return Error(path.string(), "expected an RGB image, found " + std::to_string(spec.nchannels) +
                                      " channel" + (spec.nchannels == 1 ? "" : "s"));
    Rgb8Image img;
    img.width = spec.width;
    img.height = spec.height;
    Status st = read_pixels(in, path, 0, 3, OIIO::TypeDesc::UINT8, &img.pixels);
    in.close();
    if (!st) return st.error();
    return img;
  } catch (const std::exception& e) {
    return Error(path.string(), with_detail("cannot read the image", e.what()));
  } catch (...) {
    return Error(path.string(), "cannot read the image");
  }
}

Result<FloatImage> read_float_channels(const fs::path& path,
                                       const std::vector<std::string>& wanted) {
  try {
    Result<std::unique_ptr<OIIO::ImageInput>> opened = open_input(path, "an OpenEXR image");
    if (!opened) return opened.error();
    OIIO::ImageInput& in = *opened.value();
    const OIIO::ImageSpec& spec = in.spec();
    std::vector<int> index;
    for (const std::string& name : wanted) {
      const int c = spec.channelindex(name);
      if (c < 0) return Error(path.string(), "missing channel '" + name + "'");
      index.push_back(c);
    }
    std::vector<float> all;
    Status st = read_pixels(in, path, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, &all);
    in.close();
    if (!st) return st.error();
    FloatImage img(spec.width, spec.height, wanted);
    const size_t n = static_cast<size_t>(spec.width) * spec.height;
    for (size_t p = 0; p < n; ++p)
      for (size_t c = 0; c < index.size(); ++c)
        img.pixels[p * index.size() + c] = all[p * spec.nchannels + index[c]];
    return img;
  } catch (const std::exception& e) {
    return Error(path.string(), with_detail("cannot read the image", e.what()));
  } catch (...) {
    return Error(path.string(), "cannot read the image");
  }
}

namespace {

Status write_image(const fs::path& path, const OIIO::ImageSpec& spec, OIIO::TypeDesc type,
                   const void* data, const std::string& shown) {
  try {
    std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(path.string());
    if (!out) return Error(shown, with_detail("no image writer for this format", OIIO::geterror()));
    if (!out->open(path.string(), spec))
      return Error(shown, with_detail("cannot open for writing", out->geterror()));
    if (!out->write_image(type, data)) {
      const std::string msg = out->geterror();
      out->close();
      return Error(shown, with_detail("write failed", msg));
    }
    if (!out->close()) return Error(shown, with_detail("write failed", out->geterror()));
    return Status::Ok();
  } catch (const std::exception& e) {
    return Error(shown, with_detail("write failed", e.what()));
  } catch (...) {
    return Error(shown, "write failed");
  }
}

}  // namespace

Status write_bmp_rgb8(const fs::path& path, const Rgb8Image& image, const std::string& shown) {
  OIIO::ImageSpec spec(image.width, image.height, 3, OIIO::TypeDesc::UINT8);
  spec.channelnames = {"R", "G", "B"};
  return write_image(path, spec, OIIO::TypeDesc::UINT8, image.pixels.data(), shown);
}

Status write_exr_float(const fs::path& path, const FloatImage& image, const std::string& shown) {
  OIIO::ImageSpec spec(image.width, image.height, static_cast<int>(image.channels.size()),
                       OIIO::TypeDesc::FLOAT);
  spec.channelnames = image.channels;
  spec.alpha_channel = -1;
  spec.attribute("compression", "zip");
  return write_image(path, spec, OIIO::TypeDesc::FLOAT, image.pixels.data(), shown);
}

}  // namespace sawyer::maps_detail

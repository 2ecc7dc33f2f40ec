// The VTK image data (.vti) reader: vtkXMLImageDataReader reads the file per slice (VTK's
// appended and compressed blocks can be read in part), after the checks here bound what its
// header declares (pieces, numbers, compressed block headers, the extent against the file's
// size on disk) so that VTK never allocates or reads what the file cannot hold.
#include <vtkInformation.h>
#include <vtkStreamingDemandDrivenPipeline.h>
#include <vtkXMLImageDataReader.h>

#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include "text_parse.h"
#include "volume_common.h"

namespace sawyer::ct::detail {

namespace {

// The <Piece Extent="..."> boxes of a .vti header. vtkXMLStructuredDataReader leaks its array
// iterators when asked for voxels that no piece holds, so the pieces must tile the whole extent.
Status check_vti_pieces(const std::string& xml, const int whole[6], const std::string& where) {
  long long covered = 0;
  int pieces = 0;
  for (size_t at = xml.find("<Piece"); at != std::string::npos; at = xml.find("<Piece", at + 6)) {
    const size_t end = xml.find('>', at);
    const size_t attr = xml.find(" Extent=\"", at);
    if (end == std::string::npos || attr == std::string::npos || attr > end)
      return Error(where, "corrupt VTK image file (a Piece without an Extent)");
    std::vector<double> e;
    const size_t close = xml.find('"', attr + 9);
    if (close == std::string::npos || close > end ||
        !parse_numbers(xml.substr(attr + 9, close - attr - 9), e) || e.size() != 6)
      return Error(where, "corrupt VTK image file (a Piece Extent is not 6 numbers)");
    long long voxels = 1;
    for (int a = 0; a < 3; ++a) {
      if (e[2 * a] < whole[2 * a] || e[2 * a + 1] > whole[2 * a + 1] || e[2 * a + 1] < e[2 * a])
        return Error(where, "corrupt VTK image file (a Piece Extent lies outside the WholeExtent)");
      voxels *= static_cast<long long>(e[2 * a + 1] - e[2 * a] + 1);
    }
    covered += voxels;
    ++pieces;
  }
  long long whole_voxels = 1;
  for (int a = 0; a < 3; ++a)
    whole_voxels *= static_cast<long long>(whole[2 * a + 1]) - whole[2 * a] + 1;
  if (pieces == 0 || covered != whole_voxels)
    return Error(where, "corrupt VTK image file (its pieces do not cover the WholeExtent)");
  return Status::Ok();
}

// Value of attribute `name` in the tag that starts at `tag` (up to its '>'), or "".
std::string xml_attribute(const std::string& xml, size_t tag, const std::string& name) {
  const size_t end = xml.find('>', tag);
  const size_t at = xml.find(" " + name + "=\"", tag);
  if (end == std::string::npos || at == std::string::npos || at > end) return std::string();
  const size_t from = at + name.size() + 3;
  const size_t close = xml.find('"', from);
  if (close == std::string::npos || close > end) return std::string();
  return xml.substr(from, close - from);
}

// VTK's XML reader keeps its default (spacing 1, origin 0) for an attribute it cannot parse, so
// "1.6 1.6 nan" would read as 1 mm: the ImageData element's own text must hold finite numbers.
Status check_vti_numbers(const std::string& xml, const std::string& where) {
  const size_t tag = xml.find("<ImageData");
  if (tag == std::string::npos) return Status::Ok();  // VTK reported what is missing already
  for (const char* name : {"Spacing", "Origin", "Direction"}) {
    const size_t want = std::string(name) == "Direction" ? 9 : 3;
    const std::string text = xml_attribute(xml, tag, name);
    if (text.empty()) continue;  // absent: VTK's default, as documented
    std::vector<double> v;
    if (!parse_numbers(text, v) || v.size() != want)
      return Error(where, std::string(name) + " \"" + text + "\" is not " + std::to_string(want) +
                              " finite numbers");
  }
  return Status::Ok();
}

// Decodes base64 (stops at the first character outside the alphabet).
std::string base64_decode(const std::string& text, size_t max_bytes) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  std::string out;
  uint32_t acc = 0;
  int bits = 0;
  for (char c : text) {
    const int v = value(c);
    if (v < 0) break;
    acc = (acc << 6) | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<char>((acc >> bits) & 0xFF));
      if (out.size() >= max_bytes) break;
    }
  }
  return out;
}

// VTK's compressed arrays start with a header: block count, block size, last block size, then
// one compressed size per block. vtkXMLDataParser allocates for the block count and block size
// before it checks them against anything (a 4 KB file can make it allocate gigabytes), so the
// first three words of every compressed array are checked here against the file's size.
Status check_vti_compression(const fs::path& file, const std::string& xml, size_t appended_tag,
                             uint64_t file_bytes, const std::string& where) {
  const size_t vtkfile = xml.find("<VTKFile");
  const size_t word = xml_attribute(xml, vtkfile, "header_type") == "UInt64" ? 8 : 4;
  std::string appended_encoding;
  uint64_t appended_start = 0;  // file offset of the byte after '_'
  if (appended_tag != std::string::npos) {
    appended_encoding = xml_attribute(xml, appended_tag, "encoding");
    const size_t underscore = xml.find('_', appended_tag);
    if (underscore == std::string::npos)
      return Error(where, "corrupt VTK image file (AppendedData)");
    appended_start = underscore + 1;
  }
  std::ifstream in(file, std::ios::binary);
  // The header as bytes: raw appended data, or base64 (appended or inline); 3 words suffice.
  auto header_words = [&](size_t tag) -> Result<std::vector<uint64_t>> {
    const std::string format = xml_attribute(xml, tag, "format");
    std::string bytes;
    if (format == "appended") {
      char* end = nullptr;
      const std::string off = xml_attribute(xml, tag, "offset");
      const unsigned long long offset = std::strtoull(off.c_str(), &end, 10);
      if (off.empty() || *end != '\0' || appended_tag == std::string::npos)
        return Error(where, "corrupt VTK image file (DataArray offset)");
      const uint64_t pos = appended_start + offset;
      if (pos >= file_bytes) return Error(where, "truncated: a DataArray offset lies past the end");
      const size_t want = appended_encoding == "base64" ? (3 * word + 2) / 3 * 4 : 3 * word;
      std::string chunk(want, '\0');
      in.clear();
      in.seekg(static_cast<std::streamoff>(pos));
      in.read(chunk.data(), static_cast<std::streamsize>(want));
      chunk.resize(static_cast<size_t>(in.gcount()));
      bytes = appended_encoding == "base64" ? base64_decode(chunk, 3 * word) : chunk;
    } else if (format != "ascii") {  // "binary", and what VTK takes for it (any other word)
      size_t text = xml.find('>', tag);
      if (text == std::string::npos) return Error(where, "corrupt VTK image file (DataArray)");
      ++text;
      while (text < xml.size() && std::isspace(static_cast<unsigned char>(xml[text]))) ++text;
      bytes = base64_decode(xml.substr(text, (3 * word + 2) / 3 * 4), 3 * word);
    } else {
      return std::vector<uint64_t>{};  // ascii: nothing compressed
    }
    if (bytes.size() < 3 * word)
      return Error(where, "truncated: a compressed array header is cut off");
    std::vector<uint64_t> w(3, 0);
    for (int k = 0; k < 3; ++k) {
      uint64_t v = 0;
      std::memcpy(&v, bytes.data() + k * word, word);  // little-endian hosts, as VTK writes
      w[k] = v;
    }
    return w;
  };
  for (size_t tag = xml.find("<DataArray"); tag != std::string::npos && tag < appended_tag;
       tag = xml.find("<DataArray", tag + 10)) {
    Result<std::vector<uint64_t>> w = header_words(tag);
    if (!w) return w.error();
    if (w.value().empty()) continue;
    const uint64_t blocks = w.value()[0], block_size = w.value()[1], last = w.value()[2];
    const double limit = kMaxCompressionRatio * static_cast<double>(file_bytes);
    if (blocks > file_bytes / word || static_cast<double>(block_size) > limit ||
        static_cast<double>(last) > limit ||
        static_cast<double>(blocks) * static_cast<double>(block_size) > limit) {
      return Error(where, "corrupt: a compressed array declares " + std::to_string(blocks) +
                              " blocks of " + std::to_string(block_size) + " bytes in a file of " +
                              std::to_string(file_bytes) + " bytes");
    }
  }
  return Status::Ok();
}

}  // namespace

// Reads the whole extent and the scalar type of a .vti, bounding its declared size by its size on
// disk before VTK allocates anything.
Status open_vti(const fs::path& file, VtkVolumeSource& src, VolumeHeader& h) {
  const std::string where = file.string();
  Result<std::string> head = read_head(file, 4096);
  if (!head) return head.error();
  const std::string& start = head.value();
  if (start.find("<VTKFile") == std::string::npos)
    return Error(where, "not a VTK XML file (no <VTKFile> element)");
  if (start.find("type=\"ImageData\"") == std::string::npos)
    return Error(where, "not VTK image data (the VTKFile type is not ImageData)");
  h.compressed = start.find("compressor=") != std::string::npos;

  auto reader = vtkSmartPointer<vtkXMLImageDataReader>::New();
  src.errors_->watch(reader);
  src.errors_->watch(reader->GetExecutive());
  reader->SetReaderErrorObserver(src.errors_);
  reader->SetParserErrorObserver(src.errors_);
  reader->SetFileName(file.string().c_str());
  src.errors_->clear();
  reader->UpdateInformation();
  if (src.errors_->any())
    return Error(where, with_detail("corrupt VTK image file", src.errors_->first()));
  vtkInformation* info = reader->GetOutputInformation(0);
  if (!info || !info->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
    return Error(where, "corrupt VTK image file (no WholeExtent)");
  info->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), src.extent_);
  for (int a = 0; a < 3; ++a) {
    const long long n = static_cast<long long>(src.extent_[2 * a + 1]) - src.extent_[2 * a] + 1;
    if (n <= 0 || n > 1000000000LL) return Error(where, "corrupt VTK image file (WholeExtent)");
    h.dims[a] = static_cast<int>(n);
  }
  if (Status st = check_dims(h, where, "WholeExtent"); !st) return st;
  {
    // The XML part ends where the appended samples start; 1 MB holds thousands of pieces.
    Result<std::string> xml = read_head(file, 1 << 20);
    if (!xml) return xml.error();
    const size_t appended = xml.value().find("<AppendedData");
    const std::string head_xml = xml.value().substr(0, appended);
    if (Status st = check_vti_pieces(head_xml, src.extent_, where); !st) return st;
    if (Status st = check_vti_numbers(head_xml, where); !st) return st;
    if (h.compressed) {
      Result<uint64_t> bytes = file_size(file, where);
      if (!bytes) return bytes.error();
      if (Status st = check_vti_compression(file, xml.value(), appended, bytes.value(), where); !st)
        return st;
    }
  }
  // The smallest sample is one byte; raw, base64 and text data all take at least that on disk.
  Result<uint64_t> size = file_size(file, where);
  if (!size) return size.error();
  const double declared = static_cast<double>(h.voxels());
  const double limit =
      static_cast<double>(size.value()) * (h.compressed ? kMaxCompressionRatio : 1.0);
  if (declared > limit) {
    return Error(where, "truncated or corrupt: WholeExtent declares " + std::to_string(h.dims[0]) +
                            " x " + std::to_string(h.dims[1]) + " x " + std::to_string(h.dims[2]) +
                            " voxels in a file of " + std::to_string(size.value()) + " bytes");
  }
  double spacing[3] = {1, 1, 1}, origin[3] = {0, 0, 0};
  if (info->Has(vtkDataObject::SPACING())) info->Get(vtkDataObject::SPACING(), spacing);
  if (info->Has(vtkDataObject::ORIGIN())) info->Get(vtkDataObject::ORIGIN(), origin);
  for (int a = 0; a < 3; ++a) h.spacing[a] = spacing[a];
  if (Status st = check_spacing(h, where, "Spacing"); !st) return st;
  h.origin = {origin[0], origin[1], origin[2]};
  if (info->Has(vtkDataObject::DIRECTION())) {
    double d[9];
    info->Get(vtkDataObject::DIRECTION(), d);
    for (int a = 0; a < 3; ++a) {
      const Vec3 col{d[a], d[3 + a], d[6 + a]};  // row-major matrix; column a is axis a
      if (!std::isfinite(col.norm()) || col.norm() < 1e-6)
        return Error(where, "corrupt VTK image file (Direction)");
      h.axis[a] = normalized(col);
    }
  }
  src.reader_ = reader;
  return Status::Ok();
}

}  // namespace sawyer::ct::detail

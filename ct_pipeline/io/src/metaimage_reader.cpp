// The MetaImage (.mha/.mhd) reader: the header parsed and checked here (declared sizes against
// the data file's size, supported types only), then VTK reads the samples: per slice through
// vtkImageReader2 when uncompressed, the whole volume at once through vtkMetaImageReader when
// compressed (vtkMetaImageReader writes the whole volume into a buffer sized for the requested
// slice, a heap overflow, so it is never asked for less than everything).
#include <vtkMetaImageReader.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <system_error>

#include "text_parse.h"
#include "volume_common.h"

namespace sawyer::ct::detail {

namespace {

Result<VolumeHeader> parse_metaimage(const fs::path& file) {
  const std::string where = file.string();
  Result<std::string> head = read_head(file, 1 << 20);
  if (!head) return head.error();
  const std::string& text = head.value();
  std::map<std::string, std::string> kv;
  size_t pos = 0;
  bool have_data_file = false;
  uint64_t data_start = 0;
  while (pos < text.size()) {
    size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) eol = text.size();
    const std::string line = text.substr(pos, eol - pos);
    pos = eol + 1;
    if (trim(line).empty()) continue;
    const auto key_value = split_key_value(line, "=");
    if (!key_value)
      return Error(where, "not a MetaImage header line: \"" + trim(line).substr(0, 40) + "\"");
    const std::string key = trim(key_value->first);
    if (key.empty() || key.find('\0') != std::string::npos)
      return Error(where, "corrupt MetaImage header");
    // vtkmetaio copies key names into 255-byte fields with strcpy (a stack smash found by
    // fuzzing), so keys and lines stay well inside that.
    if (key.size() > 64 || line.size() > 255)
      return Error(where, "corrupt MetaImage header (a line longer than 255 characters)");
    kv[key] = trim(key_value->second);
    if (key == "ElementDataFile") {  // always the last key; the samples may follow
      have_data_file = true;
      data_start = std::min<uint64_t>(pos, text.size());
      break;
    }
  }
  if (!have_data_file) return Error(where, "corrupt MetaImage header: missing ElementDataFile");
  if (!kv.count("NDims")) return Error(where, "corrupt MetaImage header: missing NDims");
  if (kv["NDims"] != "3")
    return Error(where, "NDims = " + kv["NDims"] + "; Sawyer reads 3D volumes (NDims = 3)");
  if (!kv.count("DimSize")) return Error(where, "corrupt MetaImage header: missing DimSize");

  VolumeHeader h;
  std::vector<double> v;
  if (!parse_numbers(kv["DimSize"], v) || v.size() != 3)
    return Error(where, "DimSize must hold 3 sizes, got \"" + kv["DimSize"] + "\"");
  for (int i = 0; i < 3; ++i) {
    if (v[i] != std::floor(v[i]) || v[i] < 1 || v[i] > 1e9)
      return Error(where, "DimSize must hold 3 positive sizes, got \"" + kv["DimSize"] + "\"");
    h.dims[i] = static_cast<int>(v[i]);
  }
  if (Status st = check_dims(h, where, "DimSize"); !st) return st.error();

  const char* spacing_key = kv.count("ElementSpacing") ? "ElementSpacing" : "ElementSize";
  if (!kv.count(spacing_key))
    return Error(where, "missing ElementSpacing: a CT volume needs its voxel size in mm");
  if (!parse_numbers(kv[spacing_key], v) || v.size() != 3)
    return Error(where, std::string(spacing_key) + " must hold 3 numbers");
  for (int i = 0; i < 3; ++i) h.spacing[i] = v[i];
  if (Status st = check_spacing(h, where, spacing_key); !st) return st.error();

  for (const char* key : {"Offset", "Position", "Origin"}) {
    if (!kv.count(key)) continue;
    if (!parse_numbers(kv[key], v) || v.size() != 3)
      return Error(where, std::string(key) + " must hold 3 numbers");
    h.origin = {v[0], v[1], v[2]};
    break;
  }
  for (const char* key : {"TransformMatrix", "Rotation", "Orientation"}) {
    if (!kv.count(key)) continue;
    if (!parse_numbers(kv[key], v) || v.size() != 9)
      return Error(where, std::string(key) + " must hold 9 numbers");
    // MetaImage lists the direction of index axis 0, then 1, then 2.
    for (int a = 0; a < 3; ++a) {
      const Vec3 d{v[3 * a], v[3 * a + 1], v[3 * a + 2]};
      if (d.norm() < 1e-6) return Error(where, std::string(key) + " has a zero axis");
      h.axis[a] = normalized(d);
    }
    break;
  }

  const std::string type = kv.count("ElementType") ? kv["ElementType"] : "";
  if (type == "MET_UCHAR")
    h.scalar = Scalar::kU8;
  else if (type == "MET_CHAR")
    h.scalar = Scalar::kI8;
  else if (type == "MET_USHORT")
    h.scalar = Scalar::kU16;
  else if (type == "MET_SHORT")
    h.scalar = Scalar::kI16;
  else if (type == "MET_FLOAT")
    h.scalar = Scalar::kF32;
  else if (type == "MET_DOUBLE")
    h.scalar = Scalar::kF64;
  else if (type.empty())
    return Error(where, "corrupt MetaImage header: missing ElementType");
  else
    return Error(where, "ElementType " + type +
                            " is not supported (Sawyer reads MET_SHORT, "
                            "MET_USHORT, MET_UCHAR, MET_CHAR, MET_FLOAT, MET_DOUBLE)");
  if (kv.count("ElementNumberOfChannels") && kv["ElementNumberOfChannels"] != "1")
    return Error(where, "ElementNumberOfChannels = " + kv["ElementNumberOfChannels"] +
                            "; CT volumes have one channel");
  auto is_true = [&](const char* key) {
    if (!kv.count(key)) return false;
    const std::string b = lower(kv[key]);
    return b == "true" || b == "1";
  };
  if (kv.count("BinaryData") && !is_true("BinaryData"))
    return Error(where, "text (BinaryData = False) MetaImage is not supported");
  h.big_endian = is_true("BinaryDataByteOrderMSB") || is_true("ElementByteOrderMSB");
  h.compressed = is_true("CompressedData");
  for (const char* key : {"ElementToIntensityFunctionSlope", "ElementToIntensityFunctionOffset"}) {
    if (!kv.count(key)) continue;
    if (!parse_numbers(kv[key], v) || v.size() != 1)
      return Error(where, std::string(key) + " must be a number");
    (std::string(key).ends_with("Slope") ? h.slope : h.intercept) = v[0];
  }
  if (h.slope && *h.slope == 0) return Error(where, "ElementToIntensityFunctionSlope is 0");

  const std::string data = kv["ElementDataFile"];
  if (data == "LOCAL") {
    h.data_file = file;
    h.data_offset = data_start;
  } else if (data.starts_with("LIST") || data.find('%') != std::string::npos ||
             data.find(' ') != std::string::npos) {
    return Error(where, "MetaImage with one data file per slice (ElementDataFile = " + data +
                            ") is not supported; give a single data file");
  } else if (data.empty()) {
    return Error(where, "corrupt MetaImage header: empty ElementDataFile");
  } else {
    h.data_file = file.parent_path() / data;
    std::error_code ec;
    if (!fs::is_regular_file(h.data_file, ec))
      return Error(where, "its data file " + data + " is missing");
    h.data_offset = 0;
  }
  if (kv.count("HeaderSize")) {
    if (!parse_numbers(kv["HeaderSize"], v) || v.size() != 1 || v[0] != std::floor(v[0]) ||
        v[0] < -1 || v[0] > 1e15)
      return Error(where, "HeaderSize must be a whole number");
    if (v[0] == -1) {  // the samples are the last bytes of the data file
      Result<uint64_t> size = file_size(h.data_file, where);
      if (!size) return size.error();
      if (h.compressed)
        return Error(where, "HeaderSize = -1 with compressed data is not supported");
      h.data_offset = size.value() >= h.data_bytes() ? size.value() - h.data_bytes() : 0;
    } else if (data != "LOCAL") {
      h.data_offset = static_cast<uint64_t>(v[0]);
    }
  }
  if (h.compressed && kv.count("CompressedDataSize")) {
    if (!parse_numbers(kv["CompressedDataSize"], v) || v.size() != 1 || !(v[0] >= 0))
      return Error(where, "CompressedDataSize must be a number");
    Result<uint64_t> size = file_size(h.data_file, where);
    if (!size) return size.error();
    if (v[0] > static_cast<double>(size.value() - std::min(size.value(), h.data_offset)))
      return Error(where, "truncated: CompressedDataSize is " + num(v[0]) +
                              " bytes but the file "
                              "holds fewer");
  }
  if (Status st = check_data_size(h, where); !st) return st.error();
  return h;
}

}  // namespace

Status open_metaimage(const fs::path& file, VtkVolumeSource& src, VolumeHeader& h) {
  Result<VolumeHeader> parsed = parse_metaimage(file);
  if (!parsed) return parsed.error();
  h = parsed.value();
  if (h.compressed) {
    // Only vtkMetaImageReader inflates MetaImage data, and only all of it at once.
    auto reader = vtkSmartPointer<vtkMetaImageReader>::New();
    reader->SetFileName(file.string().c_str());
    src.reader_ = reader;
    src.whole_ = true;
    src.notes_.push_back("compressed MetaImage: the whole volume (" +
                         mb(static_cast<double>(h.data_bytes())) + ") is read into memory at once");
  } else {
    src.reader_ = raw_reader(h);
  }
  return Status::Ok();
}

}  // namespace sawyer::ct::detail

// The volume readers' shared parts: the format-independent header (scalar types, size, spacing
// and data-size checks), reading a file's head, VTK's error messages, the raw-sample reader.
#include "volume_common.h"

#include <vtkType.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <system_error>

#include "sawyer/ct/io/limits.h"
#include "text_parse.h"

namespace sawyer::ct::detail {

std::string mb(double bytes) {
  std::ostringstream s;
  s.precision(3);
  s << bytes / (1024.0 * 1024.0) << " MB";
  return s.str();
}

size_t scalar_bytes(Scalar s) {
  switch (s) {
    case Scalar::kU8:
    case Scalar::kI8:
      return 1;
    case Scalar::kU16:
    case Scalar::kI16:
      return 2;
    case Scalar::kF32:
      return 4;
    case Scalar::kF64:
      return 8;
  }
  return 0;
}

int vtk_type(Scalar s) {
  switch (s) {
    case Scalar::kU8:
      return VTK_UNSIGNED_CHAR;
    case Scalar::kI8:
      return VTK_SIGNED_CHAR;
    case Scalar::kU16:
      return VTK_UNSIGNED_SHORT;
    case Scalar::kI16:
      return VTK_SHORT;
    case Scalar::kF32:
      return VTK_FLOAT;
    case Scalar::kF64:
      return VTK_DOUBLE;
  }
  return VTK_VOID;
}

std::optional<Scalar> scalar_of_vtk(int t) {
  switch (t) {
    case VTK_UNSIGNED_CHAR:
      return Scalar::kU8;
    case VTK_CHAR:
    case VTK_SIGNED_CHAR:
      return Scalar::kI8;
    case VTK_UNSIGNED_SHORT:
      return Scalar::kU16;
    case VTK_SHORT:
      return Scalar::kI16;
    case VTK_FLOAT:
      return Scalar::kF32;
    case VTK_DOUBLE:
      return Scalar::kF64;
    default:
      return std::nullopt;
  }
}

const char* scalar_name(Scalar s) {
  switch (s) {
    case Scalar::kU8:
      return "8-bit unsigned";
    case Scalar::kI8:
      return "8-bit signed";
    case Scalar::kU16:
      return "16-bit unsigned";
    case Scalar::kI16:
      return "16-bit signed";
    case Scalar::kF32:
      return "32-bit float";
    case Scalar::kF64:
      return "64-bit float";
  }
  return "?";
}

Status check_dims(const VolumeHeader& h, const std::string& where, const char* key) {
  for (int d : h.dims) {
    if (d <= 0) {
      return Error(where, std::string(key) + " must hold 3 positive sizes, got " +
                              std::to_string(h.dims[0]) + " " + std::to_string(h.dims[1]) + " " +
                              std::to_string(h.dims[2]));
    }
  }
  if (static_cast<long long>(h.dims[0]) * h.dims[1] > kMaxSlicePixels || h.dims[2] > kMaxSlices)
    return Error(where, std::string("implausible volume size in ") + key);
  return Status::Ok();
}

Status check_spacing(const VolumeHeader& h, const std::string& where, const char* key) {
  for (double s : h.spacing) {
    if (!(s > 0) || !std::isfinite(s))
      return Error(where, std::string(key) + " must be positive, got " + num(h.spacing[0]) + " " +
                              num(h.spacing[1]) + " " + num(h.spacing[2]));
  }
  const std::string what = std::string(key) + " " + num(h.spacing[0]) + " " + num(h.spacing[1]) +
                           " " + num(h.spacing[2]) + ":";
  for (double s : h.spacing) {
    if (Status st = ct::check_spacing(where, what, s); !st) return st;
  }
  return Status::Ok();
}

Result<uint64_t> file_size(const fs::path& p, const std::string& where) {
  std::error_code ec;
  const uint64_t n = fs::file_size(p, ec);
  if (ec) return Error(where, "cannot read " + p.filename().string() + ": " + ec.message());
  return n;
}

Status check_data_size(const VolumeHeader& h, const std::string& where) {
  Result<uint64_t> size = file_size(h.data_file, where);
  if (!size) return size.error();
  const uint64_t have = size.value() > h.data_offset ? size.value() - h.data_offset : 0;
  const uint64_t need = h.data_bytes();
  if (!h.compressed && have < need) {
    return Error(where, "truncated: the header declares " + std::to_string(h.dims[0]) + " x " +
                            std::to_string(h.dims[1]) + " x " + std::to_string(h.dims[2]) + " " +
                            scalar_name(h.scalar) + " samples (" + std::to_string(need) +
                            " bytes) but " + h.data_file.filename().string() + " holds " +
                            std::to_string(have));
  }
  if (h.compressed &&
      static_cast<double>(need) > kMaxCompressionRatio * static_cast<double>(have)) {
    return Error(where, "corrupt: the header declares " + std::to_string(need) +
                            " bytes of samples compressed into " + std::to_string(have));
  }
  return Status::Ok();
}

Result<std::string> read_head(const fs::path& file, size_t max_bytes) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return Error(file.string(), "cannot open for reading");
  std::string s(max_bytes, '\0');
  in.read(s.data(), static_cast<std::streamsize>(max_bytes));
  s.resize(static_cast<size_t>(in.gcount()));
  return s;
}

void VtkErrors::Execute(vtkObject*, unsigned long event, void* data) {
  if (event != vtkCommand::ErrorEvent) return;
  ++count_;
  if (!first_.empty() || !data) return;
  std::string m = static_cast<const char*>(data);
  // "ERROR: In <source>, line N\nvtkXMLDataParser (0x55...): text\n" -> "text".
  if (m.starts_with("ERROR: In ") || m.starts_with("Warning: In ")) {
    const size_t nl = m.find('\n');
    m = nl == std::string::npos ? std::string() : m.substr(nl + 1);
  }
  if (const size_t at = m.find("): "); at != std::string::npos && at < 80) m = m.substr(at + 3);
  if (const size_t nl = m.find('\n'); nl != std::string::npos) m = m.substr(0, nl);
  first_ = trim(m);
  if (first_.size() > 200) first_ = first_.substr(0, 197) + "...";
}

vtkSmartPointer<vtkImageReader2> raw_reader(const VolumeHeader& h) {
  auto reader = vtkSmartPointer<vtkImageReader2>::New();
  reader->SetFileName(h.data_file.string().c_str());
  reader->SetFileDimensionality(3);
  reader->SetDataExtent(0, h.dims[0] - 1, 0, h.dims[1] - 1, 0, h.dims[2] - 1);
  reader->SetDataScalarType(vtk_type(h.scalar));
  reader->SetNumberOfScalarComponents(1);
  reader->SetHeaderSize(static_cast<unsigned long>(h.data_offset));
  if (h.big_endian)
    reader->SetDataByteOrderToBigEndian();
  else
    reader->SetDataByteOrderToLittleEndian();
  reader->FileLowerLeftOn();  // rows in file order
  reader->SetDataSpacing(h.spacing[0], h.spacing[1], h.spacing[2]);
  reader->SetDataOrigin(h.origin.x, h.origin.y, h.origin.z);
  return reader;
}

}  // namespace sawyer::ct::detail

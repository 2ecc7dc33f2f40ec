// Volume files through VTK: .vti (vtkXMLImageDataReader), .mha/.mhd (MetaImage), .nrrd/.nhdr
// (vtkNrrdReader), read one slice at a time through the pipeline's update extent, and the
// writer of volume.vti / volume.mha / volume.nrrd. docs/ct_input.md is the user's side of it.
//
// VTK's readers trust their headers, so every file is checked here first: the MetaImage and
// NRRD headers are parsed by this file (declared sizes against the file's size, supported
// types and encodings only), and a .vti's declared extent is bounded by its size on disk. What
// passes is handed to VTK. Where a reader cannot produce one slice on request it reads the whole
// volume once, and the source says so in a note:
//   - .vti: per slice (VTK's appended/compressed blocks can be read in part);
//   - .mha/.mhd uncompressed: per slice through vtkImageReader2 (vtkMetaImageReader itself
//     writes the whole volume into a buffer sized for the requested slice, a heap overflow, so
//     it is never asked for less than everything);
//   - .mha/.mhd compressed: whole volume through vtkMetaImageReader;
//   - .nrrd/.nhdr raw: per slice through vtkImageReader2 (vtkNrrdReader reads row by row and
//     rereads its header on every update, 2.5 times slower);
//   - .nrrd/.nhdr gzip: whole volume through vtkNrrdReader (it cannot seek in gzip data).
#include <vtkAlgorithm.h>
#include <vtkCommand.h>
#include <vtkDataArray.h>
#include <vtkExecutive.h>
#include <vtkFloatArray.h>
#include <vtkImageAlgorithm.h>
#include <vtkImageData.h>
#include <vtkImageReader2.h>
#include <vtkInformation.h>
#include <vtkMatrix3x3.h>
#include <vtkMetaImageReader.h>
#include <vtkNrrdReader.h>
#include <vtkPointData.h>
#include <vtkShortArray.h>
#include <vtkSmartPointer.h>
#include <vtkStreamingDemandDrivenPipeline.h>
#include <vtkType.h>
#include <vtkXMLImageDataReader.h>
#include <vtkXMLImageDataWriter.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <system_error>

#include "readers.h"
#include "sawyer/ct/limits.h"
#include "sidecar.h"

namespace sawyer::ct::detail {

namespace {

constexpr long long kMaxSlicePixels = 1LL << 26;  // 8192 x 8192: beyond that, a corrupt header
constexpr long long kMaxSlices = 1LL << 20;
// deflate cannot expand data by more than about 1032:1, so a compressed volume that claims more
// than this many bytes per byte on disk is corrupt (and would make VTK allocate for nothing).
constexpr double kMaxCompressionRatio = 1100.0;

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::string trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return std::string();
  const size_t e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

std::string num(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

std::string mb(double bytes) {
  std::ostringstream s;
  s.precision(3);
  s << bytes / (1024.0 * 1024.0) << " MB";
  return s.str();
}

// Parses whitespace-separated numbers; false on anything else.
bool parse_numbers(const std::string& text, std::vector<double>& out) {
  out.clear();
  std::istringstream in(text);
  std::string tok;
  while (in >> tok) {
    char* end = nullptr;
    const double v = std::strtod(tok.c_str(), &end);
    if (end != tok.c_str() + tok.size() || !std::isfinite(v)) return false;
    out.push_back(v);
  }
  return true;
}

Vec3 normalized(Vec3 v) { return v.normalized(); }
// ---------------------------------------------------------------------------------------------
// What a header declares, format-independent.

enum class Scalar { kU8, kI8, kU16, kI16, kF32, kF64 };

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

struct Header {
  int dims[3] = {0, 0, 0};
  double spacing[3] = {0, 0, 0};
  Vec3 origin;
  Vec3 axis[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};  // unit direction of each index axis
  Scalar scalar = Scalar::kI16;
  bool big_endian = false;
  bool compressed = false;
  fs::path data_file;        // where the samples are
  uint64_t data_offset = 0;  // byte offset of the first sample in data_file (raw data)
  std::optional<double> slope, intercept;  // MetaImage ElementToIntensityFunction*

  uint64_t voxels() const {
    return static_cast<uint64_t>(dims[0]) * static_cast<uint64_t>(dims[1]) *
           static_cast<uint64_t>(dims[2]);
  }
  uint64_t data_bytes() const { return voxels() * scalar_bytes(scalar); }
};

Status check_dims(const Header& h, const std::string& where, const char* key) {
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

Status check_spacing(const Header& h, const std::string& where, const char* key) {
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

// Raw data must be all there; compressed data must be able to hold what it claims.
Status check_data_size(const Header& h, const std::string& where) {
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

// Reads the start of a file (headers are small; a 4 MB cap keeps garbage from being slurped).
Result<std::string> read_head(const fs::path& file, size_t max_bytes) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return Error(file.string(), "cannot open for reading");
  std::string s(max_bytes, '\0');
  in.read(s.data(), static_cast<std::streamsize>(max_bytes));
  s.resize(static_cast<size_t>(in.gcount()));
  return s;
}

// ---------------------------------------------------------------------------------------------
// MetaImage header

Result<Header> parse_metaimage(const fs::path& file) {
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
    const size_t eq = line.find('=');
    if (eq == std::string::npos)
      return Error(where, "not a MetaImage header line: \"" + trim(line).substr(0, 40) + "\"");
    const std::string key = trim(line.substr(0, eq));
    if (key.empty() || key.find('\0') != std::string::npos)
      return Error(where, "corrupt MetaImage header");
    // vtkmetaio copies key names into 255-byte fields with strcpy (a stack smash found by
    // fuzzing), so keys and lines stay well inside that.
    if (key.size() > 64 || line.size() > 255)
      return Error(where, "corrupt MetaImage header (a line longer than 255 characters)");
    kv[key] = trim(line.substr(eq + 1));
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

  Header h;
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

// ---------------------------------------------------------------------------------------------
// NRRD header

Result<std::vector<double>> parse_nrrd_vector(std::string s) {
  s = trim(s);
  if (s.size() < 2 || s.front() != '(' || s.back() != ')') return Error("", "not a (x,y,z) vector");
  s = s.substr(1, s.size() - 2);
  std::replace(s.begin(), s.end(), ',', ' ');
  std::vector<double> v;
  if (!parse_numbers(s, v)) return Error("", "not a (x,y,z) vector");
  return v;
}

// NRRD's `space` names the frame of its origin and directions; Sawyer's is DICOM's LPS (+x to the
// left, +y posterior, +z superior). A space spelled out axis by axis (right|left, anterior|
// posterior, superior|inferior, or NRRD's RAS, LAS, LPS) maps by negating each axis that points
// the other way (RAS: x and y); the scanner's own frames are taken as given. The sign to apply
// to each axis, or an Error naming the space.
Result<Vec3> nrrd_space_signs(const std::string& value, const std::string& where) {
  const std::string shown = value.substr(0, 60);  // a corrupt header's line stays one short line
  std::string s = lower(value);
  if (s.find("time") != std::string::npos)
    return Error(where, "NRRD space \"" + shown + "\" has a time axis, which is not supported");
  if (s == "ras") s = "right-anterior-superior";
  if (s == "las") s = "left-anterior-superior";
  if (s == "lps") s = "left-posterior-superior";
  if (s == "scanner-xyz" || s == "3d-right-handed") return Vec3{1, 1, 1};
  std::vector<std::string> part;
  for (size_t at = 0; part.size() < 4;) {
    const size_t dash = s.find('-', at);
    part.push_back(s.substr(at, dash == std::string::npos ? std::string::npos : dash - at));
    if (dash == std::string::npos) break;
    at = dash + 1;
  }
  const auto sign = [&](size_t i, const char* lps, const char* other) {
    return part[i] == lps ? 1.0 : part[i] == other ? -1.0 : 0.0;
  };
  if (part.size() == 3) {
    const Vec3 signs{sign(0, "left", "right"), sign(1, "posterior", "anterior"),
                     sign(2, "superior", "inferior")};
    if (signs.x != 0 && signs.y != 0 && signs.z != 0) return signs;
  }
  return Error(where, "NRRD space \"" + shown +
                          "\" is not one Sawyer can map to its frame (it reads right|left-"
                          "anterior|posterior-superior|inferior, RAS, LAS, LPS, scanner-xyz, "
                          "3D-right-handed)");
}

Result<Header> parse_nrrd(const fs::path& file) {
  const std::string where = file.string();
  // vtkNrrdReader reads at most 4 MB of header; anything longer it would misread.
  Result<std::string> head = read_head(file, 0x400000 - 1);
  if (!head) return head.error();
  const std::string& text = head.value();
  if (!text.starts_with("NRRD000")) return Error(where, "not a NRRD file (no NRRD000x magic)");
  // The header ends at the first empty line; the samples follow (or live in "data file").
  size_t end = std::string::npos;
  for (size_t at = text.find('\n', 1); at != std::string::npos; at = text.find('\n', at + 1)) {
    if (at + 1 < text.size() && text[at + 1] == '\n') {
      end = at + 2;
      break;
    }
    if (at + 2 < text.size() && text[at + 1] == '\r' && text[at + 2] == '\n') {
      end = at + 3;
      break;
    }
  }
  const bool whole_file_header = end == std::string::npos;
  const std::string header = text.substr(0, whole_file_header ? text.size() : end);
  if (header.find('\0') != std::string::npos) return Error(where, "corrupt NRRD header (NUL byte)");

  Header h;
  std::istringstream lines(header);
  std::string line;
  std::getline(lines, line);  // magic
  int dimension = 0;
  bool have_sizes = false, have_spacing = false, have_type = false;
  std::string encoding = "raw", data_file;
  std::vector<double> v;
  Vec3 space_signs{1, 1, 1};  // per axis, into LPS (nrrd_space_signs); no `space`: as given
  while (std::getline(lines, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) break;
    if (line[0] == '#') continue;
    if (line.find(":=") != std::string::npos && line.find(": ") > line.find(":=")) continue;
    const size_t colon = line.find(": ");
    if (colon == std::string::npos)
      return Error(where, "corrupt NRRD header line \"" + line.substr(0, 40) + "\"");
    const std::string field = lower(line.substr(0, colon));
    const std::string value = trim(line.substr(colon + 2));
    auto need_dimension = [&]() -> Status {
      if (dimension != 3)
        return Error(where, "NRRD field \"" + field + "\" before \"dimension: 3\"");
      return Status::Ok();
    };
    if (field == "dimension") {
      if (value != "3") return Error(where, "dimension: " + value + "; Sawyer reads 3D volumes");
      dimension = 3;
    } else if (field == "sizes") {
      if (Status st = need_dimension(); !st) return st.error();
      if (!parse_numbers(value, v) || v.size() != 3)
        return Error(where, "sizes must hold 3 sizes, got \"" + value + "\"");
      for (int i = 0; i < 3; ++i) {
        if (v[i] != std::floor(v[i]) || v[i] < 1 || v[i] > 1e9)
          return Error(where, "sizes must hold 3 positive sizes, got \"" + value + "\"");
        h.dims[i] = static_cast<int>(v[i]);
      }
      have_sizes = true;
    } else if (field == "spacings") {
      if (Status st = need_dimension(); !st) return st.error();
      if (!parse_numbers(value, v) || v.size() != 3)
        return Error(where, "spacings must hold 3 numbers, got \"" + value + "\"");
      for (int i = 0; i < 3; ++i) h.spacing[i] = v[i];
      have_spacing = true;
    } else if (field == "space directions") {
      std::istringstream dirs(value);
      std::string d;
      int a = 0;
      while (dirs >> d) {
        if (a >= 3) return Error(where, "space directions must hold 3 vectors");
        Result<std::vector<double>> vec = parse_nrrd_vector(d);
        if (!vec || vec.value().size() != 3)
          return Error(where,
                       "space directions must hold 3 vectors (x,y,z), got \"" + value + "\"");
        const Vec3 dv{vec.value()[0], vec.value()[1], vec.value()[2]};
        h.spacing[a] = dv.norm();
        if (h.spacing[a] > 0) h.axis[a] = normalized(dv);
        ++a;
      }
      if (a != 3) return Error(where, "space directions must hold 3 vectors (x,y,z)");
      have_spacing = true;
    } else if (field == "space origin") {
      Result<std::vector<double>> vec = parse_nrrd_vector(value);
      if (!vec || vec.value().size() != 3)
        return Error(where, "space origin must be (x,y,z), got \"" + value + "\"");
      h.origin = {vec.value()[0], vec.value()[1], vec.value()[2]};
    } else if (field == "type") {
      const std::string t = lower(value);
      have_type = true;
      if (t == "uchar" || t == "unsigned char" || t == "uint8" || t == "uint8_t")
        h.scalar = Scalar::kU8;
      else if (t == "signed char" || t == "int8" || t == "int8_t")
        h.scalar = Scalar::kI8;
      else if (t == "short" || t == "short int" || t == "signed short" || t == "signed short int" ||
               t == "int16" || t == "int16_t")
        h.scalar = Scalar::kI16;
      else if (t == "ushort" || t == "unsigned short" || t == "unsigned short int" ||
               t == "uint16" || t == "uint16_t")
        h.scalar = Scalar::kU16;
      else if (t == "float")
        h.scalar = Scalar::kF32;
      else if (t == "double")
        h.scalar = Scalar::kF64;
      else
        return Error(where, "NRRD type \"" + value +
                                "\" is not supported (Sawyer reads short, "
                                "ushort, uchar, signed char, float, double)");
    } else if (field == "encoding") {
      encoding = lower(value);
      if (encoding == "gz") encoding = "gzip";
      if (encoding != "raw" && encoding != "gzip")
        return Error(where, "NRRD encoding \"" + value + "\" is not supported (raw or gzip)");
    } else if (field == "endian") {
      if (value != "little" && value != "big")
        return Error(where, "endian must be little or big, got \"" + value + "\"");
      h.big_endian = value == "big";
    } else if (field == "data file" || field == "datafile") {
      if (value.empty() || value.starts_with("LIST") || value.find(' ') != std::string::npos ||
          value.find('%') != std::string::npos)
        return Error(where, "NRRD data split over several files (data file: " + value +
                                ") is not supported; give one data file");
      data_file = value;
    } else if (field == "line skip" || field == "lineskip" || field == "byte skip" ||
               field == "byteskip") {
      if (value != "0")
        return Error(where, "NRRD \"" + field + ": " + value + "\" is not supported");
    } else if (field == "space") {
      Result<Vec3> signs = nrrd_space_signs(value, where);
      if (!signs) return signs.error();
      space_signs = signs.value();
      // (vtkNrrdReader would turn rows bottom-up for left-handed spaces, but only on raw data,
      // which goes through vtkImageReader2 here; rows stay in file order.)
    } else if (field == "space dimension") {
      if (value != "3")
        return Error(where, "space dimension: " + value + "; Sawyer reads 3D volumes");
    } else if (field == "kinds") {
      const std::string k = lower(value);
      for (const char* vector_kind : {"vector", "rgb", "list", "point", "covariant", "complex",
                                      "quaternion", "tensor", "matrix", "color", "hsv", "xyz"}) {
        if (k.find(vector_kind) != std::string::npos)
          return Error(where, "NRRD with a vector axis (kinds: " + value +
                                  ") is not supported; CT volumes hold one value per voxel");
      }
    }
    // Other fields (content, units, centerings, ...) change nothing Sawyer reads.
  }
  // `space` may come before or after the vectors it applies to. (+ 0.0 turns -0 into 0, which
  // notes and `sawyer info` would otherwise print as "-0".)
  for (Vec3* p : {&h.origin, &h.axis[0], &h.axis[1], &h.axis[2]})
    *p = {space_signs.x * p->x + 0.0, space_signs.y * p->y + 0.0, space_signs.z * p->z + 0.0};
  if (dimension != 3) return Error(where, "corrupt NRRD header: missing \"dimension: 3\"");
  if (!have_sizes) return Error(where, "corrupt NRRD header: missing sizes");
  if (!have_type) return Error(where, "corrupt NRRD header: missing type");
  if (!have_spacing)
    return Error(where, "no spacings or space directions: a CT volume needs its voxel size in mm");
  if (Status st = check_dims(h, where, "sizes"); !st) return st.error();
  if (Status st = check_spacing(h, where, "spacing"); !st) return st.error();
  h.compressed = encoding == "gzip";
  // vtkNrrdReader (used for gzip data) takes a first axis of 9 or fewer samples for vector
  // components.
  if (h.compressed && h.dims[0] <= 9)
    return Error(where, "gzip NRRD slices " + std::to_string(h.dims[0]) +
                            " pixels wide are not supported (at least 10)");
  // vtkNrrdReader does not swap bytes of gzip data.
  if (h.compressed && h.big_endian && scalar_bytes(h.scalar) > 1)
    return Error(where, "big-endian gzip NRRD is not supported; use raw encoding or little endian");
  if (!data_file.empty()) {
    h.data_file =
        fs::path(data_file).is_absolute() ? fs::path(data_file) : file.parent_path() / data_file;
    std::error_code ec;
    if (!fs::is_regular_file(h.data_file, ec))
      return Error(where, "its data file " + data_file + " is missing");
    h.data_offset = 0;
  } else {
    if (whole_file_header) return Error(where, "truncated: no samples after the NRRD header");
    h.data_file = file;
    h.data_offset = end;
  }
  if (Status st = check_data_size(h, where); !st) return st.error();
  return h;
}

// ---------------------------------------------------------------------------------------------
// VTK plumbing

// Collects VTK's error messages (which would otherwise go to stderr) so they can become one
// Error line; warnings are dropped.
class VtkErrors : public vtkCommand {
 public:
  static VtkErrors* New() { return new VtkErrors; }
  void Execute(vtkObject*, unsigned long event, void* data) override {
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
  void clear() {
    count_ = 0;
    first_.clear();
  }
  bool any() const { return count_ > 0; }
  const std::string& first() const { return first_; }

  void watch(vtkObject* o) {
    if (!o) return;
    o->AddObserver(vtkCommand::ErrorEvent, this);
    o->AddObserver(vtkCommand::WarningEvent, this);
  }

 private:
  int count_ = 0;
  std::string first_;
};

class VtkVolumeSource final : public SliceSource {
 public:
  Format format_ = Format::kVti;
  fs::path file_;
  VolumeGeometry geometry_;
  std::string description_;
  std::vector<std::string> notes_;
  vtkSmartPointer<vtkAlgorithm> reader_;
  vtkSmartPointer<VtkErrors> errors_;
  int extent_[6] = {0, 0, 0, 0, 0, 0};  // whole extent
  bool whole_ = false;                  // the reader cannot stream: read everything once
  bool whole_loaded_ = false;
  std::optional<Scalar> scalar_;  // known from the header, or from the first slice read
  double slope_ = 1.0, intercept_ = 0.0;

  Format format() const override { return format_; }
  const VolumeGeometry& geometry() const override { return geometry_; }
  std::string description() const override { return description_; }
  const std::vector<std::string>& notes() const override { return notes_; }

  Status read(int i, Slice& out) override {
    try {
      return read_slice(i, out);
    } catch (const std::bad_alloc&) {
      return Error(file_.string(), "slice " + std::to_string(i) + ": out of memory");
    } catch (const std::exception& e) {
      return Error(file_.string(), "slice " + std::to_string(i) + ": " + e.what());
    } catch (...) {
      return Error(file_.string(), "slice " + std::to_string(i) + ": cannot read the volume");
    }
  }

  // Runs the reader for slice `i` (or everything) and returns its output's scalars.
  Result<vtkDataArray*> update(int i, vtkImageData** image) {
    const std::string where = file_.string();
    int ext[6] = {extent_[0], extent_[1], extent_[2], extent_[3], extent_[4] + i, extent_[4] + i};
    if (whole_) {
      std::copy(extent_, extent_ + 6, ext);
      if (whole_loaded_) {
        *image = vtkImageData::SafeDownCast(reader_->GetOutputDataObject(0));
        return (*image)->GetPointData()->GetScalars();
      }
    }
    errors_->clear();
    const int ok = reader_->UpdateExtent(ext);
    vtkImageData* img = vtkImageData::SafeDownCast(reader_->GetOutputDataObject(0));
    if (!ok || errors_->any() || !img) {
      return Error(where, with_detail(whole_ ? std::string("cannot read the volume")
                                             : "cannot read slice " + std::to_string(i),
                                      errors_->first()));
    }
    int got[6];
    img->GetExtent(got);
    for (int a = 0; a < 3; ++a) {
      if (got[2 * a] > ext[2 * a] || got[2 * a + 1] < ext[2 * a + 1])
        return Error(where, "the reader returned less data than the header declares");
    }
    vtkDataArray* scalars = img->GetPointData()->GetScalars();
    if (!scalars && img->GetPointData()->GetNumberOfArrays() > 0)
      scalars = img->GetPointData()->GetArray(0);
    if (!scalars) return Error(where, "holds no point data (no CT values)");
    if (scalars->GetNumberOfComponents() != 1) {
      return Error(where, "has " + std::to_string(scalars->GetNumberOfComponents()) +
                              " values per voxel; CT volumes have one");
    }
    const vtkIdType want =
        static_cast<vtkIdType>(got[1] - got[0] + 1) * (got[3] - got[2] + 1) * (got[5] - got[4] + 1);
    if (scalars->GetNumberOfTuples() < want)
      return Error(where, "the reader returned less data than the header declares");
    if (whole_) whole_loaded_ = true;
    *image = img;
    return scalars;
  }

 private:
  template <typename T>
  Status convert(const T* base, vtkImageData* img, int k, int i, Slice& out) {
    const int w = geometry_.width, h = geometry_.height;
    int got[6];
    img->GetExtent(got);
    const vtkIdType row_stride = got[1] - got[0] + 1;
    const vtkIdType slice_stride = row_stride * (got[3] - got[2] + 1);
    const float s = static_cast<float>(slope_), b = static_cast<float>(intercept_);
    constexpr bool kFloat = std::is_floating_point_v<T>;
    for (int r = 0; r < h; ++r) {
      const T* row = base + (k - got[4]) * slice_stride + (extent_[2] + r - got[2]) * row_stride +
                     (extent_[0] - got[0]);
      float* dst = out.hu.data() + static_cast<size_t>(r) * w;
      for (int c = 0; c < w; ++c) {
        dst[c] = static_cast<float>(row[c]) * s + b;
        if constexpr (kFloat) {
          // Also catches doubles beyond float's range, which become infinite here.
          if (!std::isfinite(dst[c])) {
            return Error(file_.string(),
                         "slice " + std::to_string(i) + ": value " +
                             (std::isnan(row[c]) ? std::string("NaN") : num(row[c])) +
                             " at pixel (" + std::to_string(c) + ", " + std::to_string(r) + ")");
          }
        }
      }
    }
    return Status::Ok();
  }

  Status read_slice(int i, Slice& out) {
    if (i < 0 || i >= geometry_.slice_count())
      return Error(file_.string(), "slice " + std::to_string(i) + " out of range");
    vtkImageData* img = nullptr;
    Result<vtkDataArray*> arr = update(i, &img);
    if (!arr) return arr.error();
    std::optional<Scalar> sc = scalar_of_vtk(arr.value()->GetDataType());
    if (!sc || (scalar_ && *sc != *scalar_))
      return Error(file_.string(), "slice " + std::to_string(i) + ": unexpected data type");
    out.index = i;
    out.z = geometry_.z[i];
    out.width = geometry_.width;
    out.height = geometry_.height;
    out.hu.resize(static_cast<size_t>(out.width) * out.height);
    const int k = extent_[4] + i;
    void* p = arr.value()->GetVoidPointer(0);
    switch (*sc) {
      case Scalar::kU8:
        return convert(static_cast<const uint8_t*>(p), img, k, i, out);
      case Scalar::kI8:
        return convert(static_cast<const int8_t*>(p), img, k, i, out);
      case Scalar::kU16:
        return convert(static_cast<const uint16_t*>(p), img, k, i, out);
      case Scalar::kI16:
        return convert(static_cast<const int16_t*>(p), img, k, i, out);
      case Scalar::kF32:
        return convert(static_cast<const float*>(p), img, k, i, out);
      case Scalar::kF64:
        return convert(static_cast<const double*>(p), img, k, i, out);
    }
    return Status::Ok();
  }
};

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

// A reader of raw samples at a known offset (a header checked above): vtkImageReader2 seeks to
// the requested slice, so only that slice is read.
vtkSmartPointer<vtkImageReader2> raw_reader(const Header& h) {
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

// Reads the whole extent and the scalar type of a .vti, bounding its declared size by its size on
// disk before VTK allocates anything.
Status open_vti(const fs::path& file, VtkVolumeSource& src, Header& h) {
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

Result<std::unique_ptr<SliceSource>> open_volume(const fs::path& file, const OpenOptions& options) {
  const std::string where = file.string();
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) return Error(where, "no such file");
  const std::string e = lower(file.extension().string());

  auto src = std::make_unique<VtkVolumeSource>();
  src->file_ = file;
  src->errors_ = vtkSmartPointer<VtkErrors>::New();
  Header h;
  bool scalar_known = true;
  if (e == ".vti") {
    src->format_ = Format::kVti;
    if (Status st = open_vti(file, *src, h); !st) return st.error();
    scalar_known = false;
    if (h.compressed) {
      src->notes_.push_back(
          "compressed .vti: VTK decompresses whole blocks, so each slice costs "
          "more than with raw data");
    }
  } else if (e == ".mha" || e == ".mhd") {
    src->format_ = Format::kMetaImage;
    Result<Header> parsed = parse_metaimage(file);
    if (!parsed) return parsed.error();
    h = parsed.value();
    if (h.compressed) {
      // Only vtkMetaImageReader inflates MetaImage data, and only all of it at once.
      auto reader = vtkSmartPointer<vtkMetaImageReader>::New();
      reader->SetFileName(file.string().c_str());
      src->reader_ = reader;
      src->whole_ = true;
      src->notes_.push_back("compressed MetaImage: the whole volume (" +
                            mb(static_cast<double>(h.data_bytes())) +
                            ") is read into memory at once");
    } else {
      src->reader_ = raw_reader(h);
    }
  } else if (e == ".nrrd" || e == ".nhdr") {
    src->format_ = Format::kNrrd;
    Result<Header> parsed = parse_nrrd(file);
    if (!parsed) return parsed.error();
    h = parsed.value();
    if (!h.compressed) {
      // vtkNrrdReader reads raw data row by row, with a seek per row, and rereads its 4 MB header
      // buffer on every update: 2.5 times slower than vtkImageReader2 given the checked header.
      src->reader_ = raw_reader(h);
    } else {
      auto reader = vtkSmartPointer<vtkNrrdReader>::New();
      reader->SetFileName(file.string().c_str());
      src->reader_ = reader;
      src->whole_ = true;
      src->notes_.push_back("gzip NRRD: the whole volume (" +
                            mb(static_cast<double>(h.data_bytes())) +
                            ") is read into memory at once");
    }
  } else {
    return Error(where, "not a volume file Sawyer reads (.vti, .mha/.mhd, .nrrd/.nhdr)");
  }
  if (h.dims[2] < 2) return Error(where, "needs at least 2 slices, found 1");

  if (src->format_ != Format::kVti) {
    src->errors_->watch(src->reader_);
    src->errors_->watch(src->reader_->GetExecutive());
    src->errors_->clear();
    src->reader_->UpdateInformation();
    if (src->errors_->any())
      return Error(where, with_detail("cannot read the header", src->errors_->first()));
    vtkInformation* info = src->reader_->GetOutputInformation(0);
    if (!info || !info->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
      return Error(where, "cannot read the header");
    info->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), src->extent_);
    // VTK must see the volume the header check saw.
    for (int a = 0; a < 3; ++a) {
      if (src->extent_[2 * a + 1] - src->extent_[2 * a] + 1 != h.dims[a])
        return Error(
            where, "VTK reads the header differently (size along axis " + std::to_string(a) + ")");
    }
  }

  // Geometry.
  VolumeGeometry& g = src->geometry_;
  g.width = h.dims[0];
  g.height = h.dims[1];
  g.spacing_x = h.spacing[0];
  g.spacing_y = h.spacing[1];
  g.z.resize(h.dims[2]);
  for (int k = 0; k < h.dims[2]; ++k) g.z[k] = k * h.spacing[2];
  // Origin of voxel (extent start), not of index 0 when a .vti's extent starts elsewhere.
  g.origin = h.origin + (src->extent_[0] * h.spacing[0]) * h.axis[0] +
             (src->extent_[2] * h.spacing[1]) * h.axis[1] +
             (src->extent_[4] * h.spacing[2]) * h.axis[2];
  g.orientation = {h.axis[0].x, h.axis[0].y, h.axis[0].z, h.axis[1].x, h.axis[1].y, h.axis[1].z};
  g.slice_dir = h.axis[2];
  if (std::abs(dot(h.axis[0], h.axis[1])) > 1e-3)
    src->notes_.push_back("row and column directions are not perpendicular");
  // Before the first slice is read: sizes, field of view, extent and origin within the limits.
  if (Status st = check_geometry_limits(where, g); !st) return st.error();

  // The scalar type: from the header, or (.vti) from reading the first slice.
  Slice probe;
  if (!scalar_known) {
    vtkImageData* img = nullptr;
    Result<vtkDataArray*> arr = src->update(0, &img);
    if (!arr) return arr.error();
    const int t = arr.value()->GetDataType();
    std::optional<Scalar> sc = scalar_of_vtk(t);
    if (!sc) {
      return Error(where, std::string("data type ") + arr.value()->GetDataTypeAsString() +
                              " is not supported (Sawyer reads int16, uint16, uint8, int8, float, "
                              "double)");
    }
    h.scalar = *sc;
  }
  src->scalar_ = h.scalar;

  // HU: the file's values are HU unless a rescale is given (options, then the MetaImage keys).
  std::optional<double> slope = options.rescale_slope, intercept = options.rescale_intercept;
  if (slope && !(std::isfinite(*slope) && *slope != 0))
    return Error(where, "OpenOptions::rescale_slope must be a non-zero number, got " + num(*slope));
  if (intercept && !std::isfinite(*intercept))
    return Error(where, "OpenOptions::rescale_intercept must be a number, got " + num(*intercept));
  if (!slope && !intercept) {
    slope = h.slope;
    intercept = h.intercept;
  }
  const bool rescaled = slope || intercept;
  src->slope_ = slope.value_or(1.0);
  src->intercept_ = intercept.value_or(0.0);
  if ((h.scalar == Scalar::kU8 || h.scalar == Scalar::kI8) && !rescaled)
    return Error(where,
                 "8-bit volume carries no HU scale: give "
                 "OpenOptions::rescale_slope/OpenOptions::rescale_intercept");
  if (h.scalar == Scalar::kU16 && !rescaled) {
    src->notes_.push_back(
        "unsigned 16-bit values read as HU unchanged; if they are HU + 1024, "
        "give OpenOptions::rescale_intercept -1024");
  }
  if (options.pixel_spacing || options.slice_spacing)
    src->notes_.push_back(
        "OpenOptions::pixel_spacing/OpenOptions::slice_spacing ignored: the volume file gives the "
        "spacing");
  g.rescale_slope = src->slope_;
  g.rescale_intercept = src->intercept_;
  g.bits_stored = static_cast<int>(scalar_bytes(h.scalar) * 8);
  if (g.bits_stored == 64) g.bits_stored = 32;  // "32 (float data)": doubles are float data too
  g.pixel_signed = h.scalar != Scalar::kU8 && h.scalar != Scalar::kU16;

  src->description_ = std::string(format_name(src->format_)) + " " + file.filename().string() +
                      ", " + std::to_string(g.width) + " x " + std::to_string(g.height) + " x " +
                      std::to_string(g.slice_count()) + ", " + scalar_name(h.scalar) +
                      (h.compressed ? ", compressed" : "");
  return std::unique_ptr<SliceSource>(std::move(src));
}

// ---------------------------------------------------------------------------------------------
// Writing

class VolumeSink final : public SliceSink {
 public:
  VolumeSink(StagingDir staging, const VolumeGeometry& g, const WriteOptions& o)
      : staging_(std::move(staging)), g_(g), o_(o), float_(o.bits_stored == 32) {
    const Vec3 row{g.orientation[0], g.orientation[1], g.orientation[2]};
    const Vec3 col{g.orientation[3], g.orientation[4], g.orientation[5]};
    axis_[0] = row.normalized();
    axis_[1] = col.normalized();
    axis_[2] = cross(axis_[0], axis_[1]).normalized();
    dz_ = (g.z.back() - g.z.front()) / (g.slice_count() - 1);
  }

  Status start() {
    const std::string where = staging_.out().string();
    const size_t slice_voxels = static_cast<size_t>(g_.width) * g_.height;
    if (o_.format == Format::kVti) {
      image_ = vtkSmartPointer<vtkImageData>::New();
      image_->SetDimensions(g_.width, g_.height, g_.slice_count());
      image_->SetSpacing(g_.spacing_x, g_.spacing_y, dz_);
      image_->SetOrigin(g_.origin.x, g_.origin.y, g_.origin.z);
      image_->SetDirectionMatrix(axis_[0].x, axis_[1].x, axis_[2].x, axis_[0].y, axis_[1].y,
                                 axis_[2].y, axis_[0].z, axis_[1].z, axis_[2].z);
      image_->AllocateScalars(float_ ? VTK_FLOAT : VTK_SHORT, 1);
      if (!image_->GetScalarPointer()) return Error(where, "out of memory for the volume");
      return Status::Ok();
    }
    const fs::path file =
        staging_.path() / (o_.format == Format::kMetaImage ? "volume.mha" : "volume.nrrd");
    stream_.open(file, std::ios::binary | std::ios::trunc);
    if (!stream_) return Error(where, "cannot create " + file.filename().string());
    std::ostringstream hdr;
    hdr.precision(17);
    const Vec3 d[3] = {g_.spacing_x * axis_[0], g_.spacing_y * axis_[1], dz_ * axis_[2]};
    if (o_.format == Format::kMetaImage) {
      hdr << "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
          << "CompressedData = False\nTransformMatrix =";
      for (const Vec3& a : axis_) hdr << " " << a.x << " " << a.y << " " << a.z;
      hdr << "\nOffset = " << g_.origin.x << " " << g_.origin.y << " " << g_.origin.z
          << "\nElementSpacing = " << g_.spacing_x << " " << g_.spacing_y << " " << dz_
          << "\nDimSize = " << g_.width << " " << g_.height << " " << g_.slice_count()
          << "\nElementType = " << (float_ ? "MET_FLOAT" : "MET_SHORT")
          << "\nElementDataFile = LOCAL\n";
    } else {
      // No "space" field: vtkNrrdReader would flip rows for left-handed spaces.
      hdr << "NRRD0004\n# Written by Sawyer: CT values in HU\n"
          << "type: " << (float_ ? "float" : "short") << "\ndimension: 3\nspace dimension: 3\n"
          << "sizes: " << g_.width << " " << g_.height << " " << g_.slice_count()
          << "\nspace directions:";
      for (const Vec3& a : d) hdr << " (" << a.x << "," << a.y << "," << a.z << ")";
      hdr << "\nkinds: domain domain domain\nendian: little\nencoding: raw\n"
          << "space origin: (" << g_.origin.x << "," << g_.origin.y << "," << g_.origin.z
          << ")\n\n";
    }
    const std::string text = hdr.str();
    stream_.write(text.data(), static_cast<std::streamsize>(text.size()));
    if (float_)
      fbuf_.resize(slice_voxels);
    else
      sbuf_.resize(slice_voxels);
    if (!stream_) return Error(where, "write failed (disk full?)");
    return Status::Ok();
  }

  Status write(const Slice& slice) override {
    const std::string where = staging_.out().string();
    if (finished_) return Error(where, "write() after finish()");
    if (next_ >= g_.slice_count())
      return Error(where, "more slices than the geometry's " + std::to_string(g_.slice_count()));
    if (slice.width != g_.width || slice.height != g_.height ||
        slice.hu.size() != static_cast<size_t>(g_.width) * g_.height) {
      return Error(where, "slice " + std::to_string(next_) + " is " + std::to_string(slice.width) +
                              " x " + std::to_string(slice.height) + ", expected " +
                              std::to_string(g_.width) + " x " + std::to_string(g_.height));
    }
    const size_t n = slice.hu.size();
    float* fdst = nullptr;
    int16_t* sdst = nullptr;
    if (image_) {
      void* base = image_->GetScalarPointer(0, 0, next_);
      if (float_)
        fdst = static_cast<float*>(base);
      else
        sdst = static_cast<int16_t*>(base);
    } else {
      fdst = fbuf_.data();
      sdst = sbuf_.data();
    }
    for (size_t p = 0; p < n; ++p) {
      const float hu = slice.hu[p];
      if (!std::isfinite(hu)) {
        return Error(where, "slice " + std::to_string(next_) + ": HU value " + num(hu) +
                                " at pixel (" + std::to_string(p % g_.width) + ", " +
                                std::to_string(p / g_.width) + ")");
      }
      // Volume files hold HU directly (no rescale): signed 16-bit, or float when asked.
      if (float_)
        fdst[p] = hu;
      else
        sdst[p] = static_cast<int16_t>(stored_value(hu, 1.0, 0.0, -32768.0, 32767.0));
    }
    if (!image_) {
      // Little-endian samples, as both headers declare.
      static_assert(std::endian::native == std::endian::little, "big-endian hosts need a swap");
      const char* bytes =
          float_ ? reinterpret_cast<const char*>(fdst) : reinterpret_cast<const char*>(sdst);
      stream_.write(bytes, static_cast<std::streamsize>(n * (float_ ? 4 : 2)));
      if (!stream_) return Error(where, "write failed (disk full?)");
    }
    ++next_;
    return Status::Ok();
  }

  Status finish() override {
    const std::string where = staging_.out().string();
    if (finished_) return Error(where, "finish() called twice");
    if (next_ != g_.slice_count()) {
      return Error(where, "finish() after " + std::to_string(next_) + " of " +
                              std::to_string(g_.slice_count()) + " slices");
    }
    if (image_) {
      auto writer = vtkSmartPointer<vtkXMLImageDataWriter>::New();
      auto errors = vtkSmartPointer<VtkErrors>::New();
      errors->watch(writer);
      writer->SetInputData(image_);
      writer->SetFileName((staging_.path() / "volume.vti").string().c_str());
      // Raw appended samples, uncompressed: the reader can then fetch one slice at a time.
      writer->SetDataModeToAppended();
      writer->EncodeAppendedDataOff();
      writer->SetCompressorTypeToNone();
      writer->SetHeaderTypeToUInt64();
      if (writer->Write() != 1 || errors->any())
        return Error(where, with_detail("cannot write volume.vti", errors->first()));
      image_ = nullptr;
    } else {
      stream_.close();
      if (!stream_) return Error(where, "write failed (disk full?)");
    }
    if (o_.before_commit) {
      if (Status st = o_.before_commit(staging_.path()); !st) return st;
    }
    if (Status st = staging_.commit(); !st) return st;
    finished_ = true;
    return Status::Ok();
  }

 private:
  StagingDir staging_;
  VolumeGeometry g_;
  WriteOptions o_;
  bool float_ = false;
  Vec3 axis_[3];
  double dz_ = 1.0;
  int next_ = 0;
  bool finished_ = false;
  vtkSmartPointer<vtkImageData> image_;  // .vti: the whole volume, written by finish()
  std::ofstream stream_;                 // .mha/.nrrd: header, then slices as they come
  std::vector<float> fbuf_;
  std::vector<int16_t> sbuf_;
};

}  // namespace

Result<std::unique_ptr<SliceSource>> open_vtk_volume(const fs::path& file,
                                                     const OpenOptions& options) {
  try {
    return open_volume(file, options);
  } catch (const std::bad_alloc&) {
    return Error(file.string(), "out of memory reading the header");
  } catch (const std::exception& e) {
    return Error(file.string(), with_detail("cannot read the volume", e.what()));
  } catch (...) {
    return Error(file.string(), "cannot read the volume");
  }
}

Result<std::unique_ptr<SliceSink>> create_volume_writer(const fs::path& out,
                                                        const VolumeGeometry& geometry,
                                                        const WriteOptions& options) {
  const std::string where = out.string();
  if (options.format != Format::kVti && options.format != Format::kMetaImage &&
      options.format != Format::kNrrd)
    return Error(where, "not a volume format");
  if (options.bits_stored != 16 && options.bits_stored != 32) {
    return Error(where, "volume files store HU as 16-bit integers or 32-bit floats, not " +
                            std::to_string(options.bits_stored) + "-bit values");
  }
  if (geometry.width <= 0 || geometry.height <= 0 ||
      static_cast<long long>(geometry.width) * geometry.height > kMaxSlicePixels)
    return Error(where, "implausible slice size");
  if (!(geometry.spacing_x > 0) || !(geometry.spacing_y > 0))
    return Error(where, "pixel spacing must be positive");
  const int n = geometry.slice_count();
  if (n < 2) return Error(where, "a volume file needs at least 2 slices");
  // Volume formats have one slice spacing; uneven positions need a stack (its sidecar has z_mm).
  const double median = geometry.slice_spacing();
  if (!(median > 0)) return Error(where, "slice positions must increase");
  for (int k = 1; k < n; ++k) {
    const double gap = geometry.z[k] - geometry.z[k - 1];
    if (std::abs(gap - median) > 1e-3 * median) {
      return Error(where,
                   "volume formats need evenly spaced slices, but slices " + std::to_string(k - 1) +
                       " and " + std::to_string(k) + " are " + num(gap) + " mm apart (elsewhere " +
                       num(median) +
                       " mm); write a TIFF or PNG stack (it records z_mm) or resample first");
    }
  }
  const Vec3 row{geometry.orientation[0], geometry.orientation[1], geometry.orientation[2]};
  const Vec3 col{geometry.orientation[3], geometry.orientation[4], geometry.orientation[5]};
  if (std::abs(row.norm() - 1) > 1e-3 || std::abs(col.norm() - 1) > 1e-3 ||
      std::abs(dot(row, col)) > 1e-3)
    return Error(where, "orientation must hold two perpendicular unit vectors");
  try {
    Result<StagingDir> staging = StagingDir::create(out);
    if (!staging) return staging.error();
    auto sink = std::make_unique<VolumeSink>(std::move(staging).value(), geometry, options);
    if (Status st = sink->start(); !st) return st.error();
    return std::unique_ptr<SliceSink>(std::move(sink));
  } catch (const std::bad_alloc&) {
    return Error(where, "out of memory for the volume");
  }
}

}  // namespace sawyer::ct::detail

// The NRRD (.nrrd/.nhdr) reader: the header parsed and checked here (declared sizes against the
// data file's size, supported types, encodings and spaces only), then VTK reads the samples:
// raw data per slice through vtkImageReader2, gzip data as the whole volume at once through
// vtkNrrdReader (it cannot seek in gzip data).
#include <vtkNrrdReader.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <system_error>

#include "text_parse.h"
#include "volume_common.h"

namespace sawyer::ct::detail {

namespace {

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

Result<VolumeHeader> parse_nrrd(const fs::path& file) {
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

  VolumeHeader h;
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
    const auto field_value = split_key_value(line, ": ");
    if (!field_value)
      return Error(where, "corrupt NRRD header line \"" + line.substr(0, 40) + "\"");
    const std::string field = lower(field_value->first);
    const std::string value = trim(field_value->second);
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

}  // namespace

Status open_nrrd(const fs::path& file, VtkVolumeSource& src, VolumeHeader& h) {
  Result<VolumeHeader> parsed = parse_nrrd(file);
  if (!parsed) return parsed.error();
  h = parsed.value();
  if (!h.compressed) {
    // vtkNrrdReader reads raw data row by row, with a seek per row, and rereads its 4 MB header
    // buffer on every update: 2.5 times slower than vtkImageReader2 given the checked header.
    src.reader_ = raw_reader(h);
  } else {
    auto reader = vtkSmartPointer<vtkNrrdReader>::New();
    reader->SetFileName(file.string().c_str());
    src.reader_ = reader;
    src.whole_ = true;
    src.notes_.push_back("gzip NRRD: the whole volume (" + mb(static_cast<double>(h.data_bytes())) +
                         ") is read into memory at once");
  }
  return Status::Ok();
}

}  // namespace sawyer::ct::detail

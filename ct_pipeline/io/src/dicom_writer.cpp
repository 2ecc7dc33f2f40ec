// The DICOM writer behind create_ct_writer(Format::kDicom): one CT Image Storage file per slice,
// signed stored values with the options' rescale, full image-plane geometry, deterministic UIDs.
//
// Files go to a temporary sibling folder; finish() checks that every slice arrived, runs
// options.before_commit and renames the folder into place (replacing an existing one). A sink
// destroyed without finish() removes its temporary folder, so output is all or nothing.
#include <gdcmDataElement.h>
#include <gdcmDataSet.h>
#include <gdcmFile.h>
#include <gdcmFileMetaInformation.h>
#include <gdcmTag.h>
#include <gdcmTransferSyntax.h>
#include <gdcmVR.h>
#include <gdcmWriter.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include "readers.h"
#include "staging.h"

namespace sawyer::ct::detail {

namespace {

constexpr const char* kCtImageStorage = "1.2.840.10008.5.1.4.1.1.2";

// splitmix64: a good 64-bit mixer, enough to turn (seed, role, index) into UID digits.
uint64_t mix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// "2.25.<decimal of a 128-bit number>" (the UUID-derived UID root, PS3.5 B.2): no registered
// root needed, at most 44 characters, and the same seed always gives the same UIDs.
std::string make_uid(unsigned long long seed, uint64_t role, uint64_t index) {
  const uint64_t hi = mix64(mix64(seed) ^ mix64(role * 0x100000001b3ULL + 0x5a));
  const uint64_t lo = mix64(hi ^ mix64(index + 0x243f6a8885a308d3ULL));
  // Decimal of the 128-bit number hi:lo, by long division on 32-bit limbs (no __int128 in
  // ISO C++).
  uint32_t limbs[4] = {static_cast<uint32_t>(hi >> 32), static_cast<uint32_t>(hi),
                       static_cast<uint32_t>(lo >> 32), static_cast<uint32_t>(lo)};
  if ((hi | lo) == 0) limbs[3] = 1;  // a UID component may not be empty or have leading zeros
  std::string digits;
  while (limbs[0] | limbs[1] | limbs[2] | limbs[3]) {
    uint64_t rem = 0;
    for (uint32_t& limb : limbs) {
      const uint64_t cur = (rem << 32) | limb;
      limb = static_cast<uint32_t>(cur / 10);
      rem = cur % 10;
    }
    digits.push_back(static_cast<char>('0' + rem));
  }
  std::reverse(digits.begin(), digits.end());
  return "2.25." + digits;
}

// A Decimal String value holds at most 16 characters: use the most significant digits that fit
// (about 1e-10 mm for positions up to 10 m), so geometry reads back within well under 1e-6 mm.
std::string format_ds(double v) {
  if (v == 0.0 || !std::isfinite(v)) return "0";
  char buf[64];
  for (int precision = 15; precision >= 1; --precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    if (std::string(buf).size() <= 16) return buf;
  }
  return "0";
}

std::string format_ds_list(std::initializer_list<double> values) {
  std::string s;
  for (double v : values) {
    if (!s.empty()) s += '\\';
    s += format_ds(v);
  }
  return s;
}

// DICOM string values have even length: UIDs pad with NUL, other text with a space.
void put_string(gdcm::DataSet& ds, uint16_t group, uint16_t element, gdcm::VR vr,
                std::string value) {
  if (value.size() % 2 != 0) value.push_back(vr == gdcm::VR::UI ? '\0' : ' ');
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(vr);
  de.SetByteValue(value.data(), static_cast<uint32_t>(value.size()));
  ds.Replace(de);
}

// Unsigned short, little endian (the file is Explicit VR Little Endian).
void put_us(gdcm::DataSet& ds, uint16_t group, uint16_t element, uint16_t value) {
  const char bytes[2] = {static_cast<char>(value & 0xff), static_cast<char>(value >> 8)};
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(gdcm::VR::US);
  de.SetByteValue(bytes, 2);
  ds.Replace(de);
}

class DicomSeriesWriter final : public SliceSink {
 public:
  DicomSeriesWriter(StagingDir staging, const VolumeGeometry& g, const WriteOptions& o)
      : staging_(std::move(staging)),
        out_(staging_.out()),
        tmp_(staging_.path()),
        geometry_(g),
        options_(o) {
    const Vec3 row{g.orientation[0], g.orientation[1], g.orientation[2]};
    const Vec3 col{g.orientation[3], g.orientation[4], g.orientation[5]};
    normal_ = cross(row, col).normalized();
    const int bits = std::clamp(o.bits_stored, 8, 16);
    stored_min_ = -(1 << (bits - 1));
    stored_max_ = (1 << (bits - 1)) - 1;
    build_template(bits);
    stored_.resize(static_cast<size_t>(g.width) * g.height);
  }

  Status write(const Slice& slice) override {
    const int i = next_;
    const std::string where = out_.string() + ": slice " + std::to_string(i);
    if (committed_) return Error(where, "the series is already finished");
    if (i >= geometry_.slice_count())
      return Error(where,
                   "more slices than the geometry's " + std::to_string(geometry_.slice_count()));
    if (slice.width != geometry_.width || slice.height != geometry_.height ||
        slice.hu.size() != stored_.size())
      return Error(where, "slice is " + std::to_string(slice.width) + " x " +
                              std::to_string(slice.height) + ", the geometry says " +
                              std::to_string(geometry_.width) + " x " +
                              std::to_string(geometry_.height));
    if (Status st = quantise(slice, where); !st) return st;

    gdcm::Writer writer;
    gdcm::File& file = writer.GetFile();
    gdcm::DataSet& ds = file.GetDataSet();
    ds = template_;  // values are shared smart pointers: this copy is cheap
    const double z = geometry_.z[static_cast<size_t>(i)];
    const Vec3 pos = geometry_.origin + z * normal_;
    put_string(ds, 0x0008, 0x0018, gdcm::VR::UI, make_uid(options_.uid_seed, 4, i));
    put_string(ds, 0x0020, 0x0013, gdcm::VR::IS, std::to_string(i + 1));
    put_string(ds, 0x0020, 0x0032, gdcm::VR::DS, format_ds_list({pos.x, pos.y, pos.z}));
    // Slice Location: the position along the normal, the reader's fallback for sorting.
    put_string(ds, 0x0020, 0x1041, gdcm::VR::DS, format_ds(dot(pos, normal_)));
    gdcm::DataElement pixels(gdcm::Tag(0x7fe0, 0x0010));
    pixels.SetVR(gdcm::VR::OW);
    pixels.SetByteValue(reinterpret_cast<const char*>(stored_.data()),
                        static_cast<uint32_t>(stored_.size() * sizeof(int16_t)));
    ds.Replace(pixels);

    gdcm::FileMetaInformation& meta = file.GetHeader();
    meta.SetDataSetTransferSyntax(gdcm::TransferSyntax::ExplicitVRLittleEndian);
    char name[32];
    std::snprintf(name, sizeof name, "slice_%04d.dcm", i + 1);
    const fs::path path = tmp_ / name;
    writer.SetFileName(path.string().c_str());
    bool ok = false;
    try {
      ok = writer.Write();
    } catch (const std::exception&) {
      ok = false;
    }
    if (!ok) return Error(out_.string() + ": " + name, "cannot write the DICOM file (disk full?)");
    ++next_;
    return Status::Ok();
  }

  Status finish() override {
    if (committed_) return Error(out_.string(), "the series is already finished");
    if (next_ != geometry_.slice_count())
      return Error(out_.string(), "only " + std::to_string(next_) + " of " +
                                      std::to_string(geometry_.slice_count()) +
                                      " slices were written");
    if (options_.before_commit) {
      if (Status st = options_.before_commit(tmp_); !st) return st;
    }
    // The staging folder removes itself unless committed.
    if (Status st = staging_.commit(); !st) return st;
    committed_ = true;
    return Status::Ok();
  }

 private:
  // The elements every slice shares; write() adds the per-slice ones.
  void build_template(int bits) {
    const VolumeGeometry& g = geometry_;
    const WriteOptions& o = options_;
    gdcm::DataSet& ds = template_;
    put_string(ds, 0x0008, 0x0005, gdcm::VR::CS, "ISO_IR 100");
    put_string(ds, 0x0008, 0x0008, gdcm::VR::CS, "ORIGINAL\\PRIMARY\\AXIAL");
    put_string(ds, 0x0008, 0x0016, gdcm::VR::UI, kCtImageStorage);
    // Dates and times stay empty (type 2) so the same input gives byte-identical files.
    put_string(ds, 0x0008, 0x0020, gdcm::VR::DA, "");
    put_string(ds, 0x0008, 0x0030, gdcm::VR::TM, "");
    put_string(ds, 0x0008, 0x0050, gdcm::VR::SH, "");
    put_string(ds, 0x0008, 0x0060, gdcm::VR::CS, "CT");
    put_string(ds, 0x0008, 0x0070, gdcm::VR::LO, o.manufacturer);
    put_string(ds, 0x0008, 0x0090, gdcm::VR::PN, "");
    put_string(ds, 0x0008, 0x103e, gdcm::VR::LO, o.series_description);
    put_string(ds, 0x0010, 0x0010, gdcm::VR::PN, o.patient_name);
    put_string(ds, 0x0010, 0x0020, gdcm::VR::LO, "");
    put_string(ds, 0x0010, 0x0030, gdcm::VR::DA, "");
    put_string(ds, 0x0010, 0x0040, gdcm::VR::CS, "");
    const double dz = g.slice_spacing() > 0 ? g.slice_spacing() : 1.0;
    put_string(ds, 0x0018, 0x0050, gdcm::VR::DS, format_ds(dz));
    put_string(ds, 0x0018, 0x0060, gdcm::VR::DS, "");
    put_string(ds, 0x0018, 0x0088, gdcm::VR::DS, format_ds(dz));
    put_string(ds, 0x0020, 0x000d, gdcm::VR::UI, make_uid(o.uid_seed, 1, 0));
    put_string(ds, 0x0020, 0x000e, gdcm::VR::UI, make_uid(o.uid_seed, 2, 0));
    put_string(ds, 0x0020, 0x0010, gdcm::VR::SH, "1");
    put_string(ds, 0x0020, 0x0011, gdcm::VR::IS, "1");
    put_string(ds, 0x0020, 0x0012, gdcm::VR::IS, "1");
    put_string(ds, 0x0020, 0x0037, gdcm::VR::DS,
               format_ds_list({g.orientation[0], g.orientation[1], g.orientation[2],
                               g.orientation[3], g.orientation[4], g.orientation[5]}));
    put_string(ds, 0x0020, 0x0052, gdcm::VR::UI, make_uid(o.uid_seed, 3, 0));
    put_string(ds, 0x0020, 0x1040, gdcm::VR::LO, "");
    put_us(ds, 0x0028, 0x0002, 1);
    put_string(ds, 0x0028, 0x0004, gdcm::VR::CS, "MONOCHROME2");
    put_us(ds, 0x0028, 0x0010, static_cast<uint16_t>(g.height));
    put_us(ds, 0x0028, 0x0011, static_cast<uint16_t>(g.width));
    // DICOM order: row spacing (the distance between rows, y) first, then column spacing (x).
    put_string(ds, 0x0028, 0x0030, gdcm::VR::DS, format_ds_list({g.spacing_y, g.spacing_x}));
    put_us(ds, 0x0028, 0x0100, 16);
    put_us(ds, 0x0028, 0x0101, static_cast<uint16_t>(bits));
    put_us(ds, 0x0028, 0x0102, static_cast<uint16_t>(bits - 1));
    put_us(ds, 0x0028, 0x0103, 1);
    put_string(ds, 0x0028, 0x1052, gdcm::VR::DS, format_ds(o.rescale_intercept));
    put_string(ds, 0x0028, 0x1053, gdcm::VR::DS, format_ds(o.rescale_slope));
    put_string(ds, 0x0028, 0x1054, gdcm::VR::LO, "HU");
  }

  // HU -> stored = round((HU - intercept) / slope), clamped to the stored range. NaN is bad
  // data, not something to guess a value for.
  Status quantise(const Slice& slice, const std::string& where) {
    const double inv = 1.0 / options_.rescale_slope;
    const double b = options_.rescale_intercept;
    const double lo = stored_min_, hi = stored_max_;
    for (size_t k = 0; k < stored_.size(); ++k) {
      const double hu = slice.hu[k];
      if (std::isnan(hu)) {
        return Error(where, "HU value is NaN at column " +
                                std::to_string(k % static_cast<size_t>(geometry_.width)) +
                                ", row " +
                                std::to_string(k / static_cast<size_t>(geometry_.width)));
      }
      const double v = std::clamp(std::round((hu - b) * inv), lo, hi);
      // The pixel data is little endian on disk; store it that way on any host.
      const auto u = static_cast<uint16_t>(static_cast<int16_t>(v));
      uint8_t* p = reinterpret_cast<uint8_t*>(&stored_[k]);
      p[0] = static_cast<uint8_t>(u & 0xff);
      p[1] = static_cast<uint8_t>(u >> 8);
    }
    return Status::Ok();
  }

  StagingDir staging_;
  fs::path out_;
  fs::path tmp_;
  VolumeGeometry geometry_;
  WriteOptions options_;
  Vec3 normal_;
  int stored_min_ = -32768;
  int stored_max_ = 32767;
  gdcm::DataSet template_;
  std::vector<int16_t> stored_;
  int next_ = 0;
  bool committed_ = false;
};

}  // namespace

Result<std::unique_ptr<SliceSink>> create_dicom_writer(const fs::path& out,
                                                       const VolumeGeometry& geometry,
                                                       const WriteOptions& options) {
  const std::string where = out.string();
  if (geometry.width <= 0 || geometry.height <= 0 || geometry.width > 65535 ||
      geometry.height > 65535)
    return Error(where, "DICOM images are 1 to 65535 pixels a side, got " +
                            std::to_string(geometry.width) + " x " +
                            std::to_string(geometry.height));
  if (!(options.rescale_slope > 0) || !std::isfinite(options.rescale_slope) ||
      !std::isfinite(options.rescale_intercept))
    return Error(where, "rescale slope must be positive and finite, intercept finite");
  if (options.bits_stored < 8 || options.bits_stored > 16)
    return Error(where, "DICOM output stores 8 to 16 bits, got bits_stored = " +
                            std::to_string(options.bits_stored));
  for (size_t i = 1; i < geometry.z.size(); ++i) {
    if (!(geometry.z[i] > geometry.z[i - 1]))
      return Error(where, "slice positions must increase (slice " + std::to_string(i) + ")");
  }
  const Vec3 row{geometry.orientation[0], geometry.orientation[1], geometry.orientation[2]};
  const Vec3 col{geometry.orientation[3], geometry.orientation[4], geometry.orientation[5]};
  if (std::abs(row.norm() - 1) > 1e-3 || std::abs(col.norm() - 1) > 1e-3 ||
      std::abs(dot(row, col)) > 1e-3)
    return Error(where, "orientation must be two orthogonal unit vectors");

  Result<StagingDir> staging = StagingDir::create(out);
  if (!staging) return staging.error();
  return std::unique_ptr<SliceSink>(
      new DicomSeriesWriter(std::move(staging).value(), geometry, options));
}

}  // namespace sawyer::ct::detail

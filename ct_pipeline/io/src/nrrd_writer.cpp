// The NRRD writer's part: the header of volume.nrrd (3D, raw little-endian samples after the
// blank line that ends the header). volume_writer.cpp writes the samples.
#include <sstream>

#include "volume_common.h"

namespace sawyer::ct::detail {

std::string nrrd_header(const VolumeGeometry& g, const Vec3 (&axis)[3], double dz,
                        bool float_samples) {
  std::ostringstream hdr;
  hdr.precision(17);
  const Vec3 d[3] = {g.spacing_x * axis[0], g.spacing_y * axis[1], dz * axis[2]};
  // No "space" field: vtkNrrdReader would flip rows for left-handed spaces.
  hdr << "NRRD0004\n# Written by Sawyer: CT values in HU\n"
      << "type: " << (float_samples ? "float" : "short") << "\ndimension: 3\nspace dimension: 3\n"
      << "sizes: " << g.width << " " << g.height << " " << g.slice_count() << "\nspace directions:";
  for (const Vec3& a : d) hdr << " (" << a.x << "," << a.y << "," << a.z << ")";
  hdr << "\nkinds: domain domain domain\nendian: little\nencoding: raw\n"
      << "space origin: (" << g.origin.x << "," << g.origin.y << "," << g.origin.z << ")\n\n";
  return hdr.str();
}

}  // namespace sawyer::ct::detail

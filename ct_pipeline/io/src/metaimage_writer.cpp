// The MetaImage writer's part: the header of volume.mha (3D, binary little-endian samples right
// after the header, ElementDataFile = LOCAL). volume_writer.cpp writes the samples.
#include <sstream>

#include "volume_common.h"

namespace sawyer::ct::detail {

std::string metaimage_header(const VolumeGeometry& g, const Vec3 (&axis)[3], double dz,
                             bool float_samples) {
  std::ostringstream hdr;
  hdr.precision(17);
  hdr << "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
      << "CompressedData = False\nTransformMatrix =";
  for (const Vec3& a : axis) hdr << " " << a.x << " " << a.y << " " << a.z;
  hdr << "\nOffset = " << g.origin.x << " " << g.origin.y << " " << g.origin.z
      << "\nElementSpacing = " << g.spacing_x << " " << g.spacing_y << " " << dz
      << "\nDimSize = " << g.width << " " << g.height << " " << g.slice_count()
      << "\nElementType = " << (float_samples ? "MET_FLOAT" : "MET_SHORT")
      << "\nElementDataFile = LOCAL\n";
  return hdr.str();
}

}  // namespace sawyer::ct::detail

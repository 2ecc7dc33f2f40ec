// The .vti writer's part: the volume, held whole in a vtkImageData, written by VTK's XML writer
// as raw appended samples. volume_writer.cpp fills the image slice by slice.
#include <vtkXMLImageDataWriter.h>

#include "volume_common.h"

namespace sawyer::ct::detail {

Status write_vti(vtkImageData* image, const fs::path& file, const std::string& where) {
  auto writer = vtkSmartPointer<vtkXMLImageDataWriter>::New();
  auto errors = vtkSmartPointer<VtkErrors>::New();
  errors->watch(writer);
  writer->SetInputData(image);
  writer->SetFileName(file.string().c_str());
  // Raw appended samples, uncompressed: the reader can then fetch one slice at a time.
  writer->SetDataModeToAppended();
  writer->EncodeAppendedDataOff();
  writer->SetCompressorTypeToNone();
  writer->SetHeaderTypeToUInt64();
  if (writer->Write() != 1 || errors->any())
    return Error(where, with_detail("cannot write volume.vti", errors->first()));
  return Status::Ok();
}

}  // namespace sawyer::ct::detail

// The scanner frame for the scan pass: axial slices turned so that x and y run along the
// scanner's +x and +y; coronal and sagittal slices kept as stored (docs/ct_input.md, "The scanner
// frame").
//
// A CT file places pixel (col, row) of slice i at  origin + col·sx·row_dir + row·sy·col_dir +
// z_i·slice_dir. The scan pass measures x = col·sx and y = row·sy in its image, z along the
// slices from the first. So:
//
//   auto src = to_scanner_axes(open_ct(path).value(), path.string());
//   // axial: src->geometry() orientation (1,0,0, 0,1,0); origin = scanner position of the new
//   // pixel (0, 0) of slice 0; slice_dir (0, 0, ±1); file_axes = the file's origin and
//   // orientation when the slices were mirrored or transposed. The scan adds the origin's x, y.
//   // coronal, sagittal: the file's geometry as it is, and a note saying which.
//
// Every series whose rows, columns and slices each run along a scanner axis is a stack of the
// log's cross-sections along their normal, which the log's z follows. Axial ones whose rows run
// along −x, ±y (rows and columns swapped) or whose columns run along −y are mirrored and/or
// transposed slice by slice (a copy of each slice; nothing else changes, the slice order
// included), so that the model's x and y are the scanner's. Coronal (slices along the scanner's
// y) and sagittal (along x) ones cannot be turned so, and are read as stored: the model stays in
// the slices' axes, and log.json's scanner_frame (ScannerFrame, with slice_dir) maps it back.
// Oblique scans are refused with one line naming the input and the orientation: Sawyer does not
// resample a volume.
#pragma once

#include <memory>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/ct/io/slice_source.h"

namespace sawyer::ct {

// How far a direction cosine may be off a scanner axis and still count as along it: 1e-4 rad
// moves a point 0.05 mm at 500 mm from the origin, under a tenth of a pixel, while scanners
// write the cosines of axis-aligned scans to 6 digits or exactly.
inline constexpr double kAxialTolerance = 1e-4;

// The source as the scan pass wants it (see above), or an Error naming `where` when its slices
// are oblique. An axial source already along +x/+y is returned unchanged.
Result<std::unique_ptr<SliceSource>> to_scanner_axes(std::unique_ptr<SliceSource> source,
                                                     const std::string& where);

// A geometry's slice orientation in a phrase, as `sawyer info` prints it: "axial slices: the
// log's z along the scanner's +z", "coronal slices: the log's z along the scanner's +y",
// "sagittal slices: ...", or "oblique slices: the scan refuses them".
std::string slice_orientation_text(const VolumeGeometry& g);

}  // namespace sawyer::ct

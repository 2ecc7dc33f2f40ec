// The scanner frame for the scan pass: axial slices turned so that x and y run along the
// scanner's +x and +y (docs/ct_input.md, "The scanner frame").
//
// A CT file places pixel (col, row) of slice i at  origin + col·sx·row_dir + row·sy·col_dir +
// z_i·slice_dir. The scan pass measures x = col·sx and y = row·sy in its image and adds the
// origin, which is only the scanner's position when row_dir is +x and col_dir is +y. So:
//
//   auto src = to_scanner_axes(open_ct(path).value(), path.string());
//   // src->geometry(): orientation (1,0,0, 0,1,0); origin = scanner position of the new pixel
//   // (0, 0) of slice 0; slice_dir (0, 0, ±1); file_axes = the file's origin and orientation
//   // when the slices were mirrored or transposed.
//
// Axial scans whose rows run along −x, ±y (rows and columns swapped) or whose columns run along
// −y are mirrored and/or transposed slice by slice (a copy of each slice; nothing else changes,
// the slice order included). Oblique scans are refused with one line naming the input and the
// orientation: Sawyer does not resample a volume.
#pragma once

#include <memory>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/ct/io/slice_source.h"

namespace sawyer::ct {

// How far a direction cosine may be off a scanner axis and still count as along it: 1e-4 rad
// moves a point 0.05 mm at 500 mm from the origin, under a tenth of a pixel, while scanners
// write the cosines of axial scans to 6 digits or exactly.
inline constexpr double kAxialTolerance = 1e-4;

// The source as the scan pass wants it (see above), or an Error naming `where` when its slices
// are not axial. A source already along +x/+y is returned unchanged.
Result<std::unique_ptr<SliceSource>> to_scanner_axes(std::unique_ptr<SliceSource> source,
                                                     const std::string& where);

}  // namespace sawyer::ct

// The compressed pixel data of encapsulated DICOM (JPEG, JPEG-LS, JPEG 2000, RLE): the check of
// a codestream's own header against the DICOM header, and JPEG-LS decoding through CharLS
// (dicom_codestream.cpp). Internal.
#pragma once

#include <gdcmSequenceOfFragments.h>

#include <cstdint>
#include <string>
#include <variant>
#include <vector>

namespace sawyer::ct::detail {

// Empty string when the first fragment's header matches a width x height single-component
// image of transfer syntax `ts`; else what is wrong. `precision` gets the stream's bits per
// sample (0 when it has none to give).
std::string check_codestream(const std::string& ts, const gdcm::SequenceOfFragments& frags,
                             int width, int height, int bits_allocated, int& precision);

// True when CharLS's C API is there to call (decode_jpeg_ls); else JPEG-LS goes through GDCM's
// codec.
bool charls_available();

// Decodes one JPEG-LS frame of width x height single samples into `raw` (host order); returns
// the bits per sample, or an error text. Only when charls_available().
std::variant<int, std::string> decode_jpeg_ls(const gdcm::SequenceOfFragments& frags, int width,
                                              int height, std::vector<uint8_t>& raw);

}  // namespace sawyer::ct::detail

// ct_read_bench: read throughput and peak memory of the CT readers (issue 3's bench).
//
//   ct_read_bench read <scan>                    one row: format, slices, size, s, slices/s,
//                                                 MB/s, peak RSS
//   ct_read_bench convert <scan> <out> <format>  stream a scan into another format
//                                                 (dicom, tiff, multitiff, png, vti, mha, nrrd)
//
// bench/ct_read.sh drives both over a phantom of the sample spruce and prints the table.
// MB/s counts the 16-bit stored size (width x height x 2 bytes per slice), the unit scanners
// and the target use, whatever the file's encoding.
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>

#include "sawyer/ct/io/slice_sink.h"
#include "sawyer/ct/io/slice_source.h"

using namespace sawyer;

namespace {

double peak_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // Linux: kilobytes
}

int usage() {
  std::cerr
      << "usage: ct_read_bench read <scan>\n"
         "       ct_read_bench convert <scan> <out> <dicom|tiff|multitiff|png|vti|mha|nrrd>\n";
  return 2;
}

int read_all(const std::string& path) {
  const auto t0 = std::chrono::steady_clock::now();
  auto opened = ct::open_ct(path);
  if (!opened) {
    std::cerr << "ct_read_bench: " << opened.error().message() << "\n";
    return 1;
  }
  ct::SliceSource& src = *opened.value();
  const ct::VolumeGeometry& g = src.geometry();
  ct::Slice s;
  double checksum = 0;
  for (int i = 0; i < g.slice_count(); ++i) {
    if (Status st = src.read(i, s); !st) {
      std::cerr << "ct_read_bench: " << st.error().message() << "\n";
      return 1;
    }
    checksum += s.hu[s.hu.size() / 2];
  }
  const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double mb = static_cast<double>(g.slice_count()) * g.width * g.height * 2 / 1e6;
  std::printf("| %-22s | %6d | %4dx%-4d | %7.2f | %8.0f | %7.0f | %8.0f | %.0f |\n",
              ct::format_name(src.format()), g.slice_count(), g.width, g.height, sec,
              g.slice_count() / sec, mb / sec, peak_rss_mb(), checksum);
  return 0;
}

int convert(const std::string& in, const std::string& out, const std::string& fmt) {
  ct::WriteOptions w;
  if (fmt == "dicom")
    w.format = ct::Format::kDicom;
  else if (fmt == "tiff")
    w.format = ct::Format::kTiffStack;
  else if (fmt == "multitiff")
    w.format = ct::Format::kMultiPageTiff;
  else if (fmt == "png")
    w.format = ct::Format::kPngStack;
  else if (fmt == "vti")
    w.format = ct::Format::kVti;
  else if (fmt == "mha")
    w.format = ct::Format::kMetaImage;
  else if (fmt == "nrrd")
    w.format = ct::Format::kNrrd;
  else
    return usage();
  if (w.format == ct::Format::kDicom) w.rescale_intercept = 0.0;
  auto opened = ct::open_ct(in);
  if (!opened) {
    std::cerr << "ct_read_bench: " << opened.error().message() << "\n";
    return 1;
  }
  ct::SliceSource& src = *opened.value();
  auto sink = ct::create_ct_writer(out, src.geometry(), w);
  if (!sink) {
    std::cerr << "ct_read_bench: " << sink.error().message() << "\n";
    return 1;
  }
  ct::Slice s;
  for (int i = 0; i < src.geometry().slice_count(); ++i) {
    Status st = src.read(i, s);
    if (st) st = sink.value()->write(s);
    if (!st) {
      std::cerr << "ct_read_bench: " << st.error().message() << "\n";
      return 1;
    }
  }
  if (Status st = sink.value()->finish(); !st) {
    std::cerr << "ct_read_bench: " << st.error().message() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::strcmp(argv[1], "read") == 0) return read_all(argv[2]);
  if (argc == 5 && std::strcmp(argv[1], "convert") == 0) return convert(argv[2], argv[3], argv[4]);
  return usage();
}

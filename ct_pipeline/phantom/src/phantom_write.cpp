// write_phantom(): renders the kept slices on worker threads and streams them, in order, into a
// CT writer; the truth files go into the writer's temporary folder so they appear with the
// slices or not at all.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "phantom_internal.h"

namespace sawyer::ct {

namespace fs = std::filesystem;

Result<Format> parse_phantom_format(const std::string& name) {
  if (name == "dicom") return Format::kDicom;
  if (name == "tiff") return Format::kTiffStack;
  if (name == "png") return Format::kPngStack;
  if (name == "mha") return Format::kMetaImage;
  if (name == "vti") return Format::kVti;
  if (name == "nrrd") return Format::kNrrd;
  return Error("PhantomWriteOptions::format",
               "unknown format '" + name + "' (dicom, tiff, png, mha, vti, nrrd)");
}

std::string PhantomSummary::brief_report() const {
  std::ostringstream s;
  s.precision(3);
  s << slices << " slices";
  if (dropped > 0) s << " (" << dropped << " dropped)";
  s << " in " << seconds << " s, " << slices_per_second() << " slices/s on " << threads
    << (threads == 1 ? " thread" : " threads");
  return s.str();
}

Result<PhantomSummary> write_phantom(const Phantom& phantom, const fs::path& out,
                                     const PhantomWriteOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const VolumeGeometry& geo = phantom.geometry();
  const std::vector<int>& kept = phantom.kept();
  const int n = static_cast<int>(kept.size());

  // The writers replace an existing folder whole; only let them replace an earlier phantom, so
  // a mistyped -o cannot wipe a folder of real scans.
  std::error_code ec;
  if (fs::exists(out, ec) && !fs::exists(out / "truth" / "phantom.json", ec)) {
    if (!fs::is_directory(out, ec) || !fs::is_empty(out, ec))
      return Error(out.string(), "already exists and is not a phantom folder; remove it first");
  }

  WriteOptions wo;
  wo.format = options.format;
  wo.bits_stored = 16;
  // DICOM: signed 16-bit, stored = HU. Volume files hold HU as they are (their writers take no
  // rescale). Image stacks: unsigned 16-bit with the writer's intercept of -1024.
  const bool stack = options.format == Format::kTiffStack ||
                     options.format == Format::kMultiPageTiff ||
                     options.format == Format::kPngStack;
  if (!stack) {
    wo.rescale_slope = 1.0;
    wo.rescale_intercept = 0.0;
  }
  if (options.rescale_slope) wo.rescale_slope = *options.rescale_slope;
  if (options.rescale_intercept) wo.rescale_intercept = *options.rescale_intercept;
  // Windowed 8-bit export: the window's HU range onto the 256 levels, stored as the rescale so
  // that HU = stored × slope + intercept within half a level inside the window.
  const PhantomOptions& po = phantom.options();
  const bool windowed = po.window_width_hu > 0;
  if (windowed) {
    if (!stack)
      return Error("PhantomOptions::window_width_hu",
                   "windowed 8-bit export writes TIFF or PNG stacks, not " +
                       std::string(format_name(options.format)));
    if (options.rescale_slope || options.rescale_intercept)
      return Error("PhantomOptions::window_width_hu",
                   "sets the rescale itself; leave out PhantomWriteOptions::rescale_intercept");
    wo.bits_stored = 8;
    wo.rescale_slope = po.window_width_hu / 255.0;
    wo.rescale_intercept = po.window_centre_hu - 0.5 * po.window_width_hu;
  }
  wo.series_description = "Sawyer phantom of " + phantom.log().id;
  wo.uid_seed = phantom.options().seed;
  nlohmann::json info = {{"format", format_name(options.format)},
                         {"input", options.input_name},
                         {"rescale_slope", wo.rescale_slope},
                         {"rescale_intercept", wo.rescale_intercept},
                         {"bits_stored", wo.bits_stored}};
  if (windowed) {
    info["window_centre_hu"] = po.window_centre_hu;
    info["window_width_hu"] = po.window_width_hu;
    info["window_rule"] =
        "stored = round((HU - rescale_intercept) / rescale_slope), clipped to 0-255; "
        "HU = stored x rescale_slope + rescale_intercept";
  }
  const std::string info_text = info.dump();
  wo.before_commit = [&phantom, info_text](const fs::path& tmp) {
    return phantom.write_truth(tmp, info_text);
  };

  auto sink_r = create_ct_writer(out, geo, wo);
  if (!sink_r) return sink_r.error();
  std::unique_ptr<SliceSink> sink = std::move(sink_r).value();

  int threads = phantom.options().threads;
  if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  threads = std::clamp(threads, 1, std::max(1, n));

  // Workers take slices in order from `next`, but stay within `window` slices of the writer so
  // that memory stays bounded; the writer takes finished slices strictly in order.
  const int window = 2 * threads + 2;
  std::mutex mu;
  std::condition_variable cv;
  std::vector<std::optional<Slice>> done(n);
  int next = 0, written = 0;
  bool stop = false;

  auto worker = [&]() {
    Phantom::Renderer renderer(phantom);
    for (;;) {
      int j;
      {
        std::unique_lock<std::mutex> lock(mu);
        cv.wait(lock, [&] { return stop || next >= n || next < written + window; });
        if (stop || next >= n) return;
        j = next++;
      }
      Slice s;
      renderer.render(kept[j], s);
      s.index = j;
      s.z = geo.z[j];
      {
        std::lock_guard<std::mutex> lock(mu);
        done[j] = std::move(s);
      }
      cv.notify_all();
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(worker);
  auto shut_down = [&]() {
    {
      std::lock_guard<std::mutex> lock(mu);
      stop = true;
    }
    cv.notify_all();
    for (std::thread& t : pool) t.join();
  };

  for (int j = 0; j < n; ++j) {
    Slice s;
    {
      std::unique_lock<std::mutex> lock(mu);
      cv.wait(lock, [&] { return done[j].has_value(); });
      s = std::move(*done[j]);
      done[j].reset();
    }
    Status st = sink->write(s);
    if (!st) {
      shut_down();
      return st.error();  // the sink's destructor removes its temporary folder
    }
    {
      std::lock_guard<std::mutex> lock(mu);
      written = j + 1;
    }
    cv.notify_all();
    if (options.progress) options.progress(j + 1, n);
  }
  shut_down();
  if (Status st = sink->finish(); !st) return st.error();

  PhantomSummary sum;
  sum.slices = n;
  sum.dropped = static_cast<int>(phantom.dropped().size());
  sum.threads = threads;
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return sum;
}

}  // namespace sawyer::ct

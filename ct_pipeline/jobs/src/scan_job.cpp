// The work of `sawyer scan` (see scan_job.h).
#include "sawyer/ct/jobs/scan_job.h"

#include <algorithm>
#include <string>
#include <utility>

#include "sawyer/ct/io/scanner_frame.h"
#include "sawyer/maps/float_maps.h"
#include "sawyer/maps/published_maps.h"
#include "sawyer/model/log_json.h"

namespace sawyer::ct {

namespace fs = std::filesystem;

// The scan pass measures in the slice's own axes; turned here so that they are the scanner's
// (oblique scans are refused before anything is written).
Result<std::unique_ptr<SliceSource>> open_scan(const ScanJobOptions& c) {
  auto opened = open_ct(c.input, c.open);
  if (!opened) return opened.error();
  return to_scanner_axes(std::move(opened).value(), c.input);
}

Result<ScanJob> scan_ct(const ScanJobOptions& c, const ScanProgress& progress,
                        std::unique_ptr<SliceSource> opened) {
  ScanJob job;
  job.source = std::move(opened);
  const fs::path in = fs::path(c.input).lexically_normal();
  const std::string name = (in.has_filename() ? in : in.parent_path()).filename().string();
  ScanOptions o;
  o.threads = c.threads;
  o.stem.stem_step_mm = c.stem_step_mm;
  o.id = c.id.empty() ? name : c.id;
  o.species = c.species;
  o.source_name = name;
  o.outline_slices = c.qa_slices;  // the records' radii: only the QA images' slices keep them
  // CLI11's range lets NaN through.
  if (!(c.stem_step_mm >= 0))
    return Error("stem step", "must be 0 or more mm").with_context(c.input);
  Result<MemoryPlan> plan =
      plan_memory(job.source->geometry(), c.threads, c.memory_mb, c.report_mb, c.stem_step_mm);
  if (!plan) return plan.error().with_context(c.input);
  job.memory = plan.value();
  job.memory.apply(&o);
  auto scan = scan_log(*job.source, o, progress);
  if (!scan) return scan.error().with_context(c.input);
  job.scan = std::move(scan.value());
  return job;
}

Status write_scan_files(const ScanJob& job, const ScanJobOptions& c, const fs::path& dir) {
  if (Status w = write_log_json(job.log(), dir / "log.json"); !w) return w;
  return write_scan_extras(job, c, dir);
}

Status write_scan_extras(const ScanJob& job, const ScanJobOptions& c, const fs::path& dir) {
  if (Status w = export_published_maps(job.log(), dir / "maps"); !w) return w;
  if (Status w = export_float_maps(job.log(), dir / "maps_float"); !w) return w;
  return write_scan_qa_images(job.scan, *job.source, dir / "qa", c.qa_slices);
}

std::string qa_report(const ScanQa& qa) {
  std::string s = qa_headline(qa);
  for (const ScanQa::Stage& st : qa.stages) {
    if (st.ok) continue;
    for (const std::string& n : st.notes)
      if (std::find(qa.warnings.begin(), qa.warnings.end(), n) == qa.warnings.end())
        s += "\n  " + st.name + ": " + n;
  }
  return s;
}

}  // namespace sawyer::ct

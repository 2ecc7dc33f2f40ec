// The batch manifest: a CSV list of CT scans for `sawyer batch` (docs/batch.md), and the shards
// that split it over a Slurm job array or a Kubernetes Indexed Job.
//
//   ct,id,species,pattern,grading,prices,position   (a pattern_set column may replace pattern)
//   scans/log_0001,L0001,spruce,,,,
//   /data/ct/log_0002.mha,L0002,pine,4ex,gost,prices_2026.json,
//
// Only `ct` is required; columns may come in any order; an empty cell means "not given".
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "sawyer/core/result.h"

namespace sawyer::reg {

struct ManifestRow {
  int line = 0;                   // 1-based line in the manifest file, for messages
  size_t index = 0;               // 0-based row index (header excluded): what shards split on
  std::string ct;                 // as written
  std::filesystem::path ct_path;  // absolute: relative paths are taken from the manifest's folder
  std::string id;                 // as written, else the CT folder's name or the volume file's stem
  std::string species, pattern, grading, prices, position;  // empty: not given
  std::string pattern_set;  // empty: not given; never with `pattern`
};

struct Manifest {
  std::filesystem::path path;
  std::vector<ManifestRow> rows;
};

// The manifest columns, in the order docs/batch.md lists them.
const std::vector<std::string>& manifest_columns();

// Reads a manifest: a header row naming the columns (`ct` required, unknown names refused),
// then one row per CT scan. RFC 4180 quoting ("a,b", "say ""x"""), CRLF, a UTF-8 BOM, blank
// lines and lines starting with '#' are accepted. `pattern`, `pattern_set`, `grading` and
// `prices` values that
// name an existing file relative to the manifest's folder become absolute paths; other values
// (2ex, nordic...) are kept as written. Errors name the file and line: a missing header or ct
// column, a row with the wrong number of cells, an empty ct, an id that cannot be a folder name
// or that two rows share.
Result<Manifest> read_manifest(const std::filesystem::path& path);

// One part of a manifest: rows with index % count == index. 0-based, to match
// SLURM_ARRAY_TASK_ID and JOB_COMPLETION_INDEX.
struct Shard {
  int index = 0, count = 1;
  bool owns(size_t row_index) const {
    return static_cast<int>(row_index % static_cast<size_t>(count)) == index;
  }
};

// Parses "i/N" (0 <= i < N). Errors quote the text.
Result<Shard> parse_shard(const std::string& text);

// Writes a CSV cell: quoted when it holds a comma, quote, CR or LF.
std::string csv_cell(const std::string& s);

}  // namespace sawyer::reg

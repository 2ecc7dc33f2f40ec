// Opening a log model from whatever the user points at: a log.json, a folder holding one, a
// folder of published maps, a folder of full-precision float maps, or a stem-bank (Gran_1
// style) folder. The command line and the viewer open logs through this one door.
//
//   Result<LogModel> log = maps::open_log("sample_logs/gran1_spruce");
//   if (!log) { std::cerr << log.error().message() << "\n"; ... }  // names the path
#pragma once

#include <filesystem>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/model/log_model.h"

namespace sawyer::maps {

// What kind of log source `path` is, as a short word for messages ("log.json", "published maps",
// ...), or an error naming the path when it is none of them.
Result<std::string> detect_log_source(const std::filesystem::path& path);

Result<LogModel> open_log(const std::filesystem::path& path);

}  // namespace sawyer::maps

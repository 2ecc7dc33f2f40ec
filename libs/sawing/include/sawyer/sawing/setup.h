// What a user names on a command line or in the viewer, turned into sawing inputs: the bundled
// patterns, rule sets and prices by name (files under bundled_data_dir()), or a
// file of the user's; and a log position written "rot[,x[,y]]".
//
//   Result<Pattern> p = pattern_by_name("2ex");          // 2ex | 4ex | tt | pattern file
//   Result<PatternSet> ps = pattern_set_by_name("nordic");  // nordic | pattern set file
//   Result<GradingRules> g = grading_by_name("nordic");  // nordic | gost | grading file
//   Result<PriceTable> v = prices_by_name("");           // "" = the example prices | file
//   Result<LogPosition> at = parse_position("20,4,-2");  // degrees, mm, mm
#pragma once

#include <filesystem>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/sawing/grading.h"
#include "sawyer/sawing/pattern.h"
#include "sawyer/sawing/pattern_set.h"
#include "sawyer/sawing/sawing.h"
#include "sawyer/sawing/value.h"

namespace sawyer::sawing {

// The folder of the bundled rule sets and prices: $SAWYER_DATA_DIR when set, else
// <prefix>/share/sawyer/data beside an installed <prefix>/bin/sawyer, else data/ of the source
// tree the program was built from.
std::filesystem::path bundled_data_dir();

// "2ex" (50×150 centre boards with 25×100 sides), "4ex" (38×100), "tt" (7 boards of 25 mm),
// else a pattern file (docs/sawing.md).
Result<Pattern> pattern_by_name(const std::string& name_or_file);
// "nordic" (the bundled example set, data/patterns/nordic.json: 2ex, 4ex and through-and-through
// by top-diameter class; docs/sawing.md), else a pattern set file.
Result<PatternSet> pattern_set_by_name(const std::string& name_or_file);
// "nordic", "gost", else a grading file.
Result<GradingRules> grading_by_name(const std::string& name_or_file);
// "" for the bundled example prices, else a price file.
Result<PriceTable> prices_by_name(const std::string& file);
// Pattern, pattern set, grading and price files must be regular files of at most 1 MiB (checked
// before they are read: a FIFO would hang the reader and /dev/zero never ends).
//
// "rot[,x[,y]]": rotation in degrees (0 = horns down) within ±360, offsets in mm within
// ±kMaxOffsetMm (optimise.h); finite numbers only. The error names --position.
Result<LogPosition> parse_position(const std::string& text);

}  // namespace sawyer::sawing

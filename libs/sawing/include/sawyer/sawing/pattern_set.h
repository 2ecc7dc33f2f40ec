// Pattern sets: the patterns a mill saws, by the log's diameter class (docs/sawing.md, "Pattern
// sets"). A sawmill sorts its logs by top diameter and saws each class with its own pattern;
// with a CT scan the pattern can be chosen per log as well as the position: every candidate
// pattern of the log's class (and of the neighbouring classes) is optimised and the one worth
// the most wins (choose_pattern in sawing_job.h).
//
//   Result<PatternSet> set = pattern_set_by_name("nordic");  // setup.h; or a file:
//   Result<PatternSet> mine = read_pattern_set_file("mill.json");
//   for (const PatternCandidate& c : set.value().candidates(saw_log.usable_diameter_mm())) ...
//
// Classes are ranges of the log's usable diameter (SawLog::usable_diameter_mm: the largest circle
// about the mean pith line inside the top end, under bark), the figure a pattern must fit
// (check_pattern_fits). Thread safety: plain values; the free functions are reentrant.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/sawing/pattern.h"

namespace sawyer::sawing {

// What a pattern set may hold, checked by PatternSet::validate() (so by every reader) and by the
// reader before it reads a class or a pattern. A mill's sorting table has a few dozen classes at
// most (1 cm classes from 10 to 60 cm top diameter are 50) and a few patterns per class; each
// candidate costs one run of the position optimiser per log, so the candidates of one log (at
// most (2 × kMaxNeighbourClasses + 1) × kMaxClassPatterns = 100) bound a log's sawing time.
inline constexpr int kMaxPatternSetClasses = 100;
inline constexpr int kMaxClassPatterns = 20;
inline constexpr int kMaxNeighbourClasses = 2;

// One diameter class: logs whose usable diameter lies in [min_diameter_mm, max_diameter_mm), mm,
// and the patterns to choose from for them.
struct DiameterClass {
  std::string name;  // e.g. "195-225 mm"; empty: label() makes one from the range
  double min_diameter_mm = 0;
  double max_diameter_mm = 0;
  std::vector<Pattern> patterns;
  std::string label() const;  // the name, else "195-225 mm"
};

// One candidate pattern for a log (PatternSet::candidates): a pattern of the set and its class.
struct PatternCandidate {
  const Pattern* pattern = nullptr;  // points into the set
  int class_index = -1;
  bool own_class = false;  // the log's own class, not a neighbour's
};

struct PatternSet {
  std::string name;
  std::string description;  // free text for people (where the patterns come from)
  // Classes either side of the log's own whose patterns are candidates too (0: the own class's
  // only). A log near a class limit may give more with the next class's pattern.
  int neighbour_classes = 1;
  // Ascending and contiguous: each class starts where the one before ends.
  std::vector<DiameterClass> classes;

  // The limits above, the classes ascending and contiguous with 0 ≤ min < max ≤
  // kMaxBoardSizeMm, every class with at least one pattern, every pattern valid
  // (Pattern::validate), and patterns of the same name the same pattern (a candidate is known
  // by its name in the files). Errors name the set, the class and the pattern: "pattern set 'x',
  // class 2 '170-195 mm', pattern 1: ...".
  Status validate() const;
  // The class of a log of this usable diameter (mm): the one holding it; the last class for a log
  // at or above the last class's end; -1 for a log below the first class's start (a log the set
  // does not saw: in a mill, pulpwood).
  int class_of(double usable_diameter_mm) const;
  // The candidate patterns for such a log: those of its class and of `neighbour_classes`
  // classes either side, in class order, each name once (the first class that lists it). Whether
  // each fits the log is check_pattern_fits's to say. Empty when class_of() is -1.
  std::vector<PatternCandidate> candidates(double usable_diameter_mm) const;
  // Every distinct pattern of the set (by name), in class order.
  std::vector<const Pattern*> patterns() const;
};

// The pattern set file (JSON, format tag "sawyer-pattern-set/1", docs/sawing.md). Each pattern of
// a class is either written out (the keys of a sawyer-pattern/1 file, without "format") or a
// bundled pattern with its parameters: {"preset": "2ex" | "4ex" | "tt", ...} (the CantOptions or
// ThroughAndThroughOptions keys). Unknown keys are refused. Errors name the file, the set, the
// class and the pattern, then the key or the problem. The writer writes every pattern out, so a
// set read back saws the same boards.
Result<PatternSet> pattern_set_from_json(const std::string& text);
std::string pattern_set_to_json(const PatternSet& set);
Result<PatternSet> read_pattern_set_file(const std::filesystem::path& path);
Status write_pattern_set_file(const std::filesystem::path& path, const PatternSet& set);

}  // namespace sawyer::sawing

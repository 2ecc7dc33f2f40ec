// `sawyer saw <log.json> -o sawing.json`: grades and values the boards of a sawing pattern over a
// rotation × offset grid of log positions, picks the best position under the positioning error
// and reports its gain over horns-down and horns-up (libs/sawing, docs/sawing.md).
//
//   std::function<int()> run_saw;
//   add_saw_command(app, run_saw);   // before app.parse()
//   ...
//   if (run_saw) return run_saw();   // after it: set only when the subcommand was given
#pragma once

#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "sawyer/sawing/sawing_job.h"

namespace sawyer::app {

// Adds the `saw` subcommand to `app`. When the command line selects it, parsing sets `run` to a
// function that does the work and returns the exit code (0, or 1 with one line on stderr).
void add_saw_command(CLI::App& app, std::function<int()>& run);

// The one-screen summary of a sawing job (`sawyer saw`, `sawyer run`): positions and speed,
// best / horns-down / horns-up values, the gain, and the boards' table.
void print_sawing_summary(const LogModel& log, const sawing::SawSetup& setup,
                          const sawing::SawingOutcome& outcome, std::FILE* f);
// One line per board: size, length, volume, grade, value and the rule that limited the grade.
void print_boards(const sawing::SawResult& sawn, const sawing::LogValue& value,
                  const sawing::GradingRules& rules, const std::string& currency, std::FILE* f);

}  // namespace sawyer::app

// The command line's own checks on option values and its words for CLI11's parse errors: every
// problem with the command line is one line on stderr, "sawyer: <option>: <what is wrong>",
// naming the option and what it accepts (docs/reliability.md, rule 2), like every other refusal.
//
//   cmd->add_option("--threads", n, "...")->check(whole_number_in(0, 256, "0: all cores"));
//   try { app.parse(argc, argv); }
//   catch (const CLI::ParseError& e) { ... std::cerr << parse_error_line(app, e, args) ...; }
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace sawyer::app {

// A finite number within [lo, hi] (CLI::Range lets NaN through: every comparison with it is
// false), with |v| >= min_magnitude when that is set (a slope of 1e-300 is zero in effect).
// `unit` follows the numbers ("0.01-50 mm"); `note` is added in brackets.
CLI::Validator number_in(double lo, double hi, const std::string& unit, double min_magnitude = 0,
                         const std::string& note = "");
// A whole number within [lo, hi] ("1.5" and "x" are refused as not whole numbers).
CLI::Validator whole_number_in(long long lo, long long hi, const std::string& note = "");
// One of `values`, spelt exactly.
CLI::Validator one_of(const std::vector<std::string>& values);

// --threads: worker threads, 0-256; 0 (the default) means every core, as the libraries take it.
void add_threads_option(CLI::App* cmd, int& threads);

// The one line (without "sawyer: " and the newline) that says what is wrong with the command
// line, for a ParseError that is not a call for help or the version: the option or argument,
// what was wrong with it and what it accepts (its help text). `args` are the arguments as given
// (argv[1..]), to name an unknown command.
std::string parse_error_line(const CLI::App& app, const CLI::ParseError& e,
                             const std::vector<std::string>& args);

}  // namespace sawyer::app

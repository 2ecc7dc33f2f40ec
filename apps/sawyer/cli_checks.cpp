#include "cli_checks.h"

#include <cmath>
#include <exception>
#include <sstream>

namespace sawyer::app {
namespace {

std::string number_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// "0.01-50 mm", or "-1e+04 to 1e+04" when a bound is negative (a dash would read as a sign).
std::string range_text(const std::string& lo, const std::string& hi, bool negative,
                       const std::string& unit) {
  return lo + (negative ? " to " : "-") + hi + unit;
}

std::string in_brackets(const std::string& note) { return note.empty() ? "" : " (" + note + ")"; }

// The deepest subcommand the parser entered (nullptr: none).
const CLI::App* active_command(const CLI::App& app) {
  const CLI::App* at = nullptr;
  for (const CLI::App* sub : app.get_subcommands()) {
    const CLI::App* deeper = active_command(*sub);
    at = deeper ? deeper : sub;
  }
  return at;
}

std::string command_list(const CLI::App& app) {
  std::string s;
  for (const CLI::App* sub : app.get_subcommands({}))
    s += (s.empty() ? "" : ", ") + sub->get_name();
  return s;
}

// "-o/--output", "--rot-step", "input".
std::string names_of(const CLI::Option* o) {
  std::string s = o->get_name(false, true);
  for (char& c : s)
    if (c == ',') c = '/';
  return s;
}

std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

// What a value of `o` must be, from its type: "a number", "a whole number".
std::string kind_of(const CLI::Option* o) {
  const std::string t = o->get_type_name();
  if (t.rfind("FLOAT", 0) == 0) return "a number";
  if (t.rfind("INT", 0) == 0 || t.rfind("UINT", 0) == 0) return "a whole number";
  return "a valid value";
}

const CLI::Option* find_option(const CLI::App* at, const CLI::App& app, const std::string& name) {
  for (const CLI::App* a : {at, &app}) {
    if (!a) continue;
    if (const CLI::Option* o = a->get_option_no_throw(name)) return o;
  }
  return nullptr;
}

}  // namespace

CLI::Validator number_in(double lo, double hi, const std::string& unit, double min_magnitude,
                         const std::string& note) {
  std::string range = range_text(number_text(lo), number_text(hi), lo < 0, unit);
  if (min_magnitude > 0) range += ", at least " + number_text(min_magnitude) + " away from 0";
  return CLI::Validator(
      [=](std::string& in) -> std::string {
        double v = 0;
        try {
          size_t used = 0;
          v = std::stod(in, &used);
          if (used != in.size()) throw std::invalid_argument(in);
        } catch (const std::exception&) {
          return "'" + in + "' is not a number; give " + range + in_brackets(note);
        }
        if (!std::isfinite(v) || v < lo || v > hi || std::abs(v) < min_magnitude)
          return in + " is outside " + range + in_brackets(note);
        return std::string();
      },
      "NUMBER in " + range);
}

CLI::Validator whole_number_in(long long lo, long long hi, const std::string& note) {
  const std::string range = range_text(std::to_string(lo), std::to_string(hi), lo < 0, "");
  return CLI::Validator(
      [=](std::string& in) -> std::string {
        long long v = 0;
        try {
          size_t used = 0;
          v = std::stoll(in, &used);
          if (used != in.size()) throw std::invalid_argument(in);
        } catch (const std::exception&) {
          return "'" + in + "' is not a whole number; give " + range + in_brackets(note);
        }
        if (v < lo || v > hi) return in + " is outside " + range + in_brackets(note);
        return std::string();
      },
      "INT in " + range);
}

CLI::Validator one_of(const std::vector<std::string>& values) {
  std::string list;
  for (const std::string& v : values) list += (list.empty() ? "" : ", ") + v;
  return CLI::Validator(
      [=](std::string& in) -> std::string {
        for (const std::string& v : values)
          if (in == v) return std::string();
        return "'" + in + "' is not one of " + list;
      },
      list);
}

void add_threads_option(CLI::App* cmd, int& threads) {
  cmd->add_option("--threads", threads, "worker threads, 1-256; 0 (the default): all cores")
      ->check(whole_number_in(0, 256, "0: all cores"));
}

std::string parse_error_line(const CLI::App& app, const CLI::ParseError& e,
                             const std::vector<std::string>& args) {
  const std::string what = one_line(e.what());
  const CLI::App* at = active_command(app);
  const std::string cmd = at ? "sawyer " + at->get_name() : "sawyer";
  const std::string help = " (" + cmd + " --help)";

  if (dynamic_cast<const CLI::RequiredError*>(&e)) {
    if (!at) {
      // No command: either none was given or the first word is not one.
      for (const std::string& a : args) {
        if (a.empty() || a[0] == '-') continue;
        return a + ": unknown command; the commands are " + command_list(app) + help;
      }
      return "no command given; the commands are " + command_list(app) + help;
    }
    // "<name> is required"
    const std::string name = what.substr(0, what.find(" is required"));
    if (const CLI::Option* o = find_option(at, app, name))
      return at->get_name() + ": " + names_of(o) + " is missing: " + o->get_description();
    return at->get_name() + ": " + what + help;
  }
  if (dynamic_cast<const CLI::ConversionError*>(&e)) {
    // "Could not convert: <name> = <value>"
    const std::string head = "Could not convert: ";
    if (what.rfind(head, 0) == 0) {
      const std::string rest = what.substr(head.size());
      const size_t eq = rest.find(" = ");
      const std::string name = rest.substr(0, eq);
      const std::string value = eq == std::string::npos ? "" : rest.substr(eq + 3);
      if (const CLI::Option* o = find_option(at, app, name))
        return names_of(o) + ": '" + value + "' is not " + kind_of(o) + "; give " + kind_of(o) +
               ": " + o->get_description();
    }
    return what + help;
  }
  if (dynamic_cast<const CLI::ArgumentMismatch*>(&e)) {
    // "<name>: 1 required TEXT missing" and the like: the option came without its value.
    const std::string name = what.substr(0, what.find(':'));
    if (const CLI::Option* o = find_option(at, app, name))
      return names_of(o) + ": needs a value: " + o->get_description();
    return what + help;
  }
  if (dynamic_cast<const CLI::ExtrasError*>(&e)) {
    // "The following argument(s) was/were not expected: a b"
    const size_t colon = what.find(": ");
    std::string first = colon == std::string::npos ? what : what.substr(colon + 2);
    first = first.substr(0, first.find(' '));
    const std::string where = at ? at->get_name() + ": " : "";
    if (!first.empty() && first[0] == '-') return where + first + ": unknown option" + help;
    if (!at) return first + ": unknown command; the commands are " + command_list(app) + help;
    std::string takes;
    for (const CLI::Option* o : at->get_options())
      if (o->get_positional()) takes += (takes.empty() ? "" : ", ") + o->get_name();
    return where + "'" + first + "': unexpected argument (" + at->get_name() + " takes " +
           (takes.empty() ? std::string("options only") : takes) + "; " + cmd + " --help)";
  }
  if (dynamic_cast<const CLI::ExcludesError*>(&e)) {
    // "<a> excludes <b>"
    const size_t x = what.find(" excludes ");
    if (x != std::string::npos)
      return what.substr(0, x) + ": cannot be given with " + what.substr(x + 10) +
             "; give one of them";
    return what;
  }
  if (dynamic_cast<const CLI::RequiresError*>(&e)) {
    const size_t x = what.find(" requires ");
    if (x != std::string::npos)
      return what.substr(0, x) + ": needs " + what.substr(x + 10) + " too";
    return what;
  }
  // ValidationError: "<name>: <our validator's words>"; and anything else CLI11 says.
  return what;
}

}  // namespace sawyer::app

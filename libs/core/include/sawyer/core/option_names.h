// Libraries name their own options in errors and notes (the field or type that holds the value:
// "rot_step_deg", "ImageSize", "SawNames::position"); a front end that calls them something else
// (the command line's flags) puts its names in before printing:
//
//   static constexpr OptionName kFlags[] = {{"rot_step_deg", "--rot-step"}};
//   std::cerr << "sawyer: " << with_option_names(err, kFlags).message() << "\n";
#pragma once

#include <span>
#include <string>
#include <string_view>

#include "sawyer/core/result.h"

namespace sawyer {

struct OptionName {
  std::string_view option;  // as the library writes it
  std::string_view name;    // as the front end's user knows it
};
// An option ending in "::" is a prefix rule: "PhantomOptions::" → "--" turns every
// "PhantomOptions::ring_width_mm" into "--ring-width-mm" ('_' to '-'). Rules apply in order, so
// the exceptions to a prefix rule come before it.

// Every occurrence of an option that stands as a whole word (not inside a longer identifier of
// letters, digits, '_' and "::") replaced by its name.
std::string with_option_names(std::string text, std::span<const OptionName> names);
Error with_option_names(const Error& error, std::span<const OptionName> names);

}  // namespace sawyer

// How the command line reports a problem: one line on stderr, "sawyer: <where>: <what>", with
// the libraries' option names (docs/style.md 6) replaced by the flags that set them.
#pragma once

#include <string>

#include "sawyer/core/result.h"

namespace sawyer::app {

// Prints the error and returns the exit code 1.
int fail(const Error& e);
// A library's text (an error, a note) in the command line's words.
std::string with_flags(const std::string& text);

}  // namespace sawyer::app

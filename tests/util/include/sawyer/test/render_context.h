// The headless OpenGL context the renderer tests draw in: made once per test process and kept
// current. Header-only: only tests that link sawyer::render include it.
#pragma once

#include <gtest/gtest.h>

#include <memory>
#include <stdexcept>

#include "sawyer/render/gl_context.h"

namespace sawyer::test {

// Makes (the first time) the process's headless context; a test that cannot have one fails
// with the context's error, then throws so it stops there.
inline void ensure_headless_context() {
  static std::unique_ptr<render::GlContext> ctx = [] {
    auto c = render::create_headless_context();
    if (!c) ADD_FAILURE() << c.error().message();
    return c ? std::move(c).value() : nullptr;
  }();
  if (!ctx) throw std::runtime_error("no headless OpenGL context");
}

}  // namespace sawyer::test

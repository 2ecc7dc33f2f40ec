// The renderer's shaders compile and link in a headless OpenGL context (EGL; Mesa's llvmpipe
// on a machine with no GPU and no display), and shader errors name the file and line.
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <string>

#include "sawyer/render/gl_context.h"
#include "sawyer/render/shader_program.h"

namespace sawyer::render {
namespace {

GlContext& context() {
  static std::unique_ptr<GlContext> ctx = [] {
    auto c = create_headless_context();
    if (!c) ADD_FAILURE() << c.error().message();
    return c ? std::move(c).value() : nullptr;
  }();
  if (!ctx) throw std::runtime_error("no headless OpenGL context");
  ctx->make_current();  // another test may have made its own context current
  return *ctx;
}

TEST(RenderShaders, HeadlessContextIsOpenGL43OrNewer) {
  GlContext& ctx = context();
  const std::string d =
      ctx.description();  // "OpenGL 4.5 (Core Profile) Mesa ..." or "OpenGL 4.6.0 NVIDIA ..."
  const size_t at = d.find("OpenGL ");
  ASSERT_NE(at, std::string::npos) << d;
  int major = 0, minor = 0;
  ASSERT_EQ(std::sscanf(d.c_str() + at, "OpenGL %d.%d", &major, &minor), 2) << d;
  EXPECT_TRUE(major > 4 || (major == 4 && minor >= 3)) << d;
}

TEST(RenderShaders, ContextsOnOneDisplayOutliveEachOther) {
  auto a = create_headless_context();
  auto b = create_headless_context();
  ASSERT_TRUE(a.ok() && b.ok());
  a.value().reset();  // must not take b's display down with it
  ASSERT_TRUE(b.value()->make_current());
  Result<ShaderProgram> p = ShaderProgram::build("wood.vert", "wood.frag", {"WOOD_INDEX 1"});
  EXPECT_TRUE(p.ok()) << p.error().message();
}

// A context made ahead on another thread (what `sawyer run` does for its report while it
// writes the files) is current on the thread that takes it and builds programs there; one that
// nobody takes is dropped cleanly.
TEST(RenderShaders, APrewarmedContextIsTakenCurrentOnTheTakersThread) {
  prewarm_headless_context();
  prewarm_headless_context();  // a second call while one waits does nothing
  auto taken = create_headless_context();
  ASSERT_TRUE(taken.ok()) << taken.error().message();
  EXPECT_NE(describe_current_context().find("OpenGL "), std::string::npos);
  Result<ShaderProgram> p = ShaderProgram::build("wood.vert", "wood.frag", {"WOOD_INDEX 1"});
  EXPECT_TRUE(p.ok()) << p.error().message();
  prewarm_headless_context();
  drop_prewarmed_headless_context();
  drop_prewarmed_headless_context();           // nothing left: nothing happens
  ASSERT_TRUE(taken.value()->make_current());  // the dropped one took nothing with it
  Result<ShaderProgram> q = ShaderProgram::build("wood.vert", "wood.frag", {});
  EXPECT_TRUE(q.ok()) << q.error().message();
}

TEST(RenderShaders, EmbeddedFilesArePresent) {
  const std::vector<std::string> names = embedded_shader_names();
  for (const char* f : {"wood_field.glsl", "wood_log_data.glsl", "wood.vert", "wood.frag"})
    EXPECT_FALSE(embedded_shader(f).empty()) << f;
  EXPECT_GE(names.size(), 4u);
}

TEST(RenderShaders, WoodProgramsCompileAndLink) {
  context();
  for (const std::vector<std::string>& defines :
       {std::vector<std::string>{"WOOD_INDEX 1"}, std::vector<std::string>{}}) {
    Result<ShaderProgram> p = ShaderProgram::build("wood.vert", "wood.frag", defines);
    ASSERT_TRUE(p.ok()) << p.error().message();
    EXPECT_NE(p.value().id(), 0u);
    EXPECT_GE(p.value().uniform("u_view_proj"), 0);
    EXPECT_GE(p.value().uniform("u_r_ref"), 0);
  }
}

TEST(RenderShaders, IncludesKeepFileAndLineForErrors) {
  Result<AssembledShader> a = assemble_shader("wood.frag");
  ASSERT_TRUE(a.ok()) << a.error().message();
  ASSERT_EQ(a.value().files.size(), 3u);  // wood.frag, wood_log_data.glsl, wood_field.glsl
  EXPECT_EQ(a.value().files[0], "wood.frag");
  EXPECT_EQ(a.value().files[2], "wood_field.glsl");
  EXPECT_EQ(a.value().text.rfind("#version 450 core\n", 0), 0u);
  EXPECT_EQ(map_shader_log("2:17(3): error: `foo' undeclared", a.value().files),
            "wood_field.glsl:17(3): error: `foo' undeclared");
  EXPECT_EQ(map_shader_log("1(40) : error C1008: undefined variable", a.value().files),
            "wood_log_data.glsl:40: error C1008: undefined variable");
}

TEST(RenderShaders, CompileErrorNamesFileAndLine) {
  context();
  const std::string vs = "#version 450 core\nvoid main() { gl_Position = vec4(0.0); }\n";
  const std::string fs =
      "#version 450 core\nout vec4 c;\nvoid main() {\n  c = vec4(undeclared_thing);\n}\n";
  Result<ShaderProgram> p = ShaderProgram::build_from_text("test.vert", vs, "broken.frag", fs);
  ASSERT_FALSE(p.ok());
  const std::string m = p.error().message();
  EXPECT_NE(m.find("broken.frag:4"), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
}

TEST(RenderShaders, MissingIncludeIsReported) {
  Result<AssembledShader> a = assemble_shader("no_such_file.frag");
  ASSERT_FALSE(a.ok());
  EXPECT_NE(a.error().message().find("no_such_file.frag"), std::string::npos);
}

}  // namespace
}  // namespace sawyer::render

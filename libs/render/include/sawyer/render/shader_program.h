// Shader programs built from the files in shaders/ (embedded into the binary at build time). A
// file may pull in another with `#include "name.glsl"`; the build keeps track of which file each
// line came from, so a compile error reads "wood.frag:120: error: ...".
//
//   Result<ShaderProgram> p = ShaderProgram::build("wood.vert", "wood.frag", {"WOOD_INDEX 1"});
//   if (!p) std::cerr << p.error().message() << "\n";
//   glUseProgram(p.value().id());
#pragma once

#include <string>
#include <vector>

#include "sawyer/core/result.h"

namespace sawyer::render {

// One shader stage assembled from the embedded files: the text and, per GLSL source-string
// number used in its #line directives, the file name.
struct AssembledShader {
  std::string text;
  std::vector<std::string> files;
};

// Expands `#include "x"` (from the embedded files, recursively) below a `#version 450 core`
// line and the given `#define`s. Errors name the file and line of a bad include.
Result<AssembledShader> assemble_shader(const std::string& file,
                                        const std::vector<std::string>& defines = {});

// Rewrites a driver's log ("0:12(5): error: ..." from Mesa, "0(12) : error ..." from NVIDIA)
// with file names: "wood.frag:12(5): error: ...". Unknown formats pass unchanged.
std::string map_shader_log(const std::string& log, const std::vector<std::string>& files);

class ShaderProgram {
 public:
  // Compiles and links a program from a vertex and a fragment file. Needs a current context.
  static Result<ShaderProgram> build(const std::string& vertex_file,
                                     const std::string& fragment_file,
                                     const std::vector<std::string>& defines = {});
  // Same from source text (tests): `name` is the file name used in messages.
  static Result<ShaderProgram> build_from_text(const std::string& vertex_name,
                                               const std::string& vertex_text,
                                               const std::string& fragment_name,
                                               const std::string& fragment_text);
  ShaderProgram() = default;
  ShaderProgram(ShaderProgram&& other) noexcept;
  ShaderProgram& operator=(ShaderProgram&& other) noexcept;
  ShaderProgram(const ShaderProgram&) = delete;
  ShaderProgram& operator=(const ShaderProgram&) = delete;
  ~ShaderProgram();

  // Takes ownership of a linked program object.
  static ShaderProgram adopt(unsigned id);

  unsigned id() const { return id_; }
  // Uniform location; -1 when the program has no such active uniform.
  int uniform(const char* name) const;

 private:
  unsigned id_ = 0;
};

// Names of the embedded shader files, and one file's text (empty when unknown). Where the
// environment names a folder, SAWYER_SHADER_DIR, a file of that name there is read instead (for
// shader development and before/after comparisons; docs/render.md "Gallery").
std::vector<std::string> embedded_shader_names();
std::string embedded_shader(const std::string& name);

}  // namespace sawyer::render

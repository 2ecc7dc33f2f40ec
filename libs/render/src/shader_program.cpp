#include "sawyer/render/shader_program.h"

#include <utility>

#include "gl.h"

namespace sawyer::render {
namespace {

std::string trim(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ' || s.back() == '\0')) s.pop_back();
  return s;
}

// The first problem of a log, for the one-line message; the rest follows on later lines.
std::string first_line(const std::string& s) {
  const size_t nl = s.find('\n');
  return nl == std::string::npos ? s : s.substr(0, nl) + " (and more)";
}

Result<GLuint> compile(GLenum stage, const std::string& text,
                       const std::vector<std::string>& files) {
  const GLuint sh = glCreateShader(stage);
  const char* src = text.c_str();
  glShaderSource(sh, 1, &src, nullptr);
  glCompileShader(sh);
  GLint ok = 0;
  glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    GLint len = 0;
    glGetShaderiv(sh, GL_INFO_LOG_LENGTH, &len);
    std::string log(static_cast<size_t>(std::max(len, 1)), '\0');
    glGetShaderInfoLog(sh, len, nullptr, log.data());
    glDeleteShader(sh);
    const std::string mapped = trim(map_shader_log(trim(log), files));
    return Error("shaders/" + first_line(mapped));
  }
  return sh;
}

Result<ShaderProgram> link(GLuint vs, GLuint fs, const std::string& what) {
  const GLuint prog = glCreateProgram();
  glAttachShader(prog, vs);
  glAttachShader(prog, fs);
  glLinkProgram(prog);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(prog, GL_LINK_STATUS, &ok);
  if (!ok) {
    GLint len = 0;
    glGetProgramiv(prog, GL_INFO_LOG_LENGTH, &len);
    std::string log(static_cast<size_t>(std::max(len, 1)), '\0');
    glGetProgramInfoLog(prog, len, nullptr, log.data());
    glDeleteProgram(prog);
    return Error(what, "link failed: " + first_line(trim(log)));
  }
  return ShaderProgram::adopt(prog);
}

}  // namespace

ShaderProgram ShaderProgram::adopt(unsigned id) {
  ShaderProgram p;
  p.id_ = id;
  return p;
}

Result<ShaderProgram> ShaderProgram::build(const std::string& vertex_file,
                                           const std::string& fragment_file,
                                           const std::vector<std::string>& defines) {
  Result<AssembledShader> v = assemble_shader(vertex_file, defines);
  if (!v) return v.error();
  Result<AssembledShader> f = assemble_shader(fragment_file, defines);
  if (!f) return f.error();
  Result<GLuint> vs = compile(GL_VERTEX_SHADER, v.value().text, v.value().files);
  if (!vs) return vs.error();
  Result<GLuint> fs = compile(GL_FRAGMENT_SHADER, f.value().text, f.value().files);
  if (!fs) {
    glDeleteShader(vs.value());
    return fs.error();
  }
  return link(vs.value(), fs.value(), "shaders/" + vertex_file + " + " + fragment_file);
}

Result<ShaderProgram> ShaderProgram::build_from_text(const std::string& vertex_name,
                                                     const std::string& vertex_text,
                                                     const std::string& fragment_name,
                                                     const std::string& fragment_text) {
  Result<GLuint> vs = compile(GL_VERTEX_SHADER, vertex_text, {vertex_name});
  if (!vs) return vs.error();
  Result<GLuint> fs = compile(GL_FRAGMENT_SHADER, fragment_text, {fragment_name});
  if (!fs) {
    glDeleteShader(vs.value());
    return fs.error();
  }
  return link(vs.value(), fs.value(), vertex_name + " + " + fragment_name);
}

ShaderProgram::ShaderProgram(ShaderProgram&& o) noexcept : id_(std::exchange(o.id_, 0)) {}

ShaderProgram& ShaderProgram::operator=(ShaderProgram&& o) noexcept {
  if (this != &o) {
    if (id_) glDeleteProgram(id_);
    id_ = std::exchange(o.id_, 0);
  }
  return *this;
}

ShaderProgram::~ShaderProgram() {
  if (id_) glDeleteProgram(id_);
}

int ShaderProgram::uniform(const char* name) const { return glGetUniformLocation(id_, name); }

}  // namespace sawyer::render

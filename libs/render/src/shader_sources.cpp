// The embedded shader files (generated at build time from shaders/) and the #include assembler.
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "sawyer/render/shader_program.h"

namespace sawyer::render {
namespace {

struct EmbeddedFile {
  const char* name;
  const char* text;
};

const EmbeddedFile kEmbedded[] = {
#include "embedded_shaders.inc"
};

constexpr int kMaxIncludeDepth = 16;

Status expand(const std::string& file, int depth, std::vector<std::string>& files,
              std::vector<std::string>& stack, std::string& out) {
  const std::string text = embedded_shader(file);
  if (text.empty()) return Error("shaders/" + file, "no such embedded shader file");
  if (depth > kMaxIncludeDepth || std::find(stack.begin(), stack.end(), file) != stack.end())
    return Error("shaders/" + file, "#include cycle");
  stack.push_back(file);
  const int id = static_cast<int>(files.size());
  files.push_back(file);
  out += "#line 1 " + std::to_string(id) + "\n";
  std::istringstream in(text);
  std::string line;
  int number = 0;
  static const std::regex include_re(R"(^\s*#\s*include\s+\"([^\"]+)\"\s*$)");
  static const std::regex version_re(R"(^\s*#\s*version\b.*$)");
  while (std::getline(in, line)) {
    ++number;
    std::smatch m;
    if (std::regex_match(line, m, include_re)) {
      Status st = expand(m[1].str(), depth + 1, files, stack, out);
      if (!st) {
        if (st.error().message().rfind("shaders/" + m[1].str() + ": no such", 0) == 0)
          return Error("shaders/" + file + ":" + std::to_string(number),
                       "#include \"" + m[1].str() + "\": no such shader file");
        return st;
      }
      out += "#line " + std::to_string(number + 1) + " " + std::to_string(id) + "\n";
    } else if (std::regex_match(line, version_re)) {
      out += "\n";  // the assembler writes the one #version line
    } else {
      out += line;
      out += "\n";
    }
  }
  stack.pop_back();
  return Status::Ok();
}

}  // namespace

std::vector<std::string> embedded_shader_names() {
  std::vector<std::string> names;
  for (const EmbeddedFile& f : kEmbedded) names.emplace_back(f.name);
  return names;
}

std::string embedded_shader(const std::string& name) {
  // A folder of shader files that take the embedded ones' place (shader development, and the
  // render gallery's "before" images drawn with an earlier commit's shaders).
  if (const char* dir = std::getenv("SAWYER_SHADER_DIR"); dir != nullptr && *dir != '\0') {
    std::ifstream in(std::filesystem::path(dir) / name, std::ios::binary);
    if (in) return std::string(std::istreambuf_iterator<char>(in), {});
  }
  for (const EmbeddedFile& f : kEmbedded)
    if (name == f.name) return f.text;
  return {};
}

Result<AssembledShader> assemble_shader(const std::string& file,
                                        const std::vector<std::string>& defines) {
  AssembledShader a;
  a.text = "#version 450 core\n";
  for (const std::string& d : defines) a.text += "#define " + d + "\n";
  std::vector<std::string> stack;
  Status st = expand(file, 0, a.files, stack, a.text);
  if (!st) return st.error();
  return a;
}

std::string map_shader_log(const std::string& log, const std::vector<std::string>& files) {
  // Mesa: "0:12(5): error: ..."; NVIDIA: "0(12) : error C1008: ...".
  static const std::regex mesa(R"(^(\d+):(\d+)(\(\d+\))?:)");
  static const std::regex nvidia(R"(^(\d+)\((\d+)\)\s*:)");
  std::istringstream in(log);
  std::string line, out;
  while (std::getline(in, line)) {
    std::smatch m;
    std::string mapped = line;
    auto name_of = [&](const std::string& idx) -> std::string {
      const size_t i = std::stoul(idx);
      return i < files.size() ? files[i] : "source " + idx;
    };
    if (std::regex_search(line, m, mesa)) {
      mapped = name_of(m[1].str()) + ":" + m[2].str() + m[3].str() + ":" + m.suffix().str();
    } else if (std::regex_search(line, m, nvidia)) {
      mapped = name_of(m[1].str()) + ":" + m[2].str() + ":" + m.suffix().str();
    }
    if (!out.empty()) out += "\n";
    out += mapped;
  }
  return out;
}

}  // namespace sawyer::render

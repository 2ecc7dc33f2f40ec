#include "sawyer/register/manifest.h"

#include <charconv>
#include <cstdint>
#include <cstdio>
#include <map>
#include <system_error>

#include "sawyer/core/file_util.h"

namespace sawyer::reg {
namespace fs = std::filesystem;

namespace {

// One CSV record starting at `pos`: cells, and the number of physical lines it spanned (a quoted
// cell may hold line breaks). Returns an error text for an unterminated quote.
struct Record {
  std::vector<std::string> cells;
  int lines = 1;
  std::string error;
};

Record next_record(const std::string& text, size_t& pos) {
  Record r;
  std::string cell;
  bool quoted = false, was_quoted = false;
  while (pos < text.size()) {
    const char c = text[pos++];
    if (quoted) {
      if (c == '"') {
        if (pos < text.size() && text[pos] == '"') {
          cell += '"';
          ++pos;
        } else {
          quoted = false;
        }
      } else {
        if (c == '\n') ++r.lines;
        cell += c;
      }
      continue;
    }
    if (c == '"' && cell.find_first_not_of(" \t") == std::string::npos && !was_quoted) {
      cell.clear();
      quoted = was_quoted = true;
    } else if (c == ',') {
      r.cells.push_back(cell);
      cell.clear();
      was_quoted = false;
    } else if (c == '\n') {
      break;
    } else if (c != '\r') {
      cell += c;
    }
  }
  if (quoted) r.error = "a quoted cell is not closed";
  r.cells.push_back(cell);
  return r;
}

std::string trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  const size_t e = s.find_last_not_of(" \t");
  return s.substr(b, e - b + 1);
}

bool blank_or_comment(const std::vector<std::string>& cells) {
  if (cells.size() == 1 && trim(cells[0]).empty()) return true;
  return !cells.empty() && !trim(cells[0]).empty() && trim(cells[0])[0] == '#';
}

// Ids become folder names under the batch's output folder.
std::string id_problem(const std::string& id) {
  if (id.empty()) return "is empty";
  if (id == "." || id == "..") return "cannot be '.' or '..'";
  for (char c : id) {
    if (c == '/' || c == '\\') return "cannot hold '/' or '\\' (it names the log's output folder)";
    if (static_cast<unsigned char>(c) < 0x20) return "holds a control character";
  }
  return "";
}

std::string default_id(const fs::path& ct) {
  fs::path p = ct.lexically_normal();
  if (p.filename().empty()) p = p.parent_path();  // "scans/log_1/"
  std::error_code ec;
  if (fs::is_regular_file(p, ec)) {
    // log_1.nii.gz -> log_1: drop every extension, volume files often carry two.
    std::string name = p.filename().string();
    const size_t dot = name.find('.');
    if (dot != std::string::npos && dot > 0) name.resize(dot);
    return name;
  }
  return p.filename().string();
}

}  // namespace

const std::vector<std::string>& manifest_columns() {
  static const std::vector<std::string> kColumns = {
      "ct", "id", "species", "pattern", "pattern_set", "grading", "prices", "position"};
  return kColumns;
}

namespace {

constexpr std::uintmax_t kMaxManifestBytes = 16u << 20;  // 16 MiB: ~100 000 rows

// The line and a description of the first byte that cannot be in a text CSV (a NUL or other
// control byte, or a byte sequence that is not UTF-8), or line 0 when the text is clean. A binary
// file given by mistake is refused here, before any of its bytes reach a message.
std::pair<int, std::string> first_non_text(const std::string& t) {
  int line = 1;
  for (size_t i = 0; i < t.size();) {
    const unsigned char c = static_cast<unsigned char>(t[i]);
    char hex[8];
    std::snprintf(hex, sizeof hex, "0x%02X", c);
    if (c == '\n') ++line;
    if (c < 0x80) {
      if (c < 0x20 && c != '\n' && c != '\r' && c != '\t')
        return {line, std::string("a control byte ") + hex};
      if (c == 0x7F) return {line, std::string("a control byte ") + hex};
      ++i;
      continue;
    }
    const int len = c >= 0xF0 && c <= 0xF4 ? 4 : c >= 0xE0 ? 3 : c >= 0xC2 && c <= 0xDF ? 2 : 0;
    bool ok = len > 0 && i + static_cast<size_t>(len) <= t.size();
    for (int k = 1; ok && k < len; ++k)
      ok = (static_cast<unsigned char>(t[i + static_cast<size_t>(k)]) & 0xC0) == 0x80;
    if (!ok) return {line, std::string("a byte ") + hex + " that is not UTF-8 text"};
    i += static_cast<size_t>(len);
  }
  return {0, ""};
}

}  // namespace

Result<Manifest> read_manifest(const fs::path& path) {
  Result<std::string> text = read_text_file(path, kMaxManifestBytes);
  if (!text) return text.error();
  const std::string& t = text.value();
  const std::string where = path.string();
  if (auto [bad_line, what] = first_non_text(t); bad_line > 0)
    return Error(where + ":" + std::to_string(bad_line),
                 "holds " + what + "; a manifest is a UTF-8 text CSV (a binary file given?)");
  size_t pos = t.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
  const fs::path base = fs::absolute(path).parent_path();

  auto at = [&](int line) { return where + ":" + std::to_string(line); };
  int line = 1;
  std::map<std::string, int> col;  // column name -> cell index
  Manifest m;
  m.path = path;
  std::map<std::string, int> id_line;
  bool have_header = false;

  while (pos < t.size()) {
    const int first_line = line;
    Record r = next_record(t, pos);
    line += r.lines;
    if (!r.error.empty()) return Error(at(first_line), r.error);
    if (blank_or_comment(r.cells)) continue;

    if (!have_header) {
      for (size_t i = 0; i < r.cells.size(); ++i) {
        const std::string name = trim(r.cells[i]);
        bool known = false;
        for (const std::string& k : manifest_columns()) known = known || k == name;
        if (!known) {
          std::string list;
          for (const std::string& k : manifest_columns()) list += (list.empty() ? "" : ", ") + k;
          return Error(at(first_line), "unknown column '" + name + "' in the header (" + list +
                                           "; the first row must be the header)");
        }
        if (col.count(name)) return Error(at(first_line), "column '" + name + "' given twice");
        col[name] = static_cast<int>(i);
      }
      if (!col.count("ct"))
        return Error(at(first_line), "the header has no 'ct' column (the CT folder or file)");
      have_header = true;
      continue;
    }

    if (r.cells.size() != col.size())
      return Error(at(first_line), std::to_string(r.cells.size()) + " cells, the header has " +
                                       std::to_string(col.size()));
    auto cell = [&](const char* name) -> std::string {
      auto it = col.find(name);
      return it == col.end() ? "" : trim(r.cells[static_cast<size_t>(it->second)]);
    };
    ManifestRow row;
    row.line = first_line;
    row.index = m.rows.size();
    row.ct = cell("ct");
    if (row.ct.empty()) return Error(at(first_line), "empty 'ct' cell");
    row.ct_path = fs::path(row.ct).is_absolute() ? fs::path(row.ct) : base / row.ct;
    row.ct_path = row.ct_path.lexically_normal();
    row.id = cell("id");
    if (row.id.empty()) row.id = default_id(row.ct_path);
    if (std::string p = id_problem(row.id); !p.empty())
      return Error(at(first_line), "id '" + row.id + "' " + p);
    if (auto [it, fresh] = id_line.emplace(row.id, first_line); !fresh)
      return Error(at(first_line), "id '" + row.id + "' is also on line " +
                                       std::to_string(it->second) +
                                       " (ids name the output folders; give an id column)");
    row.species = cell("species");
    row.position = cell("position");
    // Names (2ex, nordic) stay names; a file beside the manifest becomes its absolute path, so
    // the subprocess finds it whatever its working folder.
    auto resolve = [&](const std::string& v) -> std::string {
      if (v.empty() || fs::path(v).is_absolute()) return v;
      std::error_code ec;
      return fs::exists(base / v, ec) ? (base / v).lexically_normal().string() : v;
    };
    row.pattern = resolve(cell("pattern"));
    row.pattern_set = resolve(cell("pattern_set"));
    if (!row.pattern.empty() && !row.pattern_set.empty())
      return Error(at(first_line),
                   "a row gives both a pattern and a pattern_set; give one of "
                   "them");
    row.grading = resolve(cell("grading"));
    row.prices = resolve(cell("prices"));
    m.rows.push_back(std::move(row));
  }
  if (!have_header) return Error(where, "empty manifest: expected a header row with a 'ct' column");
  return m;
}

Result<Shard> parse_shard(const std::string& text) {
  const size_t slash = text.find('/');
  auto bad = [&](const std::string& why) {
    return Error("shard_spec", "'" + text + "': " + why +
                                   " (expected i/N with 0 <= i < N, e.g. 0/8 ... 7/8; 0-based like "
                                   "SLURM_ARRAY_TASK_ID)");
  };
  if (slash == std::string::npos) return bad("no '/'");
  auto number = [](const std::string& s, int& out) {
    const char* b = s.data();
    const char* e = s.data() + s.size();
    auto [p, ec] = std::from_chars(b, e, out);
    return !s.empty() && ec == std::errc() && p == e;
  };
  Shard sh;
  if (!number(text.substr(0, slash), sh.index) || !number(text.substr(slash + 1), sh.count))
    return bad("not two whole numbers");
  if (sh.count < 1) return bad("N must be at least 1");
  if (sh.index < 0 || sh.index >= sh.count) return bad("i out of range");
  return sh;
}

std::string csv_cell(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) {
    if (c == '"') q += '"';
    q += c;
  }
  return q + "\"";
}

}  // namespace sawyer::reg

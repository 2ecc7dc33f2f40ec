#include "sawyer/register/log_register.h"

#include <sqlite3.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <optional>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

namespace sawyer::reg {
namespace fs = std::filesystem;

namespace {

// How long one statement waits for another process's lock before SQLite gives up, and how many
// times we start a whole transaction again after that (SQLite returns SQLITE_BUSY at once,
// without waiting, in a few cases such as a WAL being recovered by another process).
constexpr int kBusyTimeoutMs = 10000;
constexpr int kBusyRetries = 20;

// The record's columns in table order. The table adds first_registered, last_registered, scans.
enum class Kind { kText, kReal, kInt };
struct Column {
  const char* name;
  Kind kind;
};
constexpr Column kColumns[] = {
    {"scan_source", Kind::kText},     {"scan_checksum", Kind::kText},
    {"log_id", Kind::kText},          {"species", Kind::kText},
    {"length_m", Kind::kReal},        {"butt_diameter_mm", Kind::kReal},
    {"top_diameter_mm", Kind::kReal}, {"mean_diameter_mm", Kind::kReal},
    {"volume_m3", Kind::kReal},       {"taper_mm_per_m", Kind::kReal},
    {"knot_count", Kind::kInt},       {"pattern", Kind::kText},
    {"grading", Kind::kText},         {"rotation_deg", Kind::kReal},
    {"offset_x_mm", Kind::kReal},     {"offset_y_mm", Kind::kReal},
    {"value", Kind::kReal},           {"gain_over_horns_down", Kind::kReal},
    {"currency", Kind::kText},        {"output_dir", Kind::kText},
    {"report_path", Kind::kText},     {"scanned_at", Kind::kText},
};
constexpr int kColumnCount = static_cast<int>(sizeof kColumns / sizeof kColumns[0]);

// Field access by column index, in kColumns order.
std::string* text_field(LogRecord& r, int i) {
  switch (i) {
    case 0:
      return &r.scan_source;
    case 1:
      return &r.scan_checksum;
    case 2:
      return &r.log_id;
    case 3:
      return &r.species;
    case 11:
      return &r.pattern;
    case 12:
      return &r.grading;
    case 18:
      return &r.currency;
    case 19:
      return &r.output_dir;
    case 20:
      return &r.report_path;
    case 21:
      return &r.scanned_at;
    default:
      return nullptr;
  }
}
double* real_field(LogRecord& r, int i) {
  switch (i) {
    case 4:
      return &r.length_m;
    case 5:
      return &r.butt_diameter_mm;
    case 6:
      return &r.top_diameter_mm;
    case 7:
      return &r.mean_diameter_mm;
    case 8:
      return &r.volume_m3;
    case 9:
      return &r.taper_mm_per_m;
    case 13:
      return &r.rotation_deg;
    case 14:
      return &r.offset_x_mm;
    case 15:
      return &r.offset_y_mm;
    case 16:
      return &r.value;
    case 17:
      return &r.gain_over_horns_down;
    default:
      return nullptr;
  }
}

const char* sql_type(Kind k) {
  switch (k) {
    case Kind::kText:
      return "TEXT NOT NULL DEFAULT ''";
    case Kind::kReal:
      return "REAL NOT NULL DEFAULT 0";
    case Kind::kInt:
      return "INTEGER NOT NULL DEFAULT 0";
  }
  return "";
}

std::string column_list(const char* prefix = "") {
  std::string s;
  for (int i = 0; i < kColumnCount; ++i) {
    if (i) s += ", ";
    s += prefix;
    s += kColumns[i].name;
  }
  return s;
}

std::string schema_v1() {
  std::string s = "CREATE TABLE logs (\n  id INTEGER PRIMARY KEY,\n";
  for (const Column& c : kColumns) {
    s += "  ";
    s += c.name;
    s += " ";
    s += std::string(c.name) == "scan_source" ? "TEXT NOT NULL UNIQUE" : sql_type(c.kind);
    s += ",\n";
  }
  s += "  first_registered TEXT NOT NULL,\n"
       "  last_registered TEXT NOT NULL,\n"
       "  scans INTEGER NOT NULL DEFAULT 1\n);\n"
       "CREATE INDEX logs_log_id ON logs(log_id);\n"
       "CREATE INDEX logs_species ON logs(species);\n"
       "CREATE INDEX logs_scanned_at ON logs(scanned_at);\n";
  return s;
}

constexpr const char* kNow = "strftime('%Y-%m-%dT%H:%M:%SZ', 'now')";

bool is_busy(int rc) {
  const int primary = rc & 0xff;
  return primary == SQLITE_BUSY || primary == SQLITE_LOCKED;
}

// A prepared statement, finalised on scope exit.
class Stmt {
 public:
  Stmt() = default;
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;
  ~Stmt() { sqlite3_finalize(s_); }
  sqlite3_stmt** out() { return &s_; }
  sqlite3_stmt* get() const { return s_; }

 private:
  sqlite3_stmt* s_ = nullptr;
};

}  // namespace

struct LogRegister::Impl {
  // A connection to `db` with `flags`, extended result codes and the busy timeout set.
  static Result<std::unique_ptr<Impl>> connect(const fs::path& db, int flags) {
    auto impl = std::make_unique<Impl>();
    impl->path = db;
    const int rc = sqlite3_open_v2(db.c_str(), &impl->db, flags | SQLITE_OPEN_NOMUTEX, nullptr);
    if (rc != SQLITE_OK)
      return impl->db ? impl->error_rc("cannot open", rc)
                      : Error(db.string(), std::string("cannot open: ") + sqlite3_errstr(rc));
    sqlite3_extended_result_codes(impl->db, 1);
    sqlite3_busy_timeout(impl->db, kBusyTimeoutMs);
    return impl;
  }

  fs::path path;
  sqlite3* db = nullptr;
  ~Impl() { sqlite3_close_v2(db); }

  Error error(const std::string& what) const {
    return Error(path.string(), what + ": " + sqlite3_errmsg(db));
  }
  Error error_rc(const std::string& what, int rc) const {
    // sqlite3_errmsg can describe a later call; the code's own text is always right.
    std::string msg = sqlite3_errmsg(db);
    const std::string generic = sqlite3_errstr(rc);
    if (msg == "not an error" || msg.empty()) msg = generic;
    return Error(path.string(), what + ": " + msg);
  }

  // Runs SQL without results (several statements allowed).
  int exec(const std::string& sql) const {
    return sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr);
  }

  // Runs `body` inside BEGIN IMMEDIATE ... COMMIT. BEGIN IMMEDIATE takes the write lock up front,
  // so two writers never deadlock upgrading read locks; if the lock or the commit stays busy past
  // the busy timeout, or SQLite reports busy at once, the whole transaction is run again.
  template <typename Body>
  Status transaction(const std::string& what, Body&& body) {
    int rc = SQLITE_OK;
    for (int attempt = 0; attempt <= kBusyRetries; ++attempt) {
      if (attempt) std::this_thread::sleep_for(std::chrono::milliseconds(10 + 20 * attempt));
      rc = exec("BEGIN IMMEDIATE");
      if (is_busy(rc)) continue;
      if (rc != SQLITE_OK) return error_rc(what, rc);
      rc = body();
      if (rc == SQLITE_OK || rc == SQLITE_DONE) rc = exec("COMMIT");
      if (rc == SQLITE_OK) return Status::Ok();
      Error e = error_rc(what, rc);
      exec("ROLLBACK");
      if (!is_busy(rc)) return e;
    }
    return error_rc(what + " (the database stayed locked by another process)", rc);
  }

  Result<int> user_version() const {
    Stmt st;
    int rc = sqlite3_prepare_v2(db, "PRAGMA user_version", -1, st.out(), nullptr);
    if (rc == SQLITE_OK) rc = sqlite3_step(st.get());
    if (rc != SQLITE_ROW) return error_rc("cannot read the schema version", rc);
    return sqlite3_column_int(st.get(), 0);
  }

  // Creates or migrates the schema to kRegisterSchemaVersion.
  Status migrate() {
    // The common case, an up-to-date register, needs no write lock.
    if (Result<int> v = user_version(); v && v.value() == kRegisterSchemaVersion)
      return Status::Ok();
    int found = 0;
    Status st = transaction("cannot create the register's tables", [&]() -> int {
      Result<int> v = user_version();
      if (!v) return SQLITE_ERROR;
      found = v.value();
      if (found > kRegisterSchemaVersion) return SQLITE_OK;  // refused below, nothing written
      if (found == 0) {
        // A fresh file, or an SQLite file of some other program: refuse the latter rather than
        // add our table to it.
        Stmt other;
        int rc =
            sqlite3_prepare_v2(db, "SELECT count(*) FROM sqlite_schema", -1, other.out(), nullptr);
        if (rc == SQLITE_OK) rc = sqlite3_step(other.get());
        if (rc != SQLITE_ROW) return rc;
        if (sqlite3_column_int(other.get(), 0) != 0) {
          found = -1;
          return SQLITE_OK;
        }
        rc = exec(schema_v1());
        if (rc != SQLITE_OK) return rc;
        return exec("PRAGMA user_version = " + std::to_string(kRegisterSchemaVersion));
      }
      // Later versions add their migrations here: `if (found < 2) { ALTER TABLE ...; }`.
      return SQLITE_OK;
    });
    if (!st) return st;
    if (found == -1)
      return Error(path.string(),
                   "an SQLite database, but not a Sawyer log register (it has other tables and "
                   "no schema version)");
    if (found > kRegisterSchemaVersion)
      return Error(path.string(), "written by a newer Sawyer (register schema version " +
                                      std::to_string(found) + ", this one reads up to " +
                                      std::to_string(kRegisterSchemaVersion) + ")");
    return Status::Ok();
  }
};

LogRegister::LogRegister(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
LogRegister::LogRegister(LogRegister&&) noexcept = default;
LogRegister& LogRegister::operator=(LogRegister&&) noexcept = default;
LogRegister::~LogRegister() = default;

const fs::path& LogRegister::path() const { return impl_->path; }

namespace {

// The folders above `db` that do not exist yet, the deepest first.
std::vector<fs::path> missing_folders(const fs::path& db) {
  std::vector<fs::path> missing;
  std::error_code ec;
  for (fs::path p = fs::absolute(db, ec).parent_path(); !p.empty() && p != p.root_path();
       p = p.parent_path()) {
    if (fs::exists(fs::symlink_status(p, ec))) break;
    missing.push_back(p);
  }
  return missing;
}

// A register this process created and could not finish (or merge into) is removed with its
// SQLite side files and the folders made for it, so nothing is left that was not there.
void remove_created(const fs::path& db, const std::vector<fs::path>& made_folders) {
  std::error_code ec;
  for (const char* suffix : {"", "-wal", "-shm", "-journal"})
    fs::remove(fs::path(db.string() + suffix), ec);
  for (const fs::path& f : made_folders) fs::remove(f, ec);  // only while empty
}

}  // namespace

Result<LogRegister> LogRegister::open(const fs::path& db) {
  std::error_code ec;
  if (fs::is_directory(db, ec)) return Error(db.string(), "is a folder, expected a database file");
  const std::vector<fs::path> made = missing_folders(db);
  if (!db.parent_path().empty()) {
    fs::create_directories(db.parent_path(), ec);
    if (ec) {
      remove_created(db, made);
      return Error(db.parent_path().string(), "cannot create folder: " + ec.message());
    }
  }
  const bool existed = fs::exists(fs::symlink_status(db, ec));
  Result<LogRegister> r = open_or_create(db);
  // A register that could not be created whole (a full disk, a read-only folder) is not left
  // behind as a stub that the next run would take for a register.
  if (!r && !existed) remove_created(db, made);
  return r;
}

Status check_register_creatable(const fs::path& db) {
  std::error_code ec;
  fs::path p = fs::absolute(db, ec).parent_path();
  while (!p.empty() && !fs::exists(fs::symlink_status(p, ec)) && p != p.root_path())
    p = p.parent_path();
  if (!fs::is_directory(p, ec))
    return Error(db.string(), "cannot be created: " + p.string() + " is not a folder");
  if (::access(p.c_str(), W_OK | X_OK) != 0)
    return Error(db.string(), "cannot be created: " + p.string() + " is not writable");
  return Status::Ok();
}

Result<std::vector<MergeSummary>> merge_registers(const fs::path& db,
                                                  const std::vector<fs::path>& sources) {
  std::error_code ec;
  for (const fs::path& other : sources) {
    if (fs::exists(other, ec) && fs::exists(db, ec) && fs::equivalent(other, db, ec))
      return Error(other.string(), "is the --db register itself");
    Result<LogRegister> src = LogRegister::open_read_only(other);
    if (!src) return src.error();
    if (Status st = src.value().integrity_check(); !st) return st.error();
  }
  const bool existed = fs::exists(fs::symlink_status(db, ec));
  const std::vector<fs::path> made = missing_folders(db);
  Result<LogRegister> opened = LogRegister::open(db);
  if (!opened) return opened.error();
  std::optional<LogRegister> reg(std::move(opened.value()));
  std::vector<MergeSummary> done;
  for (const fs::path& other : sources) {
    Result<MergeSummary> m = reg->merge_from(other);
    if (!m) {
      reg.reset();  // closed before its files are removed
      if (!existed) remove_created(db, made);
      return m.error();
    }
    done.push_back(m.value());
  }
  return done;
}

Result<LogRegister> LogRegister::open_or_create(const fs::path& db) {
  Result<std::unique_ptr<Impl>> opened =
      Impl::connect(db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  if (!opened) return opened.error();
  std::unique_ptr<Impl> impl = std::move(opened.value());
  int rc = SQLITE_OK;
  // WAL: readers never block the writer and one writer at a time commits without blocking
  // readers; the first statement that reads the file is also where "not a database" shows up.
  // Switching to WAL needs a moment's exclusive lock, so it is retried like a transaction.
  for (int attempt = 0;; ++attempt) {
    Stmt st;
    rc = sqlite3_prepare_v2(impl->db, "PRAGMA journal_mode=WAL", -1, st.out(), nullptr);
    if (rc == SQLITE_OK) rc = sqlite3_step(st.get());
    if (rc == SQLITE_ROW) break;
    if (!is_busy(rc) || attempt >= kBusyRetries) return impl->error_rc("cannot open", rc);
    std::this_thread::sleep_for(std::chrono::milliseconds(10 + 20 * attempt));
  }
  // NORMAL is durable against process crashes in WAL mode (only a power loss may drop the last
  // commits), and much cheaper than FULL for many small upserts.
  impl->exec("PRAGMA synchronous=NORMAL");
  if (Status s = impl->migrate(); !s) return s.error();
  return LogRegister(std::move(impl));
}

Result<LogRegister> LogRegister::open_read_only(const fs::path& db) {
  std::error_code ec;
  if (!fs::exists(db, ec)) return Error(db.string(), "no such file");
  if (fs::is_directory(db, ec)) return Error(db.string(), "is a folder, expected a database file");
  Result<std::unique_ptr<Impl>> opened = Impl::connect(db, SQLITE_OPEN_READONLY);
  if (!opened) return opened.error();
  std::unique_ptr<Impl> impl = std::move(opened.value());
  Result<int> v = impl->user_version();
  if (!v) return v.error();
  if (v.value() == 0) return Error(db.string(), "not a Sawyer log register (no schema version)");
  if (v.value() > kRegisterSchemaVersion)
    return Error(db.string(), "written by a newer Sawyer (register schema version " +
                                  std::to_string(v.value()) + ", this one reads up to " +
                                  std::to_string(kRegisterSchemaVersion) + ")");
  return LogRegister(std::move(impl));
}

Status LogRegister::upsert(const LogRecord& record) {
  if (record.scan_source.empty())
    return Error(impl_->path.string(), "cannot register a log without a scan source");
  // Built once per call: cheap next to the fsync of the commit.
  std::string sql =
      "INSERT INTO logs (" + column_list() + ", first_registered, last_registered, scans) VALUES (";
  for (int i = 0; i < kColumnCount; ++i) sql += i ? ", ?" : "?";
  sql += std::string(", ") + kNow + ", " + kNow + ", 1) ON CONFLICT(scan_source) DO UPDATE SET ";
  for (int i = 1; i < kColumnCount; ++i) {
    sql += kColumns[i].name;
    sql += " = excluded.";
    sql += kColumns[i].name;
    sql += ", ";
  }
  sql += "last_registered = excluded.last_registered, scans = logs.scans + 1";

  LogRecord r = record;
  return impl_->transaction("cannot register '" + record.scan_source + "'", [&]() -> int {
    Stmt st;
    int rc = sqlite3_prepare_v2(impl_->db, sql.c_str(), -1, st.out(), nullptr);
    if (rc != SQLITE_OK) return rc;
    for (int i = 0; i < kColumnCount; ++i) {
      const int at = i + 1;
      switch (kColumns[i].kind) {
        case Kind::kText: {
          const std::string& s = *text_field(r, i);
          rc = sqlite3_bind_text(st.get(), at, s.data(), static_cast<int>(s.size()),
                                 SQLITE_TRANSIENT);
          break;
        }
        case Kind::kReal:
          rc = sqlite3_bind_double(st.get(), at, *real_field(r, i));
          break;
        case Kind::kInt:
          rc = sqlite3_bind_int(st.get(), at, r.knot_count);
          break;
      }
      if (rc != SQLITE_OK) return rc;
    }
    return sqlite3_step(st.get());
  });
}

namespace {

LogRecord read_row(sqlite3_stmt* st) {
  LogRecord r;
  for (int i = 0; i < kColumnCount; ++i) {
    switch (kColumns[i].kind) {
      case Kind::kText: {
        const unsigned char* t = sqlite3_column_text(st, i);
        *text_field(r, i) = t ? reinterpret_cast<const char*>(t) : "";
        break;
      }
      case Kind::kReal:
        *real_field(r, i) = sqlite3_column_double(st, i);
        break;
      case Kind::kInt:
        r.knot_count = sqlite3_column_int(st, i);
        break;
    }
  }
  const unsigned char* first = sqlite3_column_text(st, kColumnCount);
  const unsigned char* last = sqlite3_column_text(st, kColumnCount + 1);
  r.first_registered = first ? reinterpret_cast<const char*>(first) : "";
  r.last_registered = last ? reinterpret_cast<const char*>(last) : "";
  r.scans = sqlite3_column_int(st, kColumnCount + 2);
  return r;
}

std::string select_all() {
  return "SELECT " + column_list() + ", first_registered, last_registered, scans FROM logs";
}

bool known_sort_column(const std::string& c) {
  for (const Column& col : kColumns)
    if (c == col.name) return true;
  return c == "first_registered" || c == "last_registered" || c == "scans";
}

}  // namespace

Status check_order_by(const std::string& order_by) {
  const std::string column = order_by.starts_with('-') ? order_by.substr(1) : order_by;
  if (known_sort_column(column)) return Status::Ok();
  return Error("LogFilter::order_by",
               "unknown field '" + order_by + "'; give one of " + column_list() +
                   ", first_registered, last_registered, scans (a leading '-' sorts descending)");
}

Result<std::vector<LogRecord>> LogRegister::list(const LogFilter& f) const {
  std::string order = f.order_by.empty() ? "scanned_at" : f.order_by;
  // The column name goes into the SQL text, so only our own column names are let through.
  if (Status st = check_order_by(order); !st) return st.error();
  const bool desc = order[0] == '-';
  if (desc) order.erase(0, 1);
  std::string sql = select_all() + " WHERE 1";
  if (!f.species.empty()) sql += " AND species = :species";
  if (!f.log_id_like.empty()) sql += " AND log_id LIKE :id";
  if (f.min_value) sql += " AND value >= :min_value";
  if (f.min_diameter_mm) sql += " AND mean_diameter_mm >= :min_diam";
  sql += " ORDER BY " + order + (desc ? " DESC" : " ASC") + ", scan_source";
  if (f.limit > 0) sql += " LIMIT " + std::to_string(f.limit);

  Stmt st;
  int rc = sqlite3_prepare_v2(impl_->db, sql.c_str(), -1, st.out(), nullptr);
  if (rc != SQLITE_OK) return impl_->error_rc("cannot list logs", rc);
  auto bind_text = [&](const char* name, const std::string& v) {
    const int i = sqlite3_bind_parameter_index(st.get(), name);
    if (i) sqlite3_bind_text(st.get(), i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
  };
  auto bind_real = [&](const char* name, const std::optional<double>& v) {
    const int i = sqlite3_bind_parameter_index(st.get(), name);
    if (i && v) sqlite3_bind_double(st.get(), i, *v);
  };
  bind_text(":species", f.species);
  bind_text(":id", f.log_id_like);
  bind_real(":min_value", f.min_value);
  bind_real(":min_diam", f.min_diameter_mm);

  std::vector<LogRecord> rows;
  while ((rc = sqlite3_step(st.get())) == SQLITE_ROW) rows.push_back(read_row(st.get()));
  if (rc != SQLITE_DONE) return impl_->error_rc("cannot list logs", rc);
  return rows;
}

Result<std::optional<LogRecord>> LogRegister::find(const std::string& scan_source) const {
  Stmt st;
  const std::string sql = select_all() + " WHERE scan_source = ?";
  int rc = sqlite3_prepare_v2(impl_->db, sql.c_str(), -1, st.out(), nullptr);
  if (rc != SQLITE_OK) return impl_->error_rc("cannot look up '" + scan_source + "'", rc);
  sqlite3_bind_text(st.get(), 1, scan_source.data(), static_cast<int>(scan_source.size()),
                    SQLITE_TRANSIENT);
  rc = sqlite3_step(st.get());
  if (rc == SQLITE_DONE) return std::optional<LogRecord>();
  if (rc != SQLITE_ROW) return impl_->error_rc("cannot look up '" + scan_source + "'", rc);
  return std::optional<LogRecord>(read_row(st.get()));
}

Result<int> LogRegister::count() const {
  Stmt st;
  int rc = sqlite3_prepare_v2(impl_->db, "SELECT count(*) FROM logs", -1, st.out(), nullptr);
  if (rc == SQLITE_OK) rc = sqlite3_step(st.get());
  if (rc != SQLITE_ROW) return impl_->error_rc("cannot count logs", rc);
  return sqlite3_column_int(st.get(), 0);
}

Status LogRegister::integrity_check() const {
  Stmt st;
  int rc = sqlite3_prepare_v2(impl_->db, "PRAGMA integrity_check", -1, st.out(), nullptr);
  if (rc == SQLITE_OK) rc = sqlite3_step(st.get());
  if (rc != SQLITE_ROW) return impl_->error_rc("integrity check failed", rc);
  const unsigned char* t = sqlite3_column_text(st.get(), 0);
  const std::string first = t ? reinterpret_cast<const char*>(t) : "";
  if (first != "ok") return Error(impl_->path.string(), "integrity check: " + first);
  return Status::Ok();
}

Result<MergeSummary> LogRegister::merge_from(const fs::path& other) {
  // Opening it ourselves first checks that it is a register of a version we read, with an error
  // naming that file rather than this one.
  MergeSummary summary;
  {
    Result<LogRegister> src = LogRegister::open_read_only(other);
    if (!src) return src.error();
    Result<int> n = src.value().count();
    if (!n) return n.error();
    summary.rows_read = n.value();
  }  // closed before ATTACH opens it again
  Result<int> before = count();
  if (!before) return before.error();

  // The later scan wins field by field; first_registered the earlier, scans the larger, so a
  // second merge of the same file changes nothing.
  std::string newer = "excluded.scanned_at > logs.scanned_at";
  std::string sql = "INSERT INTO logs (" + column_list() +
                    ", first_registered, last_registered, scans) SELECT " + column_list() +
                    ", first_registered, last_registered, scans FROM other.logs WHERE 1 "
                    "ON CONFLICT(scan_source) DO UPDATE SET ";
  for (int i = 1; i < kColumnCount; ++i) {
    const std::string c = kColumns[i].name;
    sql += c + " = CASE WHEN " + newer + " THEN excluded." + c + " ELSE logs." + c + " END, ";
  }
  sql +=
      "last_registered = max(logs.last_registered, excluded.last_registered), "
      "first_registered = min(logs.first_registered, excluded.first_registered), "
      "scans = max(logs.scans, excluded.scans) "
      // Only rows that change count as updated (and are written).
      "WHERE excluded.scanned_at > logs.scanned_at OR excluded.scans > logs.scans OR "
      "excluded.first_registered < logs.first_registered OR "
      "excluded.last_registered > logs.last_registered";

  Stmt attach;
  int rc = sqlite3_prepare_v2(impl_->db, "ATTACH DATABASE ? AS other", -1, attach.out(), nullptr);
  if (rc == SQLITE_OK) {
    const std::string p = other.string();
    sqlite3_bind_text(attach.get(), 1, p.data(), static_cast<int>(p.size()), SQLITE_TRANSIENT);
    rc = sqlite3_step(attach.get());
  }
  if (rc != SQLITE_DONE) return impl_->error_rc("cannot attach '" + other.string() + "'", rc);
  const int changes_before = sqlite3_total_changes(impl_->db);
  Status st = impl_->transaction("cannot merge '" + other.string() + "'",
                                 [&]() -> int { return impl_->exec(sql); });
  const int changed = sqlite3_total_changes(impl_->db) - changes_before;
  impl_->exec("DETACH DATABASE other");
  if (!st) return st.error();
  Result<int> after = count();
  if (!after) return after.error();
  summary.added = after.value() - before.value();
  summary.updated = changed - summary.added;
  return summary;
}

fs::path default_register_path() {
  if (const char* db = std::getenv("SAWYER_DB"); db && *db) return fs::path(db);
  if (const char* xdg = std::getenv("XDG_DATA_HOME"); xdg && *xdg)
    return fs::path(xdg) / "sawyer" / "logs.sqlite";
  if (const char* home = std::getenv("HOME"); home && *home)
    return fs::path(home) / ".local" / "share" / "sawyer" / "logs.sqlite";
  return {};
}

Result<fs::path> register_path(const std::string& db_option, const std::string& option,
                               const std::string& off_option) {
  if (!db_option.empty()) return fs::path(db_option);
  fs::path p = default_register_path();
  if (p.empty())
    return Error("log register",
                 "none of SAWYER_DB, XDG_DATA_HOME and HOME is set, so there is "
                 "no default register; give " +
                     option + " FILE or set SAWYER_DB" +
                     (off_option.empty() ? "" : " (or pass " + off_option + ")"));
  return p;
}

}  // namespace sawyer::reg

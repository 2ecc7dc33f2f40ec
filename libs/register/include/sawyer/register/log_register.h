// The log register: one SQLite row per scanned CT source (folder or volume file), with the log's
// figures, its best sawing position and value, and where its report lies. `sawyer run` writes it,
// `sawyer logs` reads it, `sawyer batch` shards write it from several processes at once
// (docs/batch.md).
//
//   Result<LogRegister> reg = LogRegister::open(default_register_path());
//   if (!reg) { std::cerr << reg.error().message() << "\n"; return 1; }
//   LogRecord r;
//   r.scan_source = fs::canonical(ct).string();   // THE key: one row per CT source
//   r.scan_checksum = ct_checksum(ct).value();
//   ...
//   Status st = reg.value().upsert(r);             // same source again: the row is updated
//   auto rows = reg.value().list({.species = "spruce", .min_value = 50.0});
//
// The database is a real file in WAL mode with a busy timeout, so any number of processes may
// read and write it at once on a local disk (not on NFS: docs/batch.md). A LogRegister is one
// connection: use it from one thread at a time; open one per thread or process.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/register/ct_checksum.h"

namespace sawyer::reg {

// One scanned log. Lengths in metres, diameters in millimetres, volume in cubic metres, taper
// in mm per metre; the position is the best one `sawyer saw` found (docs/sawing.md frames).
struct LogRecord {
  std::string scan_source;    // canonical absolute path of the CT folder or volume file: THE key
  std::string scan_checksum;  // ct_checksum() of the source when it was scanned
  std::string log_id, species;
  double length_m = 0, butt_diameter_mm = 0, top_diameter_mm = 0, mean_diameter_mm = 0,
         volume_m3 = 0, taper_mm_per_m = 0;
  int knot_count = 0;
  std::string pattern, grading;
  double rotation_deg = 0, offset_x_mm = 0, offset_y_mm = 0, value = 0, gain_over_horns_down = 0;
  std::string currency, output_dir, report_path, scanned_at /* ISO 8601 UTC */;

  // Kept by the register, ignored by upsert(): how many times the source was registered, and
  // when first and last (ISO 8601 UTC).
  int scans = 0;
  std::string first_registered, last_registered;
};

// Which rows list() returns. Empty strings and unset optionals do not filter.
struct LogFilter {
  std::string species;      // exact match
  std::string log_id_like;  // SQL LIKE pattern on log_id (% any run, _ one character)
  std::optional<double> min_value, min_diameter_mm;  // value >=, mean_diameter_mm >=
  int limit = 0;                                     // 0: all rows
  // A column of LogRecord (scanned_at, value, log_id, species, mean_diameter_mm, volume_m3,
  // length_m, knot_count, first_registered, ...); a leading '-' sorts descending.
  std::string order_by = "scanned_at";
};

// Whether `order_by` names a column LogFilter::order_by may sort by (with or without the
// leading '-'); the error names LogFilter::order_by and lists the columns.
Status check_order_by(const std::string& order_by);

// What merge_from() did.
struct MergeSummary {
  int rows_read = 0, added = 0, updated = 0;
};

// The schema version this build writes (PRAGMA user_version). Opening a register with a newer
// version is refused; older versions are migrated on open.
constexpr int kRegisterSchemaVersion = 1;

class LogRegister {
 public:
  // Opens (creating the file and its parent folder if missing) and migrates the register.
  // Errors name the db file and carry SQLite's message, e.g. "<db>: file is not a database".
  static Result<LogRegister> open(const std::filesystem::path& db);
  // Opens an existing register read-only; it is neither created nor migrated.
  static Result<LogRegister> open_read_only(const std::filesystem::path& db);

  LogRegister(LogRegister&&) noexcept;
  LogRegister& operator=(LogRegister&&) noexcept;
  ~LogRegister();

  // Inserts the record, or updates the row with the same scan_source: every field takes the new
  // value, first_registered is kept and scans goes up by one. One transaction; retried while
  // another process holds the write lock (up to the busy timeout).
  Status upsert(const LogRecord& record);

  Result<std::vector<LogRecord>> list(const LogFilter& filter = {}) const;
  Result<std::optional<LogRecord>> find(const std::string& scan_source) const;
  Result<int> count() const;

  // Copies the rows of another register into this one (`sawyer logs --merge`, one db per batch
  // shard): new sources are added; for a source in both, the row with the later scanned_at wins,
  // first_registered is the earlier and scans the larger of the two, so merging the same file
  // twice changes nothing.
  Result<MergeSummary> merge_from(const std::filesystem::path& other);

  // PRAGMA integrity_check: Ok, or an error with SQLite's first complaint.
  Status integrity_check() const;

  const std::filesystem::path& path() const;

 private:
  struct Impl;
  explicit LogRegister(std::unique_ptr<Impl> impl);
  // open() without the clean-up of a failed create.
  static Result<LogRegister> open_or_create(const std::filesystem::path& db);
  std::unique_ptr<Impl> impl_;
};

// Whether a register could be created at `db` (that does not exist yet) without creating it:
// its folder, or the nearest folder above it that exists, is a folder this process may write.
// The error names `db`. `sawyer run` checks this before a scan and creates the register only
// when it writes the row, so that a run refused or failed on the way leaves no register behind.
Status check_register_creatable(const std::filesystem::path& db);

// `sawyer logs --merge`: every source is checked first (a register of a version this reads, that
// passes SQLite's integrity check, and not `db` itself), then `db` is opened (created if
// missing) and each source merged in turn. A refusal or failure leaves no register at `db`
// that was not there before. Returns what each merge did, in the order of `sources`.
Result<std::vector<MergeSummary>> merge_registers(
    const std::filesystem::path& db, const std::vector<std::filesystem::path>& sources);

// Where the register lives by default: $SAWYER_DB, else $XDG_DATA_HOME/sawyer/logs.sqlite, else
// $HOME/.local/share/sawyer/logs.sqlite. Empty when none of the three is set: a register is
// never created in whatever folder the process happens to run in.
std::filesystem::path default_register_path();

// The register a command uses: `db_option` (its --db) if given, else default_register_path(),
// else an Error saying how to name one: `option` is the caller's name for the register's path
// (the command line's "--db"), `off_option` its way to run without one ("" when it has none).
Result<std::filesystem::path> register_path(const std::string& db_option, const std::string& option,
                                            const std::string& off_option);

}  // namespace sawyer::reg

// The log register: every field round-trips, a second scan of a source updates its row, filters,
// a file that is not a register is refused naming it, four processes writing at once lose
// nothing, merges are idempotent; ct_checksum sees content, renames and single bytes.
#include <gtest/gtest.h>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "sawyer/register/log_register.h"
#include "sawyer/test/test_util.h"

using namespace sawyer;
using namespace sawyer::reg;
namespace fs = std::filesystem;

namespace {

LogRecord full_record(const std::string& source, double value) {
  LogRecord r;
  r.scan_source = source;
  r.scan_checksum = "xxh3-64:0123456789abcdef";
  r.log_id = "L-" + fs::path(source).filename().string();
  r.species = "spruce";
  r.length_m = 4.125;
  r.butt_diameter_mm = 301.5;
  r.top_diameter_mm = 222.25;
  r.mean_diameter_mm = 260.75;
  r.volume_m3 = 0.2191;
  r.taper_mm_per_m = 19.25;
  r.knot_count = 87;
  r.pattern = "2ex 50x150";
  r.grading = "nordic";
  r.rotation_deg = 35;
  r.offset_x_mm = -4.5;
  r.offset_y_mm = 2.5;
  r.value = value;
  r.gain_over_horns_down = 0.0625;
  r.currency = "EUR";
  r.output_dir = "/out/" + r.log_id;
  r.report_path = "/out/" + r.log_id + "/report.pdf";
  r.scanned_at = "2026-11-24T05:00:00Z";
  return r;
}

LogRegister open_ok(const fs::path& db) {
  Result<LogRegister> r = LogRegister::open(db);
  EXPECT_TRUE(r.ok()) << r.error().message();
  return std::move(r).value();
}

void expect_same(const LogRecord& a, const LogRecord& b) {
  EXPECT_EQ(a.scan_source, b.scan_source);
  EXPECT_EQ(a.scan_checksum, b.scan_checksum);
  EXPECT_EQ(a.log_id, b.log_id);
  EXPECT_EQ(a.species, b.species);
  EXPECT_EQ(a.length_m, b.length_m);
  EXPECT_EQ(a.butt_diameter_mm, b.butt_diameter_mm);
  EXPECT_EQ(a.top_diameter_mm, b.top_diameter_mm);
  EXPECT_EQ(a.mean_diameter_mm, b.mean_diameter_mm);
  EXPECT_EQ(a.volume_m3, b.volume_m3);
  EXPECT_EQ(a.taper_mm_per_m, b.taper_mm_per_m);
  EXPECT_EQ(a.knot_count, b.knot_count);
  EXPECT_EQ(a.pattern, b.pattern);
  EXPECT_EQ(a.grading, b.grading);
  EXPECT_EQ(a.rotation_deg, b.rotation_deg);
  EXPECT_EQ(a.offset_x_mm, b.offset_x_mm);
  EXPECT_EQ(a.offset_y_mm, b.offset_y_mm);
  EXPECT_EQ(a.value, b.value);
  EXPECT_EQ(a.gain_over_horns_down, b.gain_over_horns_down);
  EXPECT_EQ(a.currency, b.currency);
  EXPECT_EQ(a.output_dir, b.output_dir);
  EXPECT_EQ(a.report_path, b.report_path);
  EXPECT_EQ(a.scanned_at, b.scanned_at);
}

std::string checksum_ok(const fs::path& p) {
  Result<std::string> c = ct_checksum(p);
  EXPECT_TRUE(c.ok()) << c.error().message();
  return c.ok() ? c.value() : "";
}

}  // namespace

TEST(LogRegister, EveryFieldRoundTrips) {
  test::TempDir dir;
  const fs::path db = dir / "sub" / "folder" / "logs.sqlite";  // parent folders created
  LogRecord r = full_record("/scans/log_1", 123.456);
  {
    LogRegister reg = open_ok(db);
    Status st = reg.upsert(r);
    ASSERT_TRUE(st.ok()) << st.error().message();
  }
  LogRegister reg = open_ok(db);  // reopened: the row is on disk
  Result<std::optional<LogRecord>> got = reg.find("/scans/log_1");
  ASSERT_TRUE(got.ok()) << got.error().message();
  ASSERT_TRUE(got.value().has_value());
  expect_same(*got.value(), r);
  EXPECT_EQ(got.value()->scans, 1);
  EXPECT_EQ(got.value()->first_registered.size(), 20u) << got.value()->first_registered;
  Result<std::optional<LogRecord>> none = reg.find("/scans/other");
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(none.value().has_value());
}

TEST(LogRegister, SameSourceTwiceUpdatesOneRow) {
  test::TempDir dir;
  LogRegister reg = open_ok(dir / "logs.sqlite");
  LogRecord first = full_record("/scans/log_1", 100);
  ASSERT_TRUE(reg.upsert(first).ok());
  Result<std::optional<LogRecord>> a = reg.find(first.scan_source);
  ASSERT_TRUE(a.ok() && a.value());
  LogRecord second = full_record("/scans/log_1", 150);
  second.species = "pine";
  second.knot_count = 12;
  second.scan_checksum = "xxh3-64:ffffffffffffffff";
  second.scanned_at = "2026-11-25T08:00:00Z";
  ASSERT_TRUE(reg.upsert(second).ok());
  Result<int> n = reg.count();
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(n.value(), 1);
  Result<std::optional<LogRecord>> b = reg.find(first.scan_source);
  ASSERT_TRUE(b.ok() && b.value());
  expect_same(*b.value(), second);
  EXPECT_EQ(b.value()->scans, 2);
  EXPECT_EQ(b.value()->first_registered, a.value()->first_registered);
}

TEST(LogRegister, FiltersOrderAndLimit) {
  test::TempDir dir;
  LogRegister reg = open_ok(dir / "logs.sqlite");
  for (int i = 0; i < 6; ++i) {
    LogRecord r = full_record("/scans/log_" + std::to_string(i), 10.0 * i);
    r.log_id = (i % 2 ? "pine-" : "spruce-") + std::to_string(i);
    r.species = i % 2 ? "pine" : "spruce";
    r.mean_diameter_mm = 200 + 20 * i;
    r.scanned_at = "2026-11-2" + std::to_string(i) + "T00:00:00Z";
    ASSERT_TRUE(reg.upsert(r).ok());
  }
  // The filter is set by a callback: designated initializers would skip fields (and warn).
  auto ids = [&](const std::function<void(LogFilter&)>& set) {
    LogFilter f;
    set(f);
    Result<std::vector<LogRecord>> rows = reg.list(f);
    EXPECT_TRUE(rows.ok()) << rows.error().message();
    std::vector<std::string> out;
    if (rows.ok())
      for (const LogRecord& r : rows.value()) out.push_back(r.log_id);
    return out;
  };
  using V = std::vector<std::string>;
  EXPECT_EQ(ids([](LogFilter&) {}).size(), 6u);
  EXPECT_EQ(ids([](LogFilter& f) { f.species = "pine"; }), (V{"pine-1", "pine-3", "pine-5"}));
  EXPECT_EQ(ids([](LogFilter& f) { f.log_id_like = "spruce-%"; }),
            (V{"spruce-0", "spruce-2", "spruce-4"}));
  EXPECT_EQ(ids([](LogFilter& f) { f.min_value = 30.0; }), (V{"pine-3", "spruce-4", "pine-5"}));
  EXPECT_EQ(ids([](LogFilter& f) { f.min_diameter_mm = 270.0; }), (V{"spruce-4", "pine-5"}));
  EXPECT_EQ(ids([](LogFilter& f) {
              f.species = "spruce";
              f.min_value = 15.0;
            }),
            (V{"spruce-2", "spruce-4"}));
  EXPECT_EQ(ids([](LogFilter& f) {
              f.limit = 2;
              f.order_by = "-value";
            }),
            (V{"pine-5", "spruce-4"}));
  EXPECT_EQ(ids([](LogFilter& f) { f.order_by = "-scanned_at"; }).front(), "pine-5");
  LogFilter injection;
  injection.order_by = "value; DROP TABLE logs";
  Result<std::vector<LogRecord>> bad = reg.list(injection);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message().find("LogFilter::order_by: unknown field"), std::string::npos)
      << bad.error().message();
  EXPECT_TRUE(check_order_by("-knot_count").ok());
  EXPECT_FALSE(check_order_by("--knot_count").ok());
}

TEST(LogRegister, GarbageFileIsRefusedNamingIt) {
  test::TempDir dir;
  const fs::path db = dir / "not_a_db.sqlite";
  std::string garbage(4096, '\0');
  for (size_t i = 0; i < garbage.size(); ++i) garbage[i] = static_cast<char>((i * 7919) % 251);
  test::write_file(db, garbage);
  Result<LogRegister> r = LogRegister::open(db);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message().find(db.string()), std::string::npos) << r.error().message();
  EXPECT_NE(r.error().message().find("not a database"), std::string::npos) << r.error().message();
  Result<LogRegister> ro = LogRegister::open_read_only(db);
  ASSERT_FALSE(ro.ok());
  EXPECT_NE(ro.error().message().find(db.string()), std::string::npos) << ro.error().message();
}

TEST(LogRegister, AFolderIsRefusedNamingIt) {
  test::TempDir dir;
  Result<LogRegister> r = LogRegister::open(dir.path());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message().find(dir.path().string()), std::string::npos);
}

TEST(LogRegister, NewerSchemaIsRefused) {
  test::TempDir dir;
  const fs::path db = dir / "logs.sqlite";
  { LogRegister reg = open_ok(db); }
  ASSERT_EQ(std::system(
                ("sqlite3 " + test::quoted(db) + " 'PRAGMA user_version = 99' >/dev/null").c_str()),
            0);
  Result<LogRegister> r = LogRegister::open(db);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message().find("newer"), std::string::npos) << r.error().message();
}

TEST(LogRegister, AnotherProgramsDatabaseIsNotWrittenInto) {
  test::TempDir dir;
  const fs::path db = dir / "other.sqlite";
  ASSERT_EQ(
      std::system(("sqlite3 " + test::quoted(db) + " 'CREATE TABLE t(x)' >/dev/null").c_str()), 0);
  Result<LogRegister> r = LogRegister::open(db);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message().find("not a Sawyer log register"), std::string::npos)
      << r.error().message();
}

// The real case: several batch shards, each a process with its own connection, registering at
// the same moment. Every process writes 50 sources of its own and 50 shared by all.
TEST(LogRegister, FourProcessesWritingAtOnceLoseNothing) {
  test::TempDir dir;
  const fs::path db = dir / "logs.sqlite";
  constexpr int kProcs = 4, kOwn = 50, kShared = 50;
  { LogRegister reg = open_ok(db); }  // the file exists, like after `sawyer batch` opened it
  // The children wait on a pipe until all are forked, so their writes really overlap.
  int gate[2];
  ASSERT_EQ(pipe(gate), 0);
  std::vector<pid_t> pids;
  for (int p = 0; p < kProcs; ++p) {
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      // Child: no gtest assertions here; the exit code says what went wrong.
      close(gate[1]);
      char c;
      if (read(gate[0], &c, 1) != 0) _exit(12);  // returns 0 when the parent closes its end
      Result<LogRegister> reg = LogRegister::open(db);
      if (!reg) _exit(10);
      for (int i = 0; i < kOwn + kShared; ++i) {
        const std::string source = i < kOwn ? "/p" + std::to_string(p) + "/log_" + std::to_string(i)
                                            : "/shared/log_" + std::to_string(i);
        if (!reg.value().upsert(full_record(source, p * 1000 + i))) _exit(11);
      }
      _exit(0);
    }
    pids.push_back(pid);
  }
  close(gate[0]);
  close(gate[1]);  // go
  for (pid_t pid : pids) {
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0) << "10: open failed, 11: upsert failed, 12: gate";
  }
  LogRegister reg = open_ok(db);
  Result<int> n = reg.count();
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(n.value(), kProcs * kOwn + kShared);
  Status ic = reg.integrity_check();
  EXPECT_TRUE(ic.ok()) << ic.error().message();
  Result<std::vector<LogRecord>> shared = reg.list();
  ASSERT_TRUE(shared.ok());
  int total_scans = 0;
  for (const LogRecord& r : shared.value())
    if (r.scan_source.rfind("/shared/", 0) == 0) {
      EXPECT_EQ(r.scans, kProcs) << r.scan_source;
      total_scans += r.scans;
    }
  EXPECT_EQ(total_scans, kProcs * kShared);
}

TEST(LogRegister, MergeAddsNewerWinsAndIsIdempotent) {
  test::TempDir dir;
  const fs::path a = dir / "a.sqlite", b = dir / "b.sqlite";
  {
    LogRegister ra = open_ok(a);
    ASSERT_TRUE(ra.upsert(full_record("/s/1", 1)).ok());
    LogRecord old = full_record("/s/2", 2);
    old.scanned_at = "2026-01-01T00:00:00Z";
    ASSERT_TRUE(ra.upsert(old).ok());
    LogRegister rb = open_ok(b);
    LogRecord newer = full_record("/s/2", 20);
    newer.scanned_at = "2026-06-01T00:00:00Z";
    ASSERT_TRUE(rb.upsert(newer).ok());
    ASSERT_TRUE(rb.upsert(full_record("/s/3", 3)).ok());
  }
  LogRegister ra = open_ok(a);
  Result<MergeSummary> m = ra.merge_from(b);
  ASSERT_TRUE(m.ok()) << m.error().message();
  EXPECT_EQ(m.value().rows_read, 2);
  EXPECT_EQ(m.value().added, 1);
  EXPECT_EQ(m.value().updated, 1);
  EXPECT_EQ(ra.count().value(), 3);
  EXPECT_EQ(ra.find("/s/2").value()->value, 20);
  Result<MergeSummary> again = ra.merge_from(b);
  ASSERT_TRUE(again.ok()) << again.error().message();
  EXPECT_EQ(again.value().added, 0);
  EXPECT_EQ(again.value().updated, 0);
  EXPECT_EQ(ra.count().value(), 3);

  test::write_file(dir / "junk.sqlite", "not a database at all, just text\n");
  Result<MergeSummary> bad = ra.merge_from(dir / "junk.sqlite");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message().find("junk.sqlite"), std::string::npos);
}

// Issue 44: `sawyer logs --merge` of a bad register refused, but left the merged file it had
// begun. Every source is checked before --db is made; a --db that cannot be made whole (a full
// disk: a file size limit of 0) leaves nothing, nor the folder made for it.
TEST(LogRegister, AMergeThatFailsLeavesNoRegisterThatWasNotThere) {
  test::TempDir dir;
  test::write_file(dir / "junk.sqlite", "not a database at all, just text\n");
  const fs::path target = dir / "new" / "merged.sqlite";
  Result<std::vector<MergeSummary>> r = merge_registers(target, {dir / "junk.sqlite"});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message().find("junk.sqlite"), std::string::npos) << r.error().message();
  EXPECT_FALSE(fs::exists(dir / "new"));
  r = merge_registers(target, {dir / "missing.sqlite"});
  ASSERT_FALSE(r.ok());
  EXPECT_FALSE(fs::exists(dir / "new"));

  // A good source, kept open so that its WAL index exists and reading it writes nothing.
  LogRegister src = open_ok(dir / "src.sqlite");
  ASSERT_TRUE(src.upsert(full_record("/s/1", 1)).ok());
  struct rlimit old {};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit none = old;
  none.rlim_cur = 0;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &none), 0);
  r = merge_registers(target, {dir / "src.sqlite"});
  ::setrlimit(RLIMIT_FSIZE, &old);
  std::signal(SIGXFSZ, old_handler);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message().find("merged.sqlite"), std::string::npos) << r.error().message();
  EXPECT_FALSE(fs::exists(dir / "new")) << "neither the register nor its folder is left";
  // With room, the same merge makes it.
  r = merge_registers(target, {dir / "src.sqlite"});
  ASSERT_TRUE(r.ok()) << r.error().message();
  EXPECT_EQ(r.value().at(0).added, 1);
  EXPECT_EQ(LogRegister::open_read_only(target).value().count().value(), 1);
}

TEST(LogRegister, DefaultPathFollowsTheEnvironment) {
  const char* saved_db = std::getenv("SAWYER_DB");
  const char* saved_xdg = std::getenv("XDG_DATA_HOME");
  const std::string keep_db = saved_db ? saved_db : "", keep_xdg = saved_xdg ? saved_xdg : "";
  setenv("SAWYER_DB", "/x/y.sqlite", 1);
  EXPECT_EQ(default_register_path(), fs::path("/x/y.sqlite"));
  unsetenv("SAWYER_DB");
  setenv("XDG_DATA_HOME", "/data", 1);
  EXPECT_EQ(default_register_path(), fs::path("/data/sawyer/logs.sqlite"));
  unsetenv("XDG_DATA_HOME");
  if (const char* home = std::getenv("HOME")) {
    EXPECT_EQ(default_register_path(), fs::path(home) / ".local/share/sawyer/logs.sqlite");
  }
  if (saved_db) setenv("SAWYER_DB", keep_db.c_str(), 1);
  if (saved_xdg) setenv("XDG_DATA_HOME", keep_xdg.c_str(), 1);
}

TEST(CtChecksum, SeesContentNamesAndSingleBytes) {
  test::TempDir dir;
  const fs::path ct = dir / "ct";
  fs::create_directories(ct / "sub");
  std::string slice(300000, 'a');
  for (size_t i = 0; i < slice.size(); ++i) slice[i] = static_cast<char>(i * 31 % 256);
  test::write_file(ct / "0001.dcm", slice);
  test::write_file(ct / "0002.dcm", slice);
  test::write_file(ct / "sub" / "meta.txt", "spacing 0.5");
  const std::string h = checksum_ok(ct);
  EXPECT_EQ(h.rfind("xxh3-64:", 0), 0u) << h;
  EXPECT_EQ(h.size(), 8u + 16u);

  // Same content elsewhere, files written in another order: same hash.
  const fs::path copy = dir / "copy";
  fs::create_directories(copy / "sub");
  test::write_file(copy / "sub" / "meta.txt", "spacing 0.5");
  test::write_file(copy / "0002.dcm", slice);
  test::write_file(copy / "0001.dcm", slice);
  EXPECT_EQ(checksum_ok(copy), h);

  // One byte changed.
  std::string changed = slice;
  changed[123456] ^= 1;
  test::write_file(copy / "0002.dcm", changed);
  EXPECT_NE(checksum_ok(copy), h);
  test::write_file(copy / "0002.dcm", slice);
  EXPECT_EQ(checksum_ok(copy), h);

  // A renamed file, and a byte moved from one file's end to the next file's start.
  fs::rename(copy / "0002.dcm", copy / "0003.dcm");
  EXPECT_NE(checksum_ok(copy), h);
  fs::rename(copy / "0003.dcm", copy / "0002.dcm");
  test::write_file(copy / "0001.dcm", slice + "x");
  test::write_file(copy / "0002.dcm", slice.substr(1));
  EXPECT_NE(checksum_ok(copy), h);

  // A single volume file: its content.
  test::write_file(dir / "a.mha", slice);
  test::write_file(dir / "b.mha", slice);
  EXPECT_EQ(checksum_ok(dir / "a.mha"), checksum_ok(dir / "b.mha"));

  Result<std::string> missing = ct_checksum(dir / "nope");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message().find("nope"), std::string::npos);
}

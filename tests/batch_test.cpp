// `sawyer batch`: the job pool runs real subprocesses (/bin/sh) at most N at a time and survives
// failures and crashes; manifests and shards are parsed strictly with errors naming file and
// line; `sawyer logs` and `sawyer batch` refuse bad input with one line.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "sawyer/register/job_pool.h"
#include "sawyer/register/log_register.h"
#include "sawyer/register/manifest.h"
#include "sawyer/test/test_util.h"

using namespace sawyer;
using namespace sawyer::reg;
namespace fs = std::filesystem;

namespace {

Job sh(const std::string& id, const std::string& script) {
  return {id, {"/bin/sh", "-c", script}, {}, {}};
}

size_t lines(const std::string& s) {
  return static_cast<size_t>(std::count(s.begin(), s.end(), '\n'));
}

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

TEST(JobPool, ExitCodesLastStderrLineAndOrder) {
  std::vector<Job> jobs = {sh("ok", "echo hello; exit 0"),
                           sh("three", "echo first >&2; echo 'bad log: no slices' >&2; exit 3"),
                           sh("silent", "exit 5"), sh("crash", "kill -SEGV $$")};
  std::vector<std::string> seen;
  JobPoolOptions o;
  o.jobs = 2;
  o.on_finished = [&](const JobResult& r, int done, int total) {
    EXPECT_EQ(total, 4);
    EXPECT_EQ(done, static_cast<int>(seen.size()) + 1);
    seen.push_back(r.id);
  };
  std::vector<JobResult> r = run_jobs(jobs, o);
  ASSERT_EQ(r.size(), 4u);
  EXPECT_EQ(seen.size(), 4u);
  EXPECT_EQ(r[0].id, "ok");
  EXPECT_TRUE(r[0].ok());
  EXPECT_EQ(r[0].error, "");
  EXPECT_EQ(r[1].exit_code, 3);
  EXPECT_EQ(r[1].error, "bad log: no slices");
  EXPECT_EQ(r[2].exit_code, 5);
  EXPECT_NE(r[2].error.find("exit code 5"), std::string::npos) << r[2].error;
  EXPECT_FALSE(r[3].ok());
  EXPECT_EQ(r[3].signal, 11);
  EXPECT_NE(r[3].error.find("signal 11"), std::string::npos) << r[3].error;
}

TEST(JobPool, NeverRunsMoreThanJobsAtOnce) {
  // Each job records its start and end in a shared folder; the pool must never overlap more than
  // two. Counting marker files rather than timing keeps the test free of wall-clock asserts.
  test::TempDir dir;
  const std::string d = dir.path().string();
  std::vector<Job> jobs;
  for (int i = 0; i < 6; ++i) {
    const std::string n = std::to_string(i), marker = "'" + d + "/run." + n + "'";
    jobs.push_back(sh(std::string("j").append(n), "touch " + marker + "; n=$(ls '" + d +
                                                      "' | grep -c '^run\\.'); echo $n >> '" + d +
                                                      "/max'; sleep 0.2; rm " + marker));
  }
  JobPoolOptions o;
  o.jobs = 2;
  std::vector<JobResult> r = run_jobs(jobs, o);
  for (const JobResult& x : r) EXPECT_TRUE(x.ok()) << x.id << ": " << x.error;
  std::istringstream in(read(dir / "max"));
  int n = 0, most = 0, count = 0;
  while (in >> n) {
    most = std::max(most, n);
    ++count;
  }
  EXPECT_EQ(count, 6);
  EXPECT_LE(most, 2);
}

TEST(JobPool, MissingProgramIsAFailedJobNotACrash) {
  std::vector<JobResult> r =
      run_jobs({{"x", {"/no/such/program"}, {}, {}}, sh("y", "exit 0")}, JobPoolOptions{});
  ASSERT_EQ(r.size(), 2u);
  EXPECT_FALSE(r[0].ok());
  EXPECT_NE(r[0].error.find("/no/such/program"), std::string::npos) << r[0].error;
  EXPECT_TRUE(r[1].ok());
}

TEST(JobPool, TimeoutStopsAJob) {
  JobPoolOptions o;
  o.timeout_s = 0.3;
  std::vector<JobResult> r = run_jobs({sh("slow", "sleep 30")}, o);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_FALSE(r[0].ok());
  EXPECT_TRUE(r[0].timed_out);
  EXPECT_NE(r[0].error.find("timed out"), std::string::npos) << r[0].error;
}

TEST(JobPool, OutputFilesAreKept) {
  test::TempDir dir;
  Job j = sh("x", "echo out; echo err >&2; exit 1");
  j.stdout_path = dir / "x.out";
  j.stderr_path = dir / "x.err";
  std::vector<JobResult> r = run_jobs({j}, {});
  EXPECT_EQ(r[0].error, "err");
  EXPECT_EQ(read(dir / "x.out"), "out\n");
  EXPECT_EQ(read(dir / "x.err"), "err\n");
}

TEST(Manifest, ColumnsPathsIdsAndQuoting) {
  test::TempDir dir;
  fs::create_directories(dir / "scans" / "log_a");
  test::write_file(dir / "scans" / "log_b.nii.gz", "x");
  test::write_file(dir / "my_prices.json", "{}");
  test::write_file(dir / "m.csv",
                   "\xEF\xBB\xBF# logs of 24 November\r\n"
                   "species,ct,id,prices\r\n"
                   "spruce,scans/log_a,,\r\n"
                   "\r\n"
                   "pine,scans/log_b.nii.gz,,my_prices.json\r\n"
                   "pine,/abs/ct,\"L,3\",nordic_prices\r\n");
  Result<Manifest> m = read_manifest(dir / "m.csv");
  ASSERT_TRUE(m.ok()) << m.error().message();
  ASSERT_EQ(m.value().rows.size(), 3u);
  const auto& r = m.value().rows;
  EXPECT_EQ(r[0].id, "log_a");
  EXPECT_EQ(r[0].ct_path, dir.path() / "scans" / "log_a");
  EXPECT_EQ(r[0].species, "spruce");
  EXPECT_EQ(r[0].line, 3);
  EXPECT_EQ(r[1].id, "log_b");
  EXPECT_EQ(r[1].prices, (dir.path() / "my_prices.json").string());
  EXPECT_EQ(r[1].index, 1u);
  EXPECT_EQ(r[2].id, "L,3");
  EXPECT_EQ(r[2].ct_path, fs::path("/abs/ct"));
  EXPECT_EQ(r[2].prices, "nordic_prices");  // not a file: kept as a name
}

TEST(Manifest, BadManifestsNameFileAndLine) {
  test::TempDir dir;
  struct Case {
    std::string text, expect;
  };
  const std::vector<Case> cases = {
      {"", "empty manifest"},
      {"path,id\nx,y\n", ":1: unknown column 'path'"},
      {"id,species\na,pine\n", ":1: the header has no 'ct' column"},
      {"ct,id\na,1\nb\n", ":3: 1 cells, the header has 2"},
      {"ct,id\n,1\n", ":2: empty 'ct' cell"},
      {"ct,id\na,x\nb,x\n", ":3: id 'x' is also on line 2"},
      {"ct\nscans/a\nother/a\n", ":3: id 'a' is also on line 2"},
      {"ct,id\na,../up\n", ":2: id '../up' cannot hold '/'"},
      {"ct,id\na,\"open\n", ":2: a quoted cell is not closed"},
  };
  for (const Case& c : cases) {
    test::write_file(dir / "m.csv", c.text);
    Result<Manifest> m = read_manifest(dir / "m.csv");
    ASSERT_FALSE(m.ok()) << c.text;
    EXPECT_NE(m.error().message().find((dir / "m.csv").string()), std::string::npos)
        << m.error().message();
    EXPECT_NE(m.error().message().find(c.expect), std::string::npos)
        << "got: " << m.error().message() << "\nexpected: " << c.expect;
  }
  Result<Manifest> missing = read_manifest(dir / "none.csv");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message().find("none.csv"), std::string::npos);
}

TEST(Shard, ParseAndCoverEveryRowOnce) {
  for (const char* bad : {"", "1", "2/2", "-1/2", "0/0", "a/b", "1/2x", "0/-3"}) {
    Result<Shard> s = parse_shard(bad);
    EXPECT_FALSE(s.ok()) << bad;
    if (!s.ok()) {
      EXPECT_NE(s.error().message().find("shard_spec"), std::string::npos);
    }
  }
  Result<Shard> one = parse_shard("0/1");
  ASSERT_TRUE(one.ok());
  for (int n : {1, 2, 3, 8}) {
    std::vector<int> owners(23, 0);
    for (int i = 0; i < n; ++i) {
      Result<Shard> s = parse_shard(std::to_string(i) + "/" + std::to_string(n));
      ASSERT_TRUE(s.ok());
      for (size_t row = 0; row < owners.size(); ++row) owners[row] += s.value().owns(row);
    }
    for (int o : owners) EXPECT_EQ(o, 1) << n << " shards";
  }
}

TEST(BatchCli, BadManifestIsOneLineNamingFileAndLineExitOne) {
  test::TempDir dir;
  test::write_file(dir / "m.csv", "ct,colour\na,red\n");
  std::string out;
  EXPECT_EQ(
      test::run_sawyer("batch " + test::quoted(dir / "m.csv") + " -o " + test::quoted(dir / "out") +
                           " --db " + test::quoted(dir / "logs.sqlite"),
                       &out),
      1);
  EXPECT_EQ(lines(out), 1u) << out;
  EXPECT_NE(out.find("m.csv:1"), std::string::npos) << out;
  EXPECT_NE(out.find("colour"), std::string::npos) << out;
}

TEST(BatchCli, BadShardAndOwnedOptionsAreRefused) {
  test::TempDir dir;
  test::write_file(dir / "m.csv", "ct\na\n");
  const std::string base = "batch " + test::quoted(dir / "m.csv") + " -o " +
                           test::quoted(dir / "out") + " --db " + test::quoted(dir / "logs.sqlite");
  std::string out;
  EXPECT_EQ(test::run_sawyer(base + " --shard 3/3", &out), 1);
  EXPECT_NE(out.find("--shard"), std::string::npos) << out;
  EXPECT_EQ(test::run_sawyer(base + " -- --db other.sqlite", &out), 1);
  EXPECT_NE(out.find("--db"), std::string::npos) << out;
}

TEST(BatchCli, BadDbStopsTheBatchBeforeAnyLog) {
  test::TempDir dir;
  test::write_file(dir / "m.csv", "ct\na\n");
  test::write_file(dir / "bad.sqlite", std::string(2048, 'z'));
  std::string out;
  EXPECT_EQ(
      test::run_sawyer("batch " + test::quoted(dir / "m.csv") + " -o " + test::quoted(dir / "out") +
                           " --db " + test::quoted(dir / "bad.sqlite"),
                       &out),
      1);
  EXPECT_EQ(lines(out), 1u) << out;
  EXPECT_NE(out.find("bad.sqlite"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir / "out" / "batch_0.csv"));
}

TEST(LogsCli, EmptyMissingAndBadRegisters) {
  test::TempDir dir;
  std::string out;
  EXPECT_EQ(test::run_sawyer("logs --db " + test::quoted(dir / "none.sqlite"), &out), 0);
  EXPECT_NE(out.find("no logs registered yet"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir / "none.sqlite"));  // listing creates nothing

  { ASSERT_TRUE(LogRegister::open(dir / "empty.sqlite").ok()); }
  EXPECT_EQ(test::run_sawyer("logs --db " + test::quoted(dir / "empty.sqlite"), &out), 0);
  EXPECT_NE(out.find("no logs registered yet"), std::string::npos) << out;
  EXPECT_EQ(test::run_sawyer("logs --json --db " + test::quoted(dir / "empty.sqlite"), &out), 0);
  EXPECT_EQ(out, "[]\n");

  test::write_file(dir / "bad.sqlite", std::string(2048, 'z'));
  EXPECT_EQ(test::run_sawyer("logs --db " + test::quoted(dir / "bad.sqlite"), &out), 1);
  EXPECT_EQ(lines(out), 1u) << out;
  EXPECT_NE(out.find("bad.sqlite"), std::string::npos) << out;
}

TEST(LogsCli, TableCsvJsonFiltersAndMerge) {
  test::TempDir dir;
  {
    LogRegister a = LogRegister::open(dir / "a.sqlite").value();
    LogRegister b = LogRegister::open(dir / "b.sqlite").value();
    for (int i = 0; i < 4; ++i) {
      LogRecord r;
      r.scan_source = "/ct/log_" + std::to_string(i);
      r.log_id = "L" + std::to_string(i);
      r.species = i % 2 ? "pine" : "spruce";
      r.value = 10.0 * i;
      r.mean_diameter_mm = 200 + 10 * i;
      r.currency = "EUR";
      r.report_path = "/out/L" + std::to_string(i) + "/report.pdf";
      r.scanned_at = "2026-11-24T0" + std::to_string(i) + ":00:00Z";
      ASSERT_TRUE((i < 2 ? a : b).upsert(r).ok());
    }
  }
  const std::string a = " --db " + test::quoted(dir / "a.sqlite");
  std::string out;
  ASSERT_EQ(test::run_sawyer("logs" + a + " --merge " + test::quoted(dir / "b.sqlite"), &out), 0)
      << out;
  EXPECT_NE(out.find("2 new"), std::string::npos) << out;
  ASSERT_EQ(test::run_sawyer("logs" + a, &out), 0) << out;
  EXPECT_NE(out.find("L3"), std::string::npos) << out;
  EXPECT_NE(out.find("/out/L2/report.pdf"), std::string::npos) << out;
  EXPECT_NE(out.find("4 logs in"), std::string::npos) << out;
  ASSERT_EQ(test::run_sawyer("logs --csv --species pine --min-value 15" + a, &out), 0) << out;
  EXPECT_EQ(lines(out), 2u) << out;  // header + L3
  EXPECT_NE(out.find("L3,pine"), std::string::npos) << out;
  ASSERT_EQ(test::run_sawyer("logs --json --id 'L?' --min-diameter 215 --sort=-value --limit 1" + a,
                             &out),
            0)
      << out;
  EXPECT_NE(out.find("\"log_id\": \"L3\""), std::string::npos) << out;
  EXPECT_EQ(out.find("\"L2\""), std::string::npos) << out;
  ASSERT_EQ(test::run_sawyer("logs --species oak" + a, &out), 0) << out;
  EXPECT_NE(out.find("no logs match (4 in"), std::string::npos) << out;
}

// End to end: real `sawyer run` subprocesses on two small phantom CT scans and a folder whose
// only "slice" is a text file. The scans are made once for the suite (a few seconds each).
class BatchEndToEnd : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
#ifndef SAWYER_HAVE_RUN
    return;
#endif
    dir_ = new test::TempDir();
    fs::path scans[2];  // made once per build (test_util.h)
    for (int seed : {1, 2}) {
      scans[seed - 1] = test::cached_phantom(
          "gran1_30cm_coarse_s" + std::to_string(seed),
          test::quoted(test::sample_log("gran1_spruce") / "log.json") +
              " --from-mm 1000 --to-mm 1300 --size 256 --pixel-mm 1.6 --spacing-mm 10"
              " --threads 1 --seed " +
              std::to_string(seed));
      ASSERT_FALSE(scans[seed - 1].empty());
      // Named as the batch sees it; the register keys on the resolved path.
      fs::create_directories(dir_->path() / "scans");
      fs::create_directory_symlink(scans[seed - 1],
                                   dir_->path() / "scans" / ("log_s" + std::to_string(seed)));
    }
    test::write_file(dir_->path() / "scans" / "broken" / "0001.dcm", "not a DICOM file\n");
    test::write_file(dir_->path() / "manifest.csv",
                     "ct,id,species,pattern\n"
                     "scans/log_s1,A,spruce,\n"
                     "scans/broken,B,pine,\n"
                     "scans/log_s2,,spruce,tt\n");
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  void SetUp() override {
#ifndef SAWYER_HAVE_RUN
    GTEST_SKIP() << "`sawyer run` is built only with the renderer (sawyer::render)";
#endif
  }
  static fs::path path(const std::string& name) { return dir_->path() / name; }

  // Runs a batch; returns the exit code and the rows of its CSV (id -> status).
  static int batch(const std::string& args, const fs::path& out_dir, const fs::path& db,
                   std::map<std::string, std::string>* statuses, std::string* output) {
    const int rc = test::run_sawyer("batch " + test::quoted(path("manifest.csv")) + " -o " +
                                        test::quoted(out_dir) + " --db " + test::quoted(db) + " " +
                                        args + " -- --threads 1",
                                    output);
    read_statuses(out_dir, statuses);
    return rc;
  }

  // The rows of the batch CSVs in out_dir: id -> status; an id listed twice is a failure.
  static void read_statuses(const fs::path& out_dir, std::map<std::string, std::string>* statuses) {
    for (const fs::directory_entry& e : fs::directory_iterator(out_dir)) {
      if (e.path().extension() != ".csv") continue;
      std::istringstream in(read(e.path()));
      std::string line;
      std::getline(in, line);
      EXPECT_EQ(line, "id,ct,status,exit_code,seconds,value,pattern,error");
      while (std::getline(in, line)) {
        std::vector<std::string> cells;
        std::istringstream ls(line);
        std::string cell;
        while (std::getline(ls, cell, ',')) cells.push_back(cell);
        EXPECT_FALSE((*statuses).count(cells.at(0))) << cells.at(0) << " listed twice";
        (*statuses)[cells.at(0)] = cells.at(2);
      }
    }
  }

  static test::TempDir* dir_;
};
test::TempDir* BatchEndToEnd::dir_ = nullptr;

// A log whose run completed, with or without QA warnings (exit 0 or 3), is done: at 1.6 mm pixels
// and 10 mm slices the real spruce's rings are not resolved and its pith comes from the log's
// shape, which the scan's QA verdict says ("qa_warnings"); the batch counts it done all the same.
std::map<std::string, std::string> done_or_failed(std::map<std::string, std::string> st) {
  for (auto& [id, status] : st)
    if (status == "ok" || status == "qa_warnings") status = "done";
  return st;
}

TEST_F(BatchEndToEnd, BadLogIsReportedGoodLogsAreDoneAndRegistered) {
  const fs::path out = path("out_all"), db = path("all.sqlite");
  std::map<std::string, std::string> st;
  std::string output;
  EXPECT_EQ(batch("--jobs 2", out, db, &st, &output), 2) << output;
  EXPECT_EQ(done_or_failed(st), (std::map<std::string, std::string>{
                                    {"A", "done"}, {"B", "failed"}, {"log_s2", "done"}}))
      << output;
  // The failed log's line names the bad file; the progress has one line per log.
  EXPECT_NE(read(out / "batch_0.csv").find("0001.dcm"), std::string::npos);
  EXPECT_NE(output.find("/3] B FAILED"), std::string::npos) << output;
  EXPECT_FALSE(fs::exists(out / "B"));
  EXPECT_TRUE(fs::exists(out / "A" / "report"));
  EXPECT_TRUE(fs::exists(out / "log_s2" / "report"));

  Result<LogRegister> reg = LogRegister::open_read_only(db);
  ASSERT_TRUE(reg.ok()) << reg.error().message();
  EXPECT_EQ(reg.value().count().value(), 2);
  Result<std::optional<LogRecord>> a =
      reg.value().find(fs::weakly_canonical(path("scans/log_s1")).string());
  ASSERT_TRUE(a.ok() && a.value()) << "no row for log_s1";
  EXPECT_EQ(a.value()->log_id, "A");
  EXPECT_EQ(a.value()->species, "spruce");
  EXPECT_EQ(a.value()->scan_checksum.rfind("xxh3-64:", 0), 0u);
  EXPECT_TRUE(fs::exists(a.value()->report_path)) << a.value()->report_path;
  // The manifest's pattern cell reached the run.
  Result<std::optional<LogRecord>> b =
      reg.value().find(fs::weakly_canonical(path("scans/log_s2")).string());
  ASSERT_TRUE(b.ok() && b.value()) << "no row for log_s2";
  EXPECT_EQ(b.value()->pattern.rfind("through-and-through", 0), 0u) << b.value()->pattern;
  EXPECT_EQ(a.value()->pattern.rfind("2ex", 0), 0u) << a.value()->pattern;

  // `sawyer logs` shows both.
  ASSERT_EQ(test::run_sawyer("logs --csv --db " + test::quoted(db), &output), 0) << output;
  EXPECT_EQ(lines(output), 3u) << output;
}

TEST_F(BatchEndToEnd, TwoShardsCoverEveryRowOnce) {
  const fs::path out = path("out_shards"), db = path("shards.sqlite");
  std::map<std::string, std::string> st0, st1;
  std::string o0, o1;
  // Both shards at once, sharing one register: the way a job array on one machine runs them.
  const char* env = std::getenv("SAWYER_BIN");
  const std::string bin = env && *env ? env : SAWYER_BIN_PATH;
  std::vector<Job> shards;
  for (const char* i : {"0", "1"}) {
    const fs::path o = out / (std::string("s") + i);
    shards.push_back({i,
                      {bin, "batch", path("manifest.csv").string(), "-o", o.string(), "--db",
                       db.string(), "--shard", std::string(i) + "/2", "--", "--threads", "1"},
                      out / (std::string("stdout_") + i),
                      out / (std::string("stderr_") + i)});
  }
  fs::create_directories(out);
  JobPoolOptions po;
  po.jobs = 2;
  std::vector<JobResult> r = run_jobs(shards, po);
  const int rc0 = r[0].exit_code, rc1 = r[1].exit_code;
  o0 = read(out / "stdout_0") + r[0].error;
  o1 = read(out / "stdout_1") + r[1].error;
  read_statuses(out / "s0", &st0);
  read_statuses(out / "s1", &st1);
  // Rows 0 and 2 (A, log_s2) are shard 0's, row 1 (B, the broken one) shard 1's.
  EXPECT_EQ(rc0, 0) << o0;
  EXPECT_EQ(rc1, 2) << o1;
  EXPECT_EQ(done_or_failed(st0),
            (std::map<std::string, std::string>{{"A", "done"}, {"log_s2", "done"}}));
  EXPECT_EQ(st1, (std::map<std::string, std::string>{{"B", "failed"}}));
  EXPECT_TRUE(fs::exists(out / "s0" / "batch_0.csv"));
  EXPECT_TRUE(fs::exists(out / "s1" / "batch_1.csv"));
  Result<LogRegister> reg = LogRegister::open_read_only(db);
  ASSERT_TRUE(reg.ok()) << reg.error().message();
  EXPECT_EQ(reg.value().count().value(), 2);
}

// A log whose pattern does not fit it (a pattern far wider than the 250 mm log) is its own
// category: `sawyer run` writes its scan and report and exits 4, the batch lists it "not_sawn"
// with why, counts it apart from ok and failed, leaves its folder, and is not partial (exit 0).
TEST_F(BatchEndToEnd, ALogThePatternDoesNotFitIsCountedNotSawn) {
  test::write_file(path("huge.json"), R"({"format": "sawyer-pattern/1", "name": "huge",
    "boards": [
      {"name": "1", "u_mm": -101.5, "v_mm": 0, "thickness_mm": 200, "width_mm": 400},
      {"name": "2", "u_mm": 101.5, "v_mm": 0, "thickness_mm": 200, "width_mm": 400}]})");
  test::write_file(path("manifest_huge.csv"),
                   "ct,id,species,pattern\n"
                   "scans/log_s1,BIG,spruce,huge.json\n");
  const fs::path out = path("out_huge"), db = path("huge.sqlite");
  std::string output;
  const int rc =
      test::run_sawyer("batch " + test::quoted(path("manifest_huge.csv")) + " -o " +
                           test::quoted(out) + " --db " + test::quoted(db) + " -- --threads 1",
                       &output);
  EXPECT_EQ(rc, 0) << output;
  std::map<std::string, std::string> st;
  read_statuses(out, &st);
  EXPECT_EQ(st, (std::map<std::string, std::string>{{"BIG", "not_sawn"}})) << output;
  const std::string csv = read(out / "batch_0.csv");
  EXPECT_NE(csv.find(",not_sawn,4,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("does not fit"), std::string::npos) << csv;
  EXPECT_NE(output.find("BIG NOT SAWN"), std::string::npos) << output;
  EXPECT_NE(output.find("0 ok (0 with QA warnings), 1 not sawn, 0 failed of 1"), std::string::npos)
      << output;
  EXPECT_TRUE(fs::exists(out / "BIG" / "scan" / "log.json"));
  EXPECT_TRUE(fs::exists(out / "BIG" / "report" / "report.pdf"));
  EXPECT_FALSE(fs::exists(out / "BIG" / "sawing.json"));
}

// --pattern-set after -- reaches every `sawyer run` like any run option; a row's own pattern (or
// pattern_set) replaces it for that log; the CSV's pattern column says what each log was sawn
// with (the one chosen from the set, from the register).
TEST_F(BatchEndToEnd, APatternSetIsPassedThroughAndTheTableShowsTheChosenPattern) {
  test::write_file(path("short_set.json"), R"({"format": "sawyer-pattern-set/1", "name": "short",
    "classes": [{"min_diameter_mm": 100, "max_diameter_mm": 500, "patterns": [
      {"preset": "2ex", "name": "2ex 50x100 short", "centre_width_mm": 100,
       "wane": {"min_length_mm": 200, "length_step_mm": 100}},
      {"preset": "2ex", "name": "2ex 50x150 short",
       "wane": {"min_length_mm": 200, "length_step_mm": 100}}]}]})");
  test::write_file(path("manifest_set.csv"),
                   "ct,id,species,pattern,pattern_set\n"
                   "scans/log_s1,S1,spruce,,\n"
                   "scans/log_s2,S2,spruce,tt,\n");
  const fs::path out = path("out_set"), db = path("set.sqlite");
  std::string output;
  const int rc =
      test::run_sawyer("batch " + test::quoted(path("manifest_set.csv")) + " -o " +
                           test::quoted(out) + " --db " + test::quoted(db) + " -- --pattern-set " +
                           test::quoted(path("short_set.json")) + " --threads 1",
                       &output);
  ASSERT_EQ(rc, 0) << output;
  std::istringstream in(read(out / "batch_0.csv"));
  std::string line;
  std::getline(in, line);
  ASSERT_EQ(line, "id,ct,status,exit_code,seconds,value,pattern,error");
  std::map<std::string, std::string> pattern;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::istringstream ls(line);
    for (std::string cell; std::getline(ls, cell, ',');) cells.push_back(cell);
    ASSERT_GE(cells.size(), 7u) << line;
    // These coarse test scans fail their QA verdict (exit 3): sawn and registered all the same.
    EXPECT_TRUE(cells[2] == "ok" || cells[2] == "qa_warnings") << line;
    pattern[cells[0]] = cells[6];
  }
  EXPECT_TRUE(pattern["S1"] == "2ex 50x100 short" || pattern["S1"] == "2ex 50x150 short")
      << pattern["S1"];
  EXPECT_EQ(pattern["S2"].rfind("through-and-through", 0), 0u) << pattern["S2"];
  // S1's run was given the set, S2's the row's pattern only.
  EXPECT_NE(read(out / "S1" / "run.json").find("\"pattern_set\""), std::string::npos);
  EXPECT_EQ(read(out / "S2" / "run.json").find("\"pattern_set\""), std::string::npos);

  // A row may not give both.
  test::write_file(path("manifest_both.csv"),
                   "ct,id,pattern,pattern_set\nscans/log_s1,S1,tt,nordic\n");
  EXPECT_EQ(test::run_sawyer("batch " + test::quoted(path("manifest_both.csv")) + " -o " +
                                 test::quoted(path("out_both")) + " --no-register",
                             &output),
            1);
  EXPECT_NE(output.find("both a pattern and a pattern_set"), std::string::npos) << output;
}

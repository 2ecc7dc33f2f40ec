// Reliability of the command line as a whole (issue 18): an output never destroys what is not
// Sawyer's own, interrupted and concurrent runs leave nothing behind, the register is never a
// stub, and the exit codes keep their contract (README, "Exit codes"). The limits on input values
// have their own tests beside each reader (ct_limits_test, limits_model_test).
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "sawyer/core/output_guard.h"
#include "sawyer/test/test_util.h"

using namespace sawyer;
namespace fs = std::filesystem;

namespace {

// 40 cm of the real spruce log at 0.8 mm pixels (the same cached scan as run_cli_test).
fs::path small_ct() { return test::gran1_40cm_ct(); }

// 2ex with boards kept from 200 mm: the test log is short.
fs::path short_pattern(const fs::path& dir) {
  const fs::path p = dir / "short_2ex.json";
  test::write_file(p, R"({"format": "sawyer-pattern/1", "name": "2ex short",
    "wane": {"min_length_mm": 200, "length_step_mm": 100},
    "boards": [
      {"name": "centre 1", "u_mm": -26.5, "v_mm": 0, "thickness_mm": 50, "width_mm": 150},
      {"name": "centre 2", "u_mm": 26.5, "v_mm": 0, "thickness_mm": 50, "width_mm": 150}]})");
  return p;
}

std::string run_args(const fs::path& ct, const fs::path& out, const fs::path& dir) {
  return "run " + test::quoted(ct) + " -o " + test::quoted(out) + " --pattern " +
         test::quoted(short_pattern(dir)) + " --no-register -q";
}

// Every file below `dir` with its size, to show a folder came through untouched.
std::vector<std::string> listing(const fs::path& dir) {
  std::vector<std::string> v;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    v.push_back(e.path().lexically_relative(dir).string() + ":" +
                (e.is_regular_file() ? std::to_string(e.file_size()) : "dir"));
  std::sort(v.begin(), v.end());
  return v;
}

// Hidden temporary or lock siblings of `name` in `dir`.
std::vector<std::string> leftovers(const fs::path& dir, const std::string& name) {
  std::vector<std::string> v;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string n = e.path().filename().string();
    if (n.starts_with("." + name + ".")) v.push_back(n);
  }
  return v;
}

bool mentions(const std::string& out, const std::string& what) {
  return out.find(what) != std::string::npos;
}

// A copy of the test scan that a test may lose without harm to the others.
fs::path copy_of_scan(const fs::path& dir) {
  const fs::path ct = dir / "ct";
  fs::copy(small_ct(), ct, fs::copy_options::recursive);
  return ct;
}

}  // namespace

// --- data loss -------------------------------------------------------------------------------

TEST(DataLoss, RunNeverWritesOverItsInputOrAroundIt) {
  test::TempDir dir;
  const fs::path ct = copy_of_scan(dir.path());
  const std::vector<std::string> before = listing(ct);
  std::string out;
  // -o the scan itself, the folder holding it, a folder inside it.
  for (const fs::path& o : {ct, dir.path(), ct / "sub"}) {
    EXPECT_EQ(test::run_sawyer(run_args(ct, o, dir.path()), &out), 1) << o << "\n" << out;
    EXPECT_TRUE(mentions(out, "-o ")) << out;
    EXPECT_TRUE(mentions(out, "input")) << out;
  }
  EXPECT_EQ(listing(ct), before) << "the scan folder changed";
  EXPECT_FALSE(fs::exists(ct / "sub"));
}

TEST(DataLoss, RunNeverReplacesAForeignFolderOrAFile) {
  test::TempDir dir;
  const fs::path thesis = dir / "thesis";
  test::write_file(thesis / "chapter1.tex", "three years of work\n");
  test::write_file(dir / "notes.txt", "do not lose\n");
  std::string out;
  EXPECT_EQ(test::run_sawyer(run_args(small_ct(), thesis, dir.path()), &out), 1) << out;
  EXPECT_TRUE(mentions(out, "thesis") && mentions(out, "not empty")) << out;
  EXPECT_EQ(test::run_sawyer(run_args(small_ct(), dir / "notes.txt", dir.path()), &out), 1) << out;
  EXPECT_TRUE(mentions(out, "notes.txt") && mentions(out, "is a file")) << out;
  std::ifstream a(thesis / "chapter1.tex"), b(dir / "notes.txt");
  std::string la, lb;
  std::getline(a, la);
  std::getline(b, lb);
  EXPECT_EQ(la, "three years of work");
  EXPECT_EQ(lb, "do not lose");
  EXPECT_EQ(leftovers(dir.path(), "thesis"), std::vector<std::string>{});
}

TEST(DataLoss, RunWritesAnEmptyFolderAndReplacesItsOwnRunFolder) {
  test::TempDir dir;
  const fs::path o = dir / "out";
  fs::create_directories(o);
  std::string out;
  ASSERT_EQ(test::run_sawyer(run_args(small_ct(), o, dir.path()), &out), 0) << out;
  ASSERT_TRUE(fs::exists(o / "run.json"));
  EXPECT_TRUE(is_sawyer_output(o, OutputKind::kRunFolder));
  ASSERT_EQ(test::run_sawyer(run_args(small_ct(), o, dir.path()), &out), 0) << out;
  EXPECT_EQ(leftovers(dir.path(), "out"), std::vector<std::string>{});
}

TEST(DataLoss, ScanPhantomAndConvertNeverReplaceAFileOrAForeignFolder) {
  test::TempDir dir;
  const fs::path file = dir / "precious.dat";
  test::write_file(file, "precious\n");
  const fs::path foreign = dir / "foreign";
  test::write_file(foreign / "a.txt", "a\n");
  const std::string log = test::quoted(test::sample_log("pine_8") / "log.json");
  const std::vector<std::string> commands = {
      "scan " + test::quoted(small_ct()) + " -o ",
      "phantom " + log + " --size 64 --pixel-mm 5 --from-mm 0 --to-mm 50 -o ",
      "convert " + log + " --format published -o ",
      "convert " + log + " --format float -o ",
  };
  for (const std::string& c : commands) {
    for (const fs::path& o : {file, foreign}) {
      std::string out;
      EXPECT_EQ(test::run_sawyer(c + test::quoted(o), &out), 1) << c << o << "\n" << out;
      EXPECT_TRUE(mentions(out, o.filename().string())) << out;
    }
  }
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "precious");
  EXPECT_EQ(listing(foreign), std::vector<std::string>{"a.txt:2"});
}

TEST(DataLoss, FileOutputsNeverReplaceTheirInputAFolderOrAFifo) {
  test::TempDir dir;
  const fs::path log = dir / "log.json";
  fs::copy_file(test::sample_log("pine_8") / "log.json", log);
  const auto size = fs::file_size(log);
  std::string out;
  EXPECT_EQ(test::run_sawyer("convert " + test::quoted(log) + " -o " + test::quoted(log), &out), 1)
      << out;
  EXPECT_TRUE(mentions(out, "is the input")) << out;
  EXPECT_EQ(test::run_sawyer("saw " + test::quoted(log) + " -o " + test::quoted(log), &out), 1)
      << out;
  EXPECT_TRUE(mentions(out, "is the input")) << out;
  EXPECT_EQ(fs::file_size(log), size);
  fs::create_directories(dir / "folder.json");
  EXPECT_EQ(test::run_sawyer("generate --seed 3 -o " + test::quoted(dir / "folder.json"), &out), 1)
      << out;
  EXPECT_TRUE(mentions(out, "is a folder")) << out;
  const fs::path fifo = dir / "pipe.json";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  EXPECT_EQ(test::run_sawyer("generate --seed 3 -o " + test::quoted(fifo), &out), 1) << out;
  EXPECT_TRUE(mentions(out, "not a regular file")) << out;
  EXPECT_TRUE(fs::is_fifo(fifo));
  // A regular file that is not an input may be replaced: that is what a file output is for.
  EXPECT_EQ(test::run_sawyer("generate --seed 3 -o " + test::quoted(dir / "new.json"), &out), 0)
      << out;
  EXPECT_EQ(test::run_sawyer("generate --seed 4 -o " + test::quoted(dir / "new.json"), &out), 0)
      << out;
}

TEST(DataLoss, BatchRefusesReservedIdsAndForeignFolders) {
  test::TempDir dir;
  for (const std::string id : {"logs", "batch_0.csv"}) {
    test::write_file(dir / "m.csv", "ct,id\n" + small_ct().string() + ",good\n" +
                                        small_ct().string() + "," + id + "\n");
    std::string out;
    EXPECT_EQ(test::run_sawyer("batch " + test::quoted(dir / "m.csv") + " -o " +
                                   test::quoted(dir / "b") + " --no-register",
                               &out),
              1)
        << out;
    EXPECT_TRUE(mentions(out, "'" + id + "'") && mentions(out, "reserved")) << out;
    EXPECT_FALSE(fs::exists(dir / "b")) << "nothing may be started for a refused manifest";
  }
  test::write_file(dir / "m.csv", "ct,id\n" + small_ct().string() + ",good\n");
  test::write_file(dir / "home" / "thesis.tex", "x\n");
  std::string out;
  EXPECT_EQ(test::run_sawyer("batch " + test::quoted(dir / "m.csv") + " -o " +
                                 test::quoted(dir / "home") + " --no-register",
                             &out),
            1)
      << out;
  EXPECT_TRUE(mentions(out, "not empty")) << out;
  EXPECT_EQ(listing(dir / "home"), std::vector<std::string>{"thesis.tex:2"});
}

// --- interrupted and concurrent runs ---------------------------------------------------------

namespace {

// Runs a shell script (written to a file, so that its $variables reach the shell that runs it)
// under `timeout`, in `dir`; returns what it printed.
std::string run_script(const fs::path& dir, const std::string& script) {
  const fs::path file = dir / "script.sh";
  test::write_file(file, script + "\n");
  std::string out;
  test::run_command("timeout 300 sh " + test::quoted(file), &out);
  fs::remove(file);
  return out;
}

// Starts `sawyer <args>` in the background, waits (at most `wait_s`) until a hidden temporary
// sibling of `name` appears in `dir`, sends `signal`, and returns the shell's report:
// "rc=<exit code> seen=<1 if the temporary was seen before the signal>". Bounded in time by
// construction (the wait loop ends when the process does, and `timeout` caps the whole).
std::string interrupt_while_writing(const std::string& args, const fs::path& dir,
                                    const std::string& name, const std::string& signal,
                                    int wait_s = 120) {
  const std::string script = "cd " + test::quoted(dir) + "; \"" + test::sawyer_bin() + "\" " +
                             args +
                             " >/dev/null 2>&1 & p=$!; seen=0; i=0; "
                             "while kill -0 $p 2>/dev/null && [ $i -lt " +
                             std::to_string(wait_s * 500) +
                             " ]; do "
                             "  if ls -A | grep -q '^\\." +
                             name +
                             "\\.tmp'; then seen=1; break; fi; "
                             "  sleep 0.002; i=$((i+1)); done; "
                             "kill -" +
                             signal + " $p 2>/dev/null; wait $p; echo rc=$? seen=$seen";
  return run_script(dir, script);
}

}  // namespace

TEST(Interrupt, SigintWhilePhantomWritesLeavesNothing) {
  test::TempDir dir;
  const std::string args = "phantom " + test::quoted(test::sample_log("pine_8") / "log.json") +
                           " --size 256 --pixel-mm 1.6 --from-mm 0 --to-mm 3000 -o ph";
  const std::string r = interrupt_while_writing(args, dir.path(), "ph", "INT");
  ASSERT_TRUE(mentions(r, "seen=1")) << r;
  EXPECT_TRUE(mentions(r, "rc=130")) << r;
  EXPECT_FALSE(fs::exists(dir / "ph"));
  EXPECT_EQ(leftovers(dir.path(), "ph"), std::vector<std::string>{});
}

TEST(Interrupt, SigtermWhileRunWritesItsReportLeavesNothing) {
  test::TempDir dir;
  short_pattern(dir.path());
  // The run folder exists under its temporary name while the report is drawn (about a second);
  // three tries make catching it near certain even on a fast machine.
  std::string r;
  for (int attempt = 0; attempt < 3; ++attempt) {
    const std::string args =
        "run " + test::quoted(small_ct()) + " -o out --no-register -q --pattern short_2ex.json";
    r = interrupt_while_writing(args, dir.path(), "out", "TERM");
    if (mentions(r, "seen=1")) break;
    fs::remove_all(dir / "out");
  }
  ASSERT_TRUE(mentions(r, "seen=1")) << r;
  EXPECT_TRUE(mentions(r, "rc=143")) << r;
  EXPECT_FALSE(fs::exists(dir / "out"));
  EXPECT_EQ(leftovers(dir.path(), "out"), std::vector<std::string>{});
}

TEST(Interrupt, StaleTemporariesOfAKilledRunAreSweptByTheNextRun) {
  test::TempDir dir;
  // What a SIGKILLed run and a killed folder swap leave, and things that only look alike.
  fs::create_directories(dir / ".out.tmp5a3c9e01d2" / "scan");
  test::write_file(dir / ".out.tmp5a3c9e01d2" / "run.json", "{}");
  fs::create_directories(dir / ".out.tmp77ab.old");
  test::write_file(dir / ".out.tmpnothex", "keep");
  test::write_file(dir / ".output.tmp12", "keep");
  std::string out;
  ASSERT_EQ(test::run_sawyer(run_args(small_ct(), dir / "out", dir.path()), &out), 0) << out;
  std::vector<std::string> left = leftovers(dir.path(), "out");
  std::sort(left.begin(), left.end());
  EXPECT_EQ(left, std::vector<std::string>{".out.tmpnothex"});
  EXPECT_TRUE(fs::exists(dir / ".output.tmp12"));
}

TEST(Concurrency, ASecondRunOfTheSameOutputIsRefusedAtOnce) {
  test::TempDir dir;
  short_pattern(dir.path());
  const std::string first = "\"" + test::sawyer_bin() + "\" run " + test::quoted(small_ct()) +
                            " -o out --no-register -q --pattern short_2ex.json";
  // The first run holds .out.lock for its whole length (the scan takes a second or more); the
  // second starts once the lock is there.
  const std::string script =
      "cd " + test::quoted(dir.path()) + "; " + first +
      " >first.log 2>&1 & p=$!; i=0; "
      "while [ ! -e .out.lock ] && kill -0 $p 2>/dev/null && [ $i -lt 30000 ]; do "
      "sleep 0.002; i=$((i+1)); done; "
      "[ -e .out.lock ] && echo locked; " +
      first + " 2>&1; echo second_rc=$?; wait $p; echo first_rc=$?";
  const std::string out = run_script(dir.path(), script);
  ASSERT_TRUE(mentions(out, "locked")) << out;
  EXPECT_TRUE(mentions(out, "second_rc=1")) << out;
  EXPECT_TRUE(mentions(out, "is being written by another Sawyer process")) << out;
  EXPECT_TRUE(mentions(out, "first_rc=0")) << out;
  EXPECT_TRUE(fs::exists(dir / "out" / "run.json"));
  EXPECT_EQ(leftovers(dir.path(), "out"), std::vector<std::string>{}) << "the lock is removed";
}

// --- the register ----------------------------------------------------------------------------

TEST(Register, NoHomeMeansNoRegisterInTheCurrentFolder) {
  test::TempDir dir;
  std::string out;
  const int rc = test::run_command("cd " + test::quoted(dir.path()) +
                                       " && env -u HOME -u SAWYER_DB -u XDG_DATA_HOME \"" +
                                       test::sawyer_bin() + "\" logs",
                                   &out);
  EXPECT_EQ(rc, 1) << out;
  EXPECT_TRUE(mentions(out, "HOME") && mentions(out, "--db") && mentions(out, "SAWYER_DB")) << out;
  EXPECT_TRUE(fs::is_empty(dir.path())) << "nothing may be created in the current folder";
}

TEST(Register, AFailedCreateLeavesNoStub) {
  test::TempDir dir;
  const fs::path db = dir / "reg.sqlite";
  std::string out;
  // A file size limit of 0 makes every write fail, as a full disk does; SIGXFSZ is ignored so
  // the write returns an error instead of killing the process.
  // `sawyer run` creates a new register only when it writes the log's row, last: the run fails
  // writing its folder, and leaves neither folder nor register.
  const int rc = test::run_command("trap '' XFSZ; ulimit -f 0; \"" + test::sawyer_bin() +
                                       "\" run " + test::quoted(small_ct()) + " -o " +
                                       test::quoted(dir / "out") + " -q --db " + test::quoted(db),
                                   &out);
  EXPECT_EQ(rc, 1) << out;
  EXPECT_FALSE(fs::exists(db)) << "a stub register was left behind";
  EXPECT_FALSE(fs::exists(dir / "reg.sqlite-wal"));
  EXPECT_FALSE(fs::exists(dir / "out"));
  // And the same path works once the disk has room (a merge makes the register; that a merge
  // which cannot make it leaves nothing is register_test's).
  ASSERT_EQ(
      test::run_sawyer("run " + test::quoted(small_ct()) + " -o " + test::quoted(dir / "out") +
                           " --pattern " + test::quoted(short_pattern(dir.path())) + " -q --db " +
                           test::quoted(dir / "src.sqlite"),
                       &out),
      0)
      << out;
  EXPECT_EQ(test::run_sawyer("logs --merge " + test::quoted(dir / "src.sqlite") + " --db " +
                                 test::quoted(dir / "new" / "reg.sqlite"),
                             &out),
            0)
      << out;
  EXPECT_TRUE(fs::exists(dir / "new" / "reg.sqlite"));
}

// --- exit codes ------------------------------------------------------------------------------

TEST(ExitCodes, CommandLineErrorsExitOneHelpExitsZero) {
  std::string out;
  for (const std::string args :
       {"", "frobnicate", "run", "saw --rot-step x a.json -o b.json", "info --no-such-option x",
        "generate --length-m x -o x.json", "scan ct -o out --threads 100000",
        "batch m.csv -o b --jobs 0", "run ct -o out --threads -1"}) {
    EXPECT_EQ(test::run_sawyer(args, &out), 1) << "sawyer " << args << "\n" << out;
    EXPECT_FALSE(out.empty()) << "sawyer " << args << " said nothing";
  }
  EXPECT_EQ(test::run_sawyer("--help", &out), 0) << out;
  EXPECT_EQ(test::run_sawyer("run --help", &out), 0) << out;
  EXPECT_EQ(test::run_sawyer("--version", &out), 0) << out;
}

// --- issue 44: refusals leave nothing, parse errors in Sawyer's words, long names -----------

// Runs the sawyer binary with `args`; returns the exit code and its stderr alone in *err.
int run_stderr(const std::string& args, std::string* err) {
  // run_command adds its own 2>&1 after the command: the group's stderr is sawyer's.
  return test::run_command("( \"" + test::sawyer_bin() + "\" " + args + " 2>&1 >/dev/null )", err);
}

TEST(Leftovers, ARunRefusedBeforeItStartsLeavesNoRegister) {
  test::TempDir dir;
  test::write_file(dir / "notes.txt", "mine\n");
  fs::create_directories(dir / "empty_ct");
  const std::vector<std::string> before = listing(dir.path());
  const std::string db = " -q --db " + test::quoted(dir / "reg" / "logs.sqlite");
  std::string out;
  // No scan there; an output that is a file of the user's; a pattern that does not exist.
  for (const std::string& args :
       {"run " + test::quoted(dir / "empty_ct") + " -o " + test::quoted(dir / "out") + db,
        "run " + test::quoted(small_ct()) + " -o " + test::quoted(dir / "notes.txt") + db,
        "run " + test::quoted(small_ct()) + " -o " + test::quoted(dir / "out") + " --pattern " +
            test::quoted(dir / "none.json") + db}) {
    EXPECT_EQ(test::run_sawyer(args, &out), 1) << args << "\n" << out;
    EXPECT_EQ(listing(dir.path()), before) << args << "\n" << out;
  }
  // The default register ($HOME/.local/share/sawyer/logs.sqlite) is not created either.
  fs::create_directories(dir / "home");
  EXPECT_EQ(test::run_command(
                "env -u SAWYER_DB -u XDG_DATA_HOME HOME=" + test::quoted(dir / "home") + " \"" +
                    test::sawyer_bin() + "\" run " + test::quoted(dir / "empty_ct") + " -o " +
                    test::quoted(dir / "out") + " -q",
                &out),
            1)
      << out;
  EXPECT_TRUE(fs::is_empty(dir / "home")) << "no ~/.local/share/sawyer";
  // A register that cannot be made is refused before the scan, naming it.
  EXPECT_EQ(
      test::run_sawyer("run " + test::quoted(small_ct()) + " -o " + test::quoted(dir / "out") +
                           " -q --db " + test::quoted(dir / "notes.txt" / "logs.sqlite"),
                       &out),
      1);
  EXPECT_TRUE(mentions(out, "logs.sqlite: cannot be created")) << out;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(Leftovers, MergingACorruptRegisterLeavesNoMergedFile) {
  test::TempDir dir;
  test::write_file(dir / "corrupt.sqlite", std::string("SQLite format 3") + std::string(4000, 'x'));
  test::write_file(dir / "text.sqlite", "not a database at all\n");
  const std::vector<std::string> before = listing(dir.path());
  std::string out;
  for (const char* bad : {"corrupt.sqlite", "text.sqlite", "missing.sqlite"}) {
    EXPECT_EQ(test::run_sawyer("logs --merge " + test::quoted(dir / bad) + " --db " +
                                   test::quoted(dir / "merged" / "all.sqlite"),
                               &out),
              1)
        << bad << ": " << out;
    EXPECT_TRUE(mentions(out, bad)) << out;
    EXPECT_EQ(listing(dir.path()), before) << bad << ": " << out;
  }
}

TEST(Messages, ParseErrorsAreOneSawyerLineNamingTheOptionAndWhatItTakes) {
  struct Case {
    std::string args, names, takes;
  };
  for (const Case& c : std::vector<Case>{
           {"run ct -o out --threads 300", "--threads: 300", "0-256"},
           {"saw log.json -o s.json --threads 1.5", "--threads: '1.5'", "0-256"},
           {"saw log.json -o s.json --rot-step abc", "--rot-step: 'abc' is not a number",
            "rotation step"},
           {"batch m.csv -o b --jobs 0", "--jobs: 0", "1-256"},
           {"logs --limit -2", "--limit: -2", "0-"},
           {"run ct -o out --stem-step -1", "--stem-step: -1", "0-1000 mm"},
           {"convert a.json -o b --format x", "--format: 'x'", "log, published, float"},
           {"", "no command given", "info, convert"},
           {"frobnicate", "frobnicate: unknown command", "info, convert"},
           {"run", "run: input is missing", "CT scan"},
           {"saw log.json", "saw: -o/--output is missing", "sawing.json to write"},
           {"info --no-such-option x", "info: --no-such-option: unknown option", "--help"},
           {"info a b", "info: 'b': unexpected argument", "info takes input"},
           {"logs --merge", "--merge: needs a value", "registers"},
           {"logs --csv --json", "--csv: cannot be given with --json", "one of them"},
           {"logs --sort bogus", "--sort: unknown field 'bogus'", "scanned_at"},
           {"info ct --rescale-slope 1e9", "--rescale-slope: 1e9 is outside",
            "-100000 to 100000"}}) {
    std::string err;
    EXPECT_EQ(run_stderr(c.args, &err), 1) << c.args << "\n" << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << c.args << "\n" << err;
    EXPECT_EQ(err.rfind("sawyer: ", 0), 0u) << c.args << "\n" << err;
    EXPECT_TRUE(mentions(err, c.names)) << c.args << "\n" << err;
    EXPECT_TRUE(mentions(err, c.takes)) << c.args << "\n" << err;
    EXPECT_FALSE(mentions(err, "Run with --help")) << err;
    EXPECT_FALSE(mentions(err, "order by")) << err;
  }
}

TEST(Messages, ThreadsZeroMeansAllCoresAndTheHelpSaysSo) {
  std::string out;
  for (const char* cmd : {"run", "scan", "saw", "phantom"}) {
    EXPECT_EQ(test::run_sawyer(std::string(cmd) + " --help", &out), 0);
    EXPECT_TRUE(mentions(out, "0 (the default): all cores")) << cmd << "\n" << out;
  }
  test::TempDir dir;
  EXPECT_EQ(test::run_sawyer("saw " + test::quoted(test::sample_log("pine_8") / "log.json") +
                                 " --threads 0 -o " + test::quoted(dir / "s.json"),
                             &out),
            0)
      << out;
  EXPECT_TRUE(fs::exists(dir / "s.json"));
}

TEST(LongNames, AnOutputNameUpToTheFileSystemLimitIsWritten) {
  test::TempDir dir;
  std::string out;
  // A 250-byte file name (the temporary's ".<name>.tmp<hex>" would be 271) and a 255-byte one;
  // a 250-byte folder name for the writers that stage a folder beside it.
  const std::string name250 = std::string(245, 'l') + ".json";
  const std::string name255 = std::string(250, 'k') + ".json";
  const std::string log = test::quoted(test::sample_log("pine_8") / "log.json");
  for (const std::string& name : {name250, name255}) {
    EXPECT_EQ(test::run_sawyer("saw " + log + " -q -o " + test::quoted(dir / name), &out), 0)
        << out;
    EXPECT_TRUE(fs::is_regular_file(dir / name)) << name.size();
    // Written again over its own output (the lock and the temporaries fit as well).
    EXPECT_EQ(test::run_sawyer("convert " + log + " -o " + test::quoted(dir / name), &out), 0)
        << out;
  }
  const std::string folder = std::string(250, 'm');
  EXPECT_EQ(test::run_sawyer("convert " + log + " -o " + test::quoted(dir / folder), &out), 0)
      << out;
  EXPECT_TRUE(fs::exists(dir / folder / "sawyer_maps.json")) << out;
  for (const auto& e : fs::directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename().string()[0] == '.', false) << "left behind: " << e.path();
}

// --- messages and hangs ----------------------------------------------------------------------

TEST(Messages, ABinaryManifestIsRefusedWithoutEchoingItsBytes) {
  test::TempDir dir;
  std::string bytes = "ct,id\n";
  for (int i = 0; i < 256; ++i) bytes.push_back(static_cast<char>(i));
  test::write_file(dir / "m.csv", bytes);
  test::write_file(dir / "latin1.csv", "ct,id\nscans/k\xF6rv,x\n");
  for (const char* name : {"m.csv", "latin1.csv"}) {
    std::string out;
    EXPECT_EQ(test::run_sawyer("batch " + test::quoted(dir / name) + " -o " +
                                   test::quoted(dir / "b") + " --no-register",
                               &out),
              1)
        << out;
    EXPECT_TRUE(mentions(out, std::string(name) + ":2:")) << out;
    for (unsigned char c : out)
      EXPECT_TRUE(c == '\n' || (c >= 0x20 && c < 0x7F)) << "raw byte in the message: " << out;
  }
}

TEST(Hangs, DevicesAndFifosAreNotReadAsFiles) {
  test::TempDir dir;
  const fs::path fifo = dir / "manifest.csv";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  // Without the check both would block or read forever; `timeout` bounds the test either way.
  for (const std::string input : {std::string("/dev/zero"), fifo.string()}) {
    std::string out;
    const int rc = test::run_command("timeout 60 \"" + test::sawyer_bin() + "\" batch " +
                                         test::quoted(input) + " -o " + test::quoted(dir / "b"),
                                     &out);
    EXPECT_EQ(rc, 1) << input << ": " << out;
    EXPECT_TRUE(mentions(out, "expected a regular file")) << out;
  }
}

// --- invented slices are stated -------------------------------------------------------------

TEST(InventedSlices, RunStatesTheResamplingInItsSummaryRunJsonAndReport) {
  test::TempDir dir;
  // Three slices left out at random: few enough to be resampled (not refused), and then said.
  const fs::path ct = test::cached_phantom(
      "gran1_40cm_08_dropped", test::quoted(test::sample_log("gran1_spruce") / "log.json") +
                                   " --from-mm 1000 --to-mm 1400 --size 480 --pixel-mm 0.8"
                                   " --seed 5 --drop-slices 3");
  std::string out;
  ASSERT_EQ(test::run_sawyer(run_args(ct, dir / "out", dir.path()), &out), 0) << out;
  EXPECT_TRUE(mentions(out, "note: resampled along z")) << out;
  EXPECT_TRUE(mentions(out, "3 invented")) << out;
  std::ifstream rj(dir / "out" / "run.json");
  const std::string run_json((std::istreambuf_iterator<char>(rj)),
                             std::istreambuf_iterator<char>());
  EXPECT_TRUE(mentions(run_json, "\"invented_slices\": 3")) << run_json;
  EXPECT_TRUE(mentions(run_json, "resampled along z")) << run_json;
  ASSERT_EQ(test::run_command(
                "pdftotext " + test::quoted(dir / "out" / "report" / "report.pdf") + " -", &out),
            0);
  EXPECT_TRUE(mentions(out, "Scan: resampled along z")) << out;
  // And a scan with every slice in place says nothing of the kind.
  ASSERT_EQ(test::run_sawyer(run_args(small_ct(), dir / "out2", dir.path()), &out), 0) << out;
  EXPECT_FALSE(mentions(out, "resampled")) << out;
}

TEST(Interrupt, ABatchTimeoutLeavesNoTemporaryOutput) {
  test::TempDir dir;
  short_pattern(dir.path());
  // One log's run takes over a second (scan 0.3 s, saw, then the report in its temporary
  // folder); 0.7 s stops it, by SIGTERM, most likely while the report is drawn.
  test::write_file(dir / "m.csv", "ct,id,pattern\n" + small_ct().string() + ",slow," +
                                      (dir / "short_2ex.json").string() + "\n");
  std::string out;
  EXPECT_EQ(test::run_sawyer("batch " + test::quoted(dir / "m.csv") + " -o " +
                                 test::quoted(dir / "b") + " --no-register --timeout 0.7",
                             &out),
            2)
      << out;
  EXPECT_TRUE(mentions(out, "slow FAILED")) << out;
  EXPECT_FALSE(fs::exists(dir / "b" / "slow"));
  EXPECT_EQ(leftovers(dir / "b", "slow"), std::vector<std::string>{});
}

TEST(DataLoss, ABatchFolderIsRecognisedByItsOwnFilesOnly) {
  test::TempDir dir;
  // A user's folder with a logs/ of its own is not a batch folder.
  test::write_file(dir / "project" / "logs" / "field_notes.txt", "notes\n");
  test::write_file(dir / "m.csv", "ct,id\n" + small_ct().string() + ",good\n");
  std::string out;
  EXPECT_EQ(test::run_sawyer("batch " + test::quoted(dir / "m.csv") + " -o " +
                                 test::quoted(dir / "project") + " --no-register",
                             &out),
            1)
      << out;
  EXPECT_TRUE(mentions(out, "not empty")) << out;
  EXPECT_EQ(listing(dir / "project"),
            (std::vector<std::string>{"logs/field_notes.txt:6", "logs:dir"}));
  // A manifest kept in the batch's own folder is fine: the batch never replaces the folder.
  test::write_file(dir / "b" / "m.csv", "ct,id\n" + small_ct().string() + ",good\n");
  fs::create_directories(dir / "b" / "logs");
  test::write_file(dir / "b" / "logs" / "old.err", "");
  EXPECT_TRUE(is_sawyer_output(dir / "b", OutputKind::kBatchFolder));
  EXPECT_FALSE(is_sawyer_output(dir / "project", OutputKind::kBatchFolder));
}

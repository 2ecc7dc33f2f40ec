// The deployment files in deploy/: the Kubernetes Indexed Job checked against the Kubernetes API
// schema (tools/k8s: kubernetes-models, the batch/v1 Job schema compiled from the API's OpenAPI
// document), and broken copies of it rejected with a message naming the field. The Slurm job
// array runs on a real one-node cluster in deploy/slurm/test_local_slurm.sh (root only;
// docs/batch.md).
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>

#include "sawyer/test/test_util.h"

namespace fs = std::filesystem;
namespace test = sawyer::test;

namespace {

const fs::path& tools() {
  static const fs::path p = test::source_dir() / "tools" / "k8s";
  return p;
}
fs::path job_yaml() { return test::source_dir() / "deploy" / "k8s" / "sawyer-batch-job.yaml"; }

// Empty when the validator can run, else why not (the test then skips).
std::string validator_missing() {
  std::string out;
  if (test::run_command("command -v node >/dev/null 2>&1", &out) != 0)
    return "node not installed (scripts/install_deps.sh)";
  if (!fs::exists(tools() / "node_modules" / "kubernetes-models"))
    return "kubernetes-models not installed: npm ci --prefix " + tools().string();
  return "";
}

int validate(const fs::path& file, std::string* out) {
  return test::run_command(
      "node " + test::quoted(tools() / "validate.mjs") + " " + test::quoted(file), out);
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// `text` with the first `from` replaced by `to` (the test fails if `from` is not there, so a
// change to the manifest cannot silently turn the broken copy into the original).
std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "'" << from << "' is no longer in the manifest";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

}  // namespace

TEST(K8sManifest, TheIndexedJobIsAValidBatchV1Job) {
  if (const std::string why = validator_missing(); !why.empty()) GTEST_SKIP() << why;
  std::string out;
  EXPECT_EQ(validate(job_yaml(), &out), 0) << out;
  EXPECT_NE(out.find(": 1 documents valid"), std::string::npos) << out;
}

// A wrong type, a value outside an enum and a missing required field are each rejected, the
// message naming the field by its path in the manifest.
TEST(K8sManifest, BrokenCopiesAreRejectedNamingTheField) {
  if (const std::string why = validator_missing(); !why.empty()) GTEST_SKIP() << why;
  const std::string yaml = read_text(job_yaml());
  ASSERT_FALSE(yaml.empty()) << job_yaml();
  struct Case {
    std::string from, to, expect;
  };
  const Case cases[] = {
      {"completions: 8", "completions: eight", "/spec/completions must be integer"},
      {"completionMode: Indexed", "completionMode: Numbered",
       "/spec/completionMode must be equal to one of the allowed values"},
      {"- name: sawyer\n", "- nam: sawyer\n",
       "/spec/template/spec/containers/0 must have required property name"},
      {"backoffLimit: 3", "backoffLimit: [3]", "/spec/backoffLimit must be integer"},
  };
  test::TempDir dir;
  for (const Case& c : cases) {
    const fs::path bad = dir / "bad.yaml";
    test::write_file(bad, replaced(yaml, c.from, c.to));
    std::string out;
    EXPECT_EQ(validate(bad, &out), 1) << c.to << "\n" << out;
    EXPECT_NE(out.find(bad.string() + ": doc 1 (Job sawyer-batch): " + c.expect), std::string::npos)
        << c.to << "\n"
        << out;
  }
}

// A kind the schemas do not have is refused (exit 2), not passed as valid.
TEST(K8sManifest, AnUnknownKindIsRefused) {
  if (const std::string why = validator_missing(); !why.empty()) GTEST_SKIP() << why;
  test::TempDir dir;
  test::write_file(dir / "k.yaml", "apiVersion: batch/v1\nkind: Jobb\nmetadata: {name: x}\n");
  std::string out;
  EXPECT_EQ(validate(dir / "k.yaml", &out), 2) << out;
  EXPECT_NE(out.find("kind \"Jobb\" is not in batch/v1"), std::string::npos) << out;
}

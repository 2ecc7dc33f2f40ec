// A plain main() for the fuzz targets, so that the test suite runs them without libFuzzer (and
// with GCC): every file of the given seed folders goes through the target's
// LLVMFuzzerTestOneInput, then a fixed number of mutations of them drawn from a fixed seed (bit
// flips, bytes set to edge values, cuts, repeated and inserted runs). The same run every time: a
// smoke test that the readers still refuse what the seeds and their near misses hold, not a
// search. scripts/fuzz.sh does the searching with libFuzzer.
//
//   fuzz_dicom_smoke [--mutations N] [--seed S] <seed folder>...
//
// A target reports a broken property by aborting; a crash or an escaped exception also fails.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

// xorshift64*: the same sequence on every platform.
struct Rng {
  std::uint64_t s;
  std::uint64_t next() {
    s ^= s >> 12;
    s ^= s << 25;
    s ^= s >> 27;
    return s * 2685821657736338717ULL;
  }
  std::size_t below(std::size_t n) { return n == 0 ? 0 : static_cast<std::size_t>(next() % n); }
};

std::vector<std::uint8_t> mutate(std::vector<std::uint8_t> b, Rng& rng) {
  static constexpr std::uint8_t kEdge[] = {0x00, 0x01, 0x7f, 0x80, 0xfe, 0xff};
  const int edits = 1 + static_cast<int>(rng.below(4));
  for (int e = 0; e < edits; ++e) {
    switch (rng.below(b.empty() ? 1 : 5)) {
      case 0: {  // insert a short run of random bytes
        const std::size_t at = rng.below(b.size() + 1), n = 1 + rng.below(8);
        std::vector<std::uint8_t> run(n);
        for (std::uint8_t& x : run) x = static_cast<std::uint8_t>(rng.next());
        b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), run.begin(), run.end());
        break;
      }
      case 1:  // flip a bit
        b[rng.below(b.size())] ^= static_cast<std::uint8_t>(1u << rng.below(8));
        break;
      case 2:  // a byte to an edge value
        b[rng.below(b.size())] = kEdge[rng.below(sizeof kEdge)];
        break;
      case 3:  // cut the tail
        b.resize(rng.below(b.size()));
        break;
      case 4: {  // repeat a run
        const std::size_t at = rng.below(b.size());
        const std::size_t n = 1 + rng.below(std::min<std::size_t>(64, b.size() - at));
        const std::vector<std::uint8_t> run(b.begin() + static_cast<std::ptrdiff_t>(at),
                                            b.begin() + static_cast<std::ptrdiff_t>(at + n));
        b.insert(b.begin() + static_cast<std::ptrdiff_t>(at + n), run.begin(), run.end());
        break;
      }
    }
  }
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  long mutations = 200;
  std::uint64_t seed = 20261203;
  std::vector<std::vector<std::uint8_t>> seeds;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--mutations" && i + 1 < argc) {
      mutations = std::strtol(argv[++i], nullptr, 10);
    } else if (a == "--seed" && i + 1 < argc) {
      seed = std::strtoull(argv[++i], nullptr, 10);
    } else {
      std::error_code ec;
      std::vector<std::filesystem::path> files;
      for (const auto& e : std::filesystem::directory_iterator(a, ec))
        if (e.is_regular_file()) files.push_back(e.path());
      if (ec || files.empty()) {
        std::fprintf(stderr, "%s: no seed files there (%s)\n", a.c_str(),
                     ec ? ec.message().c_str() : "empty folder");
        return 2;
      }
      std::sort(files.begin(), files.end());  // the same order on every file system
      for (const auto& f : files) {
        std::ifstream in(f, std::ios::binary);
        seeds.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
      }
    }
  }
  if (seeds.empty()) {
    std::fprintf(stderr, "usage: %s [--mutations N] [--seed S] <seed folder>...\n", argv[0]);
    return 2;
  }
  try {
    for (const auto& s : seeds) LLVMFuzzerTestOneInput(s.data(), s.size());
    Rng rng{seed | 1};
    for (long i = 0; i < mutations; ++i) {
      const std::vector<std::uint8_t> m = mutate(seeds[rng.below(seeds.size())], rng);
      LLVMFuzzerTestOneInput(m.data(), m.size());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "an exception escaped the target: %s\n", e.what());
    return 1;
  }
  std::printf("%zu seeds and %ld mutations: no crash, no broken property\n", seeds.size(),
              mutations);
  return 0;
}

// A Phantom behind the SliceSource interface, in memory, for benchmarks and tests that run the
// CT passes on phantoms without writing files. Slice i is the phantom's i-th kept slice.
//
//   PhantomSource src(*phantom, /*prerender=*/true);   // render every slice now
//   auto uniform = make_uniform_z(std::make_unique<PhantomSource>(...), {});  // fill drops
//
// prerender = true renders all slices up front (so reading them costs a copy: timing a pass
// then excludes rendering; memory: one float slice each); false renders on every read.
#pragma once

#include <string>
#include <vector>

#include "sawyer/ct/io/slice_source.h"
#include "sawyer/ct/phantom/phantom.h"

namespace sawyer::ct {

class PhantomSource final : public SliceSource {
 public:
  PhantomSource(const Phantom& phantom, bool prerender);
  Format format() const override { return Format::kDicom; }
  const VolumeGeometry& geometry() const override { return phantom_.geometry(); }
  std::string description() const override { return "phantom of " + phantom_.log().id; }
  const std::vector<std::string>& notes() const override { return notes_; }
  Status read(int i, Slice& out) override;

 private:
  const Phantom& phantom_;
  std::vector<Slice> slices_;
  std::vector<std::string> notes_;
};

}  // namespace sawyer::ct

// PhantomSource (see phantom_source.h).
#include "sawyer/ct/phantom/phantom_source.h"

namespace sawyer::ct {

PhantomSource::PhantomSource(const Phantom& phantom, bool prerender) : phantom_(phantom) {
  if (!prerender) return;
  Phantom::Renderer renderer(phantom);
  slices_.resize(phantom.kept().size());
  for (size_t i = 0; i < slices_.size(); ++i) renderer.render(phantom.kept()[i], slices_[i]);
}

Status PhantomSource::read(int i, Slice& out) {
  const int n = static_cast<int>(phantom_.kept().size());
  if (i < 0 || i >= n)
    return Error(description(),
                 "slice " + std::to_string(i) + " out of range 0.." + std::to_string(n - 1));
  out = slices_.empty() ? phantom_.render_slice(phantom_.kept()[static_cast<size_t>(i)])
                        : slices_[static_cast<size_t>(i)];
  out.index = i;
  return Status::Ok();
}

}  // namespace sawyer::ct

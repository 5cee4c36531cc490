#pragma once
// The node lists of a mesh's assembly elements (a Catmull–Clark face's 16 control points, a
// triangle's 3 vertices, a hinge's 4, a bending stencil's n), stored flat: element e has the
// nodes nodes()[start(e) … start(e + 1)). Element ids are 0 … size() − 1 in insertion order.
// A node may appear twice in one element (a boundary patch's phantom points); every user
// below handles that.
#include <cassert>
#include <cstddef>
#include <span>
#include <vector>

namespace twill {

class ElementNodes {
 public:
  /// Appends an element; returns its id.
  int add(std::span<const int> nodes) {
    nodes_.insert(nodes_.end(), nodes.begin(), nodes.end());
    start_.push_back(static_cast<int>(nodes_.size()));
    return size() - 1;
  }
  int size() const { return static_cast<int>(start_.size()) - 1; }
  std::span<const int> operator[](int element) const {
    assert(element >= 0 && element < size());
    const auto e = static_cast<std::size_t>(element);
    return {nodes_.data() + start_[e], static_cast<std::size_t>(start_[e + 1] - start_[e])};
  }
  std::size_t bytes() const { return (nodes_.capacity() + start_.capacity()) * sizeof(int); }

 private:
  std::vector<int> nodes_;
  std::vector<int> start_ = {0};
};

}  // namespace twill

// Union-find over part indices: which module parts are rigidly joined.
#pragma once

#include <algorithm>
#include <cstddef>
#include <numeric>
#include <vector>

namespace yamor::physics {

/// Disjoint sets over 0..n-1 with path halving; the smallest index of a set
/// is its root, so the grouping does not depend on the order of Union calls.
/// Thread-safety: a plain value; no internal synchronisation.
struct DisjointSets {
  /// n singleton sets.
  explicit DisjointSets(std::size_t n) : parent(n) {
    std::iota(parent.begin(), parent.end(), std::size_t{0});
  }
  /// Root of the set holding x.
  std::size_t Find(std::size_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  /// Merges the sets of a and b.
  void Union(std::size_t a, std::size_t b) {
    a = Find(a);
    b = Find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::vector<std::size_t> parent;  ///< Parent of each index (a root is its own parent).
};

}  // namespace yamor::physics

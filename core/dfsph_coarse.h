// DFSPH two-level solve: the factorized coarse operator that core/dfsph_coarse.cpp keeps between
// corrections (private to core/dfsph.cpp and core/dfsph_coarse.cpp).
#pragma once

#include <Eigen/Sparse>
#include <Eigen/SparseLU>

#include <array>
#include <cstdint>
#include <vector>

namespace sph {

/// A factorized coarse operator and the aggregates it was built on (one per solve kind).
struct DfsphCoarseOperator {
  bool valid = false;
  std::array<int32_t, 3> lo{}, hi{};  ///< box of aggregate cells (one cell of margin)
  int64_t ny = 0, nz = 0;
  std::vector<int32_t> index;         ///< box cell -> aggregate number, -1 = none
  int32_t m = 0;                      ///< aggregates
  double dt2 = 0;                     ///< dt^2 of K (unit: s^2)
  uint64_t step = 0;                  ///< the step it was built in
  Eigen::SparseLU<Eigen::SparseMatrix<double>> lu;
  /// The aggregate of cell (x, y, z), -1 = not one of this operator's.
  int32_t at(int32_t x, int32_t y, int32_t z) const {
    if (x < lo[0] || x > hi[0] || y < lo[1] || y > hi[1] || z < lo[2] || z > hi[2]) return -1;
    return index[static_cast<std::size_t>(((x - lo[0]) * ny + (y - lo[1])) * nz + (z - lo[2]))];
  }
};

}  // namespace sph

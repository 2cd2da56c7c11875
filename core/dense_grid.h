// DenseGrid: a scalar field sampled on a regular grid of points, on the host. The isosurface
// stage produces one per frame (the surface field), the OpenVDB writer consumes it.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <vector>

namespace sph {

struct DenseGrid {
  Eigen::Vector3d origin{0, 0, 0};  ///< world position of sample (0,0,0) (unit: m)
  double spacing = 0;               ///< distance between neighbouring samples (unit: m)
  std::array<int, 3> dims{0, 0, 0}; ///< samples along x, y, z
  std::vector<float> values;        ///< dims[0]*dims[1]*dims[2] samples, x fastest, then y, then z
  std::size_t index(int i, int j, int k) const {
    return static_cast<std::size_t>(i) + static_cast<std::size_t>(dims[0]) * (static_cast<std::size_t>(j) + static_cast<std::size_t>(dims[1]) * static_cast<std::size_t>(k));
  }
  float at(int i, int j, int k) const { return values[index(i, j, k)]; }
  Eigen::Vector3d position(int i, int j, int k) const { return origin + spacing * Eigen::Vector3d(i, j, k); }
};

}  // namespace sph

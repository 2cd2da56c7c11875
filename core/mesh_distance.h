// Distances between triangle meshes: the closest point on a triangle, a uniform-grid index for
// nearest-surface queries, and the symmetric Hausdorff distance used by `sphaptics compare`.
#pragma once

#include "core/mesh.h"

#include <Eigen/Core>

#include <memory>
#include <vector>

namespace sph {

/// Closest point to p on triangle (a, b, c) (Ericson, Real-Time Collision Detection, 5.1.5).
Eigen::Vector3d closestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c);

/// Nearest-surface queries against one mesh, through a uniform grid of its triangles.
class SurfaceIndex {
 public:
  explicit SurfaceIndex(const TriMesh& mesh);
  ~SurfaceIndex();
  SurfaceIndex(const SurfaceIndex&) = delete;
  SurfaceIndex& operator=(const SurfaceIndex&) = delete;
  /// Distance from p to the surface (unit: m); +infinity for a mesh without triangles.
  double distance(const Eigen::Vector3d& p) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// One-sided Hausdorff distance from `from` to the surface of `to`: the largest distance from a
/// sample of `from` (its vertices and triangle centroids) to the surface of `to` (unit: m).
/// 0 when `from` is empty; +infinity when only `to` is empty.
double hausdorffOneSided(const TriMesh& from, const TriMesh& to);

/// max of both directions.
double hausdorff(const TriMesh& a, const TriMesh& b);

}  // namespace sph

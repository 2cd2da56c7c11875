// Distances between triangle meshes: the closest point on a triangle, a uniform-grid index for
// nearest-surface queries, and the symmetric Hausdorff distance used by `sphaptics compare`.
#pragma once

#include "core/mesh.h"

#include <Eigen/Core>

#include <array>

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

namespace sph {

/// The feature of a triangle (a, b, c) that holds a closest point: its interior, a vertex, or an
/// edge (ab = the edge from a to b).
enum class TriangleFeature : uint8_t { Face, VertexA, VertexB, VertexC, EdgeAB, EdgeBC, EdgeCA };

/// Closest point to p on triangle (a, b, c) (Ericson, Real-Time Collision Detection, 5.1.5); with
/// `feature`, also the feature it lies on.
Eigen::Vector3d closestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c, TriangleFeature* feature = nullptr);

/// Nearest-surface queries against one mesh, through a uniform grid of its triangles.
class SurfaceIndex {
 public:
  explicit SurfaceIndex(const TriMesh& mesh);
  ~SurfaceIndex();
  SurfaceIndex(const SurfaceIndex&) = delete;
  SurfaceIndex& operator=(const SurfaceIndex&) = delete;
  /// Distance from p to the surface (unit: m); +infinity for a mesh without triangles.
  double distance(const Eigen::Vector3d& p) const;

  /// The closest surface point to p, if one lies within `max_distance` (unit: m).
  struct Nearest {
    double distance = std::numeric_limits<double>::infinity();  ///< +infinity: none within reach
    Eigen::Vector3d point = Eigen::Vector3d::Zero();
    uint32_t triangle = 0;                                     ///< index into the mesh's triangles
    TriangleFeature feature = TriangleFeature::Face;
  };
  /// Ties go to the triangle found first (cells in a fixed order): deterministic.
  Nearest nearest(const Eigen::Vector3d& p, double max_distance = std::numeric_limits<double>::infinity()) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// A closed, outward-facing mesh for inside/outside queries: nearest surface points through a
/// SurfaceIndex, and the angle-weighted pseudo-normal of each feature (Baerentzen & Aanaes 2005),
/// whose sign against (p - closest point) tells outside (> 0) from inside, exactly on a closed
/// mesh. Costs a grid query per point, where a winding number costs a pass over every triangle.
class ClosedSurface {
 public:
  explicit ClosedSurface(const TriMesh& mesh);
  const SurfaceIndex& index() const { return index_; }
  /// The pseudo-normal of feature f of triangle t (unit vector, outward).
  const Eigen::Vector3d& pseudoNormal(uint32_t t, TriangleFeature f) const;
  /// Whether p lies inside the closed surface (points on it count as inside).
  bool inside(const Eigen::Vector3d& p) const;
  /// The same, with p's distance to the surface: every point closer to p than that distance is on
  /// the same side (unit: m; +infinity for a mesh without triangles).
  bool inside(const Eigen::Vector3d& p, double& distance) const;

 private:
  const TriMesh& mesh_;
  SurfaceIndex index_;
  std::vector<Eigen::Vector3d> face_normal_;                 // per triangle, unit, outward
  std::vector<std::array<Eigen::Vector3d, 3>> edge_normal_;  // per triangle edge (ab, bc, ca): mean of both faces
  std::vector<Eigen::Vector3d> vertex_normal_;               // angle-weighted mean of the faces around
};

/// One-sided Hausdorff distance from `from` to the surface of `to`: the largest distance from a
/// sample of `from` (its vertices and triangle centroids) to the surface of `to` (unit: m).
/// 0 when `from` is empty; +infinity when only `to` is empty.
double hausdorffOneSided(const TriMesh& from, const TriMesh& to);

/// max of both directions.
double hausdorff(const TriMesh& a, const TriMesh& b);

}  // namespace sph

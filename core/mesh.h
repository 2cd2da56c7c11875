// TriMesh: an indexed triangle mesh on the host, shared by the isosurface export, `compare`,
// and rigid bodies (mass properties, sampling). Geometry only; reading and writing OBJ is in
// io/obj_io.h.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace sph {

struct TriMesh {
  std::vector<Eigen::Vector3f> positions;          ///< (unit: m)
  std::vector<Eigen::Vector3f> normals;            ///< per vertex, unit length; empty or positions.size()
  std::vector<Eigen::Vector3f> colours;            ///< per vertex linear RGB in [0, 1]; empty or positions.size()
  std::vector<std::array<uint32_t, 3>> triangles;  ///< counter-clockwise seen from outside
  std::size_t numVertices() const { return positions.size(); }
  std::size_t numTriangles() const { return triangles.size(); }
};

/// Signed enclosed volume by the divergence theorem (positive for outward-facing triangles;
/// meaningful only for a closed mesh). Accumulated in double. (unit: m^3)
double meshVolume(const TriMesh& m);
/// Total triangle area. (unit: m^2)
double meshArea(const TriMesh& m);

/// Generalised winding number of a closed mesh around point p (Jacobson et al. 2013): the sum of
/// the signed solid angles of the triangles seen from p over 4 pi (Van Oosterom & Strackee 1983).
/// About 1 inside an outward-facing closed mesh, 0 outside; use > 0.5 as "inside".
double windingNumber(const TriMesh& m, const Eigen::Vector3d& p);

/// Edge topology: a closed (watertight) mesh has every undirected edge in exactly two triangles,
/// used once in each direction.
struct EdgeReport {
  std::size_t edges = 0;         ///< distinct undirected edges
  std::size_t boundary = 0;      ///< edges in one triangle only (holes)
  std::size_t nonmanifold = 0;   ///< edges in three or more triangles
  std::size_t misoriented = 0;   ///< edges used twice in the same direction (inconsistent winding)
  std::size_t degenerate = 0;    ///< triangles with a repeated vertex index
  bool closed() const { return boundary == 0 && nonmanifold == 0 && misoriented == 0; }
};
EdgeReport checkEdges(const TriMesh& m);

/// Merges vertices closer than `tolerance` (unit: m), e.g. after reading an OBJ whose faces do not
/// share indices; drops triangles that become degenerate. Normals and colours of merged vertices
/// are those of the first. Deterministic.
void weldVertices(TriMesh& m, float tolerance);

}  // namespace sph

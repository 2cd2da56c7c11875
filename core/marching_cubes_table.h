// Marching-cubes case table (Lorensen & Cline 1987), derived at start-up instead of typed in.
//
// Numbering (also used by kernels/isosurface.cl):
//   corner c = x + 2 y + 4 z  (x, y, z in {0, 1}: the cell's node at offset (x, y, z))
//   edge   e = 4 a + u + 2 v  along axis a (0 = x, 1 = y, 2 = z) from the corner whose a-coordinate is 0
//                             and whose two other coordinates, in axis order, are (u, v)
//   case bit c set  <=>  corner c is inside (field > iso)
//
// How the table is built, per case:
//   1. On each of the 6 faces, join the crossing edges into segments. A face with 2 crossings gets one
//      segment. A face with 4 crossings (inside corners on a diagonal: the ambiguous face) always
//      gets two segments that cut off its inside corners ("separate the inside"): the decision depends
//      on the face alone, so the two cells sharing a face always agree and the mesh has no holes.
//   2. Orient each segment so that, with n the face's outward normal and d the segment direction,
//      d x n points to the inside corners. Each crossing edge lies on two faces and ends one segment
//      and starts the other, so the segments chain into closed loops.
//   3. Triangulate each loop as a fan, choosing the apex so that no fan diagonal joins two points of
//      one face (such a diagonal could be shared with the neighbouring cell: 4 triangles on one edge).
// The loop order makes triangles counter-clockwise seen from outside (the field decreases outward).
#pragma once

#include <array>
#include <cstdint>

namespace sph {

struct MarchingCubesTable {
  /// Room per case: a loop of m crossings gives m - 2 triangles and a cell has at most 12 crossings.
  static constexpr int kMaxTriangles = 10;
  std::array<uint8_t, 256> triangle_count{};
  /// Per case, 3 * kMaxTriangles edge indices (unused entries 255): 256 x 15.
  std::array<std::array<uint8_t, 3 * kMaxTriangles>, 256> triangles{};
  /// Cases in which some loop had no apex free of face-sharing diagonals (expected: none).
  int unsafe_cases = 0;
  int max_triangles = 0;  ///< largest triangle count over all cases
};

/// The table, built once.
const MarchingCubesTable& marchingCubesTable();

}  // namespace sph

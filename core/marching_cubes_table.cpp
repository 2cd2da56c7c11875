#include "core/marching_cubes_table.h"

#include "core/errors.h"

#include <vector>

namespace sph {

namespace {

// Coordinates of corner c.
int cornerCoord(int c, int axis) { return (c >> axis) & 1; }

// The two axes other than `a`, in axis order.
void otherAxes(int a, int& o1, int& o2) {
  o1 = a == 0 ? 1 : 0;
  o2 = a == 2 ? 1 : 2;
}

// Corner at the start (t = 0) or end (t = 1) of edge e.
int edgeCorner(int e, int t) {
  const int a = e / 4, u = e & 1, v = (e >> 1) & 1;
  int o1, o2;
  otherAxes(a, o1, o2);
  return (t << a) | (u << o1) | (v << o2);
}

// Bit f (face index 2 * axis + side) set when edge e lies in face f.
int edgeFaces(int e) {
  const int a = e / 4, u = e & 1, v = (e >> 1) & 1;
  int o1, o2;
  otherAxes(a, o1, o2);
  return (1 << (2 * o1 + u)) | (1 << (2 * o2 + v));
}

struct V3 {
  double x[3];
};
V3 sub(V3 a, V3 b) { return {{a.x[0] - b.x[0], a.x[1] - b.x[1], a.x[2] - b.x[2]}}; }
V3 cross(V3 a, V3 b) {
  return {{a.x[1] * b.x[2] - a.x[2] * b.x[1], a.x[2] * b.x[0] - a.x[0] * b.x[2], a.x[0] * b.x[1] - a.x[1] * b.x[0]}};
}
double dot(V3 a, V3 b) { return a.x[0] * b.x[0] + a.x[1] * b.x[1] + a.x[2] * b.x[2]; }
V3 cornerPos(int c) { return {{double(cornerCoord(c, 0)), double(cornerCoord(c, 1)), double(cornerCoord(c, 2))}}; }
V3 edgeMid(int e) {
  V3 p = cornerPos(edgeCorner(e, 0));
  p.x[e / 4] = 0.5;
  return p;
}

MarchingCubesTable build() {
  MarchingCubesTable t;
  for (auto& row : t.triangles) row.fill(255);
  for (int cs = 0; cs < 256; ++cs) {
    auto inside = [cs](int c) { return (cs >> c) & 1; };
    auto crossing = [&](int e) { return inside(edgeCorner(e, 0)) != inside(edgeCorner(e, 1)); };
    int next[12], prev[12];
    for (int e = 0; e < 12; ++e) next[e] = prev[e] = -1;

    // 1-2. Oriented segments on each face.
    auto addSegment = [&](int ea, int eb, int corner, V3 normal) {
      const V3 a = edgeMid(ea), b = edgeMid(eb);
      const V3 mid{{0.5 * (a.x[0] + b.x[0]), 0.5 * (a.x[1] + b.x[1]), 0.5 * (a.x[2] + b.x[2])}};
      if (dot(cross(sub(b, a), normal), sub(cornerPos(corner), mid)) < 0) std::swap(ea, eb);
      SPH_ASSERT(next[ea] == -1 && prev[eb] == -1, "marching-cubes table: segments do not chain");
      next[ea] = eb;
      prev[eb] = ea;
    };
    for (int fa = 0; fa < 3; ++fa) {
      for (int side = 0; side < 2; ++side) {
        const int face = 2 * fa + side;
        V3 normal{{0, 0, 0}};
        normal.x[fa] = side ? 1.0 : -1.0;
        std::vector<int> edges;  // crossing edges of this face
        for (int e = 0; e < 12; ++e)
          if ((edgeFaces(e) >> face & 1) && crossing(e)) edges.push_back(e);
        std::vector<int> in_corners;
        for (int c = 0; c < 8; ++c)
          if (cornerCoord(c, fa) == side && inside(c)) in_corners.push_back(c);
        if (edges.size() == 2) {
          addSegment(edges[0], edges[1], in_corners.at(0), normal);
        } else if (edges.size() == 4) {
          // Ambiguous face: cut off each inside corner on its own.
          for (int c : in_corners) {
            int pair[2], k = 0;
            for (int e : edges)
              if (edgeCorner(e, 0) == c || edgeCorner(e, 1) == c) pair[k++] = e;
            SPH_ASSERT(k == 2, "marching-cubes table: ambiguous face corner without two edges");
            addSegment(pair[0], pair[1], c, normal);
          }
        }
      }
    }

    // 3. Chain into loops and fan-triangulate each.
    bool used[12] = {};
    int ntri = 0;
    for (int start = 0; start < 12; ++start) {
      if (!crossing(start) || used[start]) continue;
      std::vector<int> loop;
      for (int e = start; !used[e]; e = next[e]) {
        SPH_ASSERT(next[e] >= 0, "marching-cubes table: open loop");
        used[e] = true;
        loop.push_back(e);
      }
      const int m = static_cast<int>(loop.size());
      SPH_ASSERT(m >= 3, "marching-cubes table: loop with fewer than 3 edges");
      int apex = -1;
      for (int k = 0; k < m && apex < 0; ++k) {
        bool ok = true;
        for (int j = 2; j <= m - 2; ++j)
          if (edgeFaces(loop[k]) & edgeFaces(loop[(k + j) % m])) ok = false;
        if (ok) apex = k;
      }
      if (apex < 0) {
        ++t.unsafe_cases;
        apex = 0;
      }
      for (int j = 1; j <= m - 2; ++j) {
        SPH_ASSERT(ntri < MarchingCubesTable::kMaxTriangles, "marching-cubes table: too many triangles");
        auto& row = t.triangles[static_cast<std::size_t>(cs)];
        row[static_cast<std::size_t>(3 * ntri + 0)] = static_cast<uint8_t>(loop[apex]);
        row[static_cast<std::size_t>(3 * ntri + 1)] = static_cast<uint8_t>(loop[(apex + j) % m]);
        row[static_cast<std::size_t>(3 * ntri + 2)] = static_cast<uint8_t>(loop[(apex + j + 1) % m]);
        ++ntri;
      }
    }
    t.triangle_count[static_cast<std::size_t>(cs)] = static_cast<uint8_t>(ntri);
    if (ntri > t.max_triangles) t.max_triangles = ntri;
  }
  return t;
}

}  // namespace

const MarchingCubesTable& marchingCubesTable() {
  static const MarchingCubesTable table = build();  // immutable after first use
  return table;
}

}  // namespace sph

// Isosurface stage: a surface field per fluid phase on a regular grid, meshed by marching cubes,
// all on the device (kernels/isosurface.cl). Runs once per output frame, when the scene asks for
// it (output.isosurface); the meshes go to the host for export. See kernels/isosurface.cl for the
// field and the passes, and core/marching_cubes_table.h for the case table.
#pragma once

#include "core/cl_context.h"
#include "core/dense_grid.h"
#include "core/mesh.h"
#include "core/prefix_sum.h"
#include "kernels/shared/sim_params.h"
#include "kernels/shared/iso_params.h"

#include <cstddef>
#include <vector>

namespace sph {

struct IsoSettings {
  double spacing = 0;           ///< surface grid spacing (unit: m); must be > 0
  float iso = 0.5f;             ///< surface value of the normalised field (unit: 1)
  bool vertex_colours = false;  ///< per-vertex colour from the particles' colour field
  bool meshes = true;           ///< run marching cubes; false: only the field (for a VDB-only export)
};

/// The fluid particles as the mesher reads them (device buffers in neighbour-grid order).
struct ParticleView {
  const SimParams* params = nullptr;
  const cl::Buffer* pos = nullptr;
  const cl::Buffer* phase = nullptr;
  const cl::Buffer* colour = nullptr;
  const cl::Buffer* cell_start = nullptr;
  std::size_t count = 0;
  uint32_t num_phases = 1;
  double drift = 0;  ///< largest particle travel since the grid was built (unit: m)
};

/// The grid of one extraction (no values; for reports and tests).
struct SurfaceGridShape {
  Eigen::Vector3d origin{0, 0, 0};  ///< position of node (0, 0, 0) (unit: m)
  double spacing = 0;               ///< (unit: m)
  std::array<int, 3> dims{0, 0, 0};  ///< nodes per axis
};

class SurfaceMesher {
 public:
  /// `kernels` (a program built from the embedded sources) must outlive the mesher.
  SurfaceMesher(ClContext& cl, KernelSet& kernels);

  /// One mesh per phase (index = phase) from the particles, on a grid covering the fluid's
  /// bounding box plus the kernel support. Vertices are welded; triangles are counter-clockwise
  /// seen from outside and in cell order (deterministic).
  std::vector<TriMesh> meshParticles(const ParticleView& particles, const IsoSettings& settings);

  /// Marching cubes of a field given on the host (analytic fields in tests), with the same kernels.
  /// The surface is {grid > iso}; it is closed when the border samples are all <= iso.
  TriMesh meshGrid(const DenseGrid& grid, float iso);

  const SurfaceGridShape& lastGrid() const { return last_grid_; }
  /// The field of `phase` from the last meshParticles() call, on the host (for the VDB export).
  DenseGrid readField(uint32_t phase);
  /// Device memory held (unit: bytes).
  std::size_t bytes() const;

 private:
  struct Grow {
    cl::Buffer buf;
    std::size_t bytes = 0;
  };
  cl::Buffer& ensure(Grow& g, std::size_t bytes);
  TriMesh march(IsoParams q, const ParticleView* particles);

  ClContext& cl_;
  KernelSet& kernels_;
  PrefixSum scan_;
  cl::Buffer case_triangles_, case_edges_;
  Grow bounds_, field_, edge_mask_, vert_count_, vert_offset_, tri_count_, tri_offset_;
  Grow vert_pos_, vert_normal_, vert_colour_, tris_;
  SurfaceGridShape last_grid_;
  uint32_t last_fields_ = 0;  // fields held in field_ by the last extraction
};

}  // namespace sph

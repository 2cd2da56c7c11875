// OpenVDB export of the surface field: one .vdb file per output frame, for Blender's volume
// import and `vdb_print`.
#pragma once

#include "core/dense_grid.h"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace sph::io {

struct NamedGrid {
  std::string name;               ///< grid name in the file ("density", "density_<phase>", ...)
  const DenseGrid* grid = nullptr;
};

struct VdbOptions {
  bool level_set = false;  ///< also write a narrow-band level set "surface" from the grid named "density"
  float iso = 0.5f;        ///< value of the "density" field on the surface (for the level set)
  float half_width = 3.f;  ///< narrow-band half width of the level set (unit: voxels)
};

/// Writes every grid as an openvdb::FloatGrid (class fog volume, background 0, samples below
/// 1e-6 of the maximum left inactive) with a linear world transform: voxel size = grid.spacing
/// and index (0,0,0) at grid.origin. Written to a temporary file and renamed, so a reader never
/// sees half a file. Throws std::runtime_error naming the file on failure.
void writeVdb(const std::string& path, const std::vector<NamedGrid>& grids, const VdbOptions& options = {});

/// What a .vdb file holds, read back through OpenVDB (for tests and checks).
struct VdbGridInfo {
  std::string name;
  std::string grid_class;         ///< "fog volume", "level set", ...
  std::string value_type;         ///< "float", ...
  double voxel_size = 0;          ///< (unit: m)
  Eigen::Vector3d index_origin_world{0, 0, 0};  ///< world position of index (0,0,0) (unit: m)
  std::size_t active_voxels = 0;
  float min_active = 0, max_active = 0;
};
/// Reads the grids of a file. Throws std::runtime_error naming the file when it cannot be read.
std::vector<VdbGridInfo> readVdbInfo(const std::string& path);
/// Value of grid `name` at a world point (trilinear). Throws when the grid does not exist.
float sampleVdb(const std::string& path, const std::string& name, const Eigen::Vector3d& world);

}  // namespace sph::io

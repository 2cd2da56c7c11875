// Cloth output: cloth.csv (one row per cloth per output frame, the conventions of bodies.csv) and
// each cloth's surface, one OBJ per cloth per frame (cloth_<name>_NNNN.obj, vertex colours, broken
// springs' triangles removed), picked up by scripts/render.sh like the other OBJ sequences. Soft
// bodies alike: soft.csv (the same columns, a row per soft body) and soft_<name>_NNNN.obj.
#pragma once

#include "core/cloth.h"
#include "core/mesh.h"
#include "core/scene_spec.h"

#include <Eigen/Core>

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

namespace sph::io {

/// The triangles of cloth `c` at node positions `x` (all cloths' nodes): two per grid cell, each
/// kept only while the springs along its three edges (stretch, and the shear diagonal when the
/// cloth has shear springs) are unbroken. Vertices: the cloth's nodes, in the cloth's colour.
TriMesh clothMesh(const cloth::ClothModel& model, std::size_t c, const ClothSpec& spec,
                  const std::vector<Eigen::Vector4f>& x, const std::vector<uint32_t>& broken);

/// The surface of soft body `b` (item model.num_cloths + b) at node positions `x` (all nodes): the
/// faces of its intact lattice cells (a cell is intact while none of its 28 springs is broken) that
/// no other intact cell shares, two triangles each, facing out. So the walls of a cut show. Vertices:
/// the body's nodes, in `colour` (linear RGB).
TriMesh softMesh(const cloth::ClothModel& model, std::size_t b, const Eigen::Vector3d& colour,
                 const std::vector<Eigen::Vector4f>& x, const std::vector<uint32_t>& broken);

/// cloth.csv: '#' lines (units, conventions), a header row, then one row per cloth per frame:
/// time, cloth, energies (kinetic, gravity, elastic, total), largest strain, broken springs, the
/// force of the springs on the anchored nodes.
class ClothCsvWriter {
 public:
  /// Creates (truncates) the file. Throws std::runtime_error naming it when it cannot be opened.
  /// `soft`: soft.csv (rows of soft bodies), else cloth.csv.
  explicit ClothCsvWriter(const std::string& path, bool soft = false);
  void writeRow(double time, const std::string& name, const cloth::ClothReport& r);
  void close();

 private:
  std::string path_;
  std::ofstream out_;
};

/// The header comment and column row of cloth.csv (`soft`: of soft.csv, column soft_body).
std::string clothCsvHeader(bool soft = false);

/// "cloth_<name>_<frame, 4 digits>.obj".
std::string clothObjName(const std::string& name, int frame);

/// "soft_<name>_<frame, 4 digits>.obj".
std::string softObjName(const std::string& name, int frame);

}  // namespace sph::io

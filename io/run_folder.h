// What an output folder holds, for reading it back (the viewer): run.json's scene (domain box,
// particle spacing, phase and body colours), the particle file (final or still being written) and
// the OBJ sequences fluid_<phase>_NNNN.obj, body_<name>_NNNN.obj, cloth_<name>_NNNN.obj and
// soft_<name>_NNNN.obj (soft bodies' surfaces, in the cloth OBJ's format).
#pragma once

#include <Eigen/Core>

#include <map>
#include <string>
#include <vector>

namespace sph::io {

struct RunFolderInfo {
  std::string status;                    ///< run.json "status" ("running", "complete", ...); "" without run.json
  bool has_domain = false;               ///< domain_min/max come from run.json
  Eigen::Vector3f domain_min{0, 0, 0};   ///< (unit: m)
  Eigen::Vector3f domain_max{1, 1, 1};   ///< (unit: m)
  double particle_spacing = 0;           ///< dx; 0 when unknown (unit: m)
  double frame_rate = 0;                 ///< output frames per simulated second; 0 when unknown (unit: 1/s)
  std::vector<std::pair<std::string, Eigen::Vector3f>> phases;  ///< name, linear RGB colour
  std::vector<std::pair<std::string, Eigen::Vector3f>> bodies;  ///< name, linear RGB colour
  std::vector<std::pair<std::string, Eigen::Vector3f>> cloths;  ///< name, linear RGB colour
  std::vector<std::pair<std::string, Eigen::Vector3f>> soft_bodies;  ///< name, linear RGB colour (scene key soft_bodies)
};

/// Reads DIR/run.json. A folder without run.json gives a default RunFolderInfo (status "").
/// Throws InputError with file:line:col when run.json is not valid JSON.
RunFolderInfo readRunFolderInfo(const std::string& dir);

/// DIR/particles.h5part when it exists, else DIR/particles.h5part.partial (a run still going, or
/// one that stopped), else "".
std::string particlesFile(const std::string& dir);

/// One OBJ sequence: "fluid_water" or "body_ball", frame index -> file path.
struct ObjSequence {
  std::string name;           ///< file name without _NNNN.obj
  bool body = false;          ///< body_*, cloth_* or soft_* (else fluid_*): drawn in the bodies layer
  bool cloth = false;         ///< cloth_*
  bool soft = false;          ///< soft_* (a soft body's surface)
  std::map<int, std::string> frames;
};

/// Every fluid_*_NNNN.obj, body_*_NNNN.obj, cloth_*_NNNN.obj and soft_*_NNNN.obj sequence in DIR,
/// sorted by name.
std::vector<ObjSequence> scanObjSequences(const std::string& dir);

}  // namespace sph::io

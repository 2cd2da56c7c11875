#include "io/run_json.h"

#include "io/atomic_file.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace sph::io {

std::string jsonString(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    switch (c) {
      case '"': o += "\\\""; break;
      case '\\': o += "\\\\"; break;
      case '\n': o += "\\n"; break;
      case '\t': o += "\\t"; break;
      case '\r': o += "\\r"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          o += buf;
        } else {
          o += c;
        }
    }
  }
  return o + "\"";
}

void writeRunJson(const std::string& path, const RunInfo& info) {
  std::ostringstream j;
  j.precision(9);
  j << "{\n";
  j << "  \"program\": \"sphaptics\",\n";
  j << "  \"version\": " << jsonString(SPHAPTICS_VERSION) << ",\n";
  j << "  \"status\": " << jsonString(info.status) << ",\n";
  j << "  \"message\": " << jsonString(info.message) << ",\n";
  j << "  \"scene_file\": " << jsonString(info.scene_file) << ",\n";
  j << "  \"device\": " << jsonString(info.device) << ",\n";
  j << "  \"stages\": " << jsonString(info.stages) << ",\n";
  j << "  \"notes\": [";
  for (std::size_t i = 0; i < info.notes.size(); ++i) j << (i ? ", " : "") << jsonString(info.notes[i]);
  j << "],\n";
  j << "  \"frames\": " << info.frames << ",\n";
  j << "  \"simulated_seconds\": " << info.sim_time << ",\n";
  j << "  \"wall_seconds\": " << info.wall_seconds << ",\n";
  j << "  \"particles\": " << info.particles << ",\n";
  j << "  \"steps\": " << info.profile.steps << ",\n";
  j << "  \"particle_steps_per_second\": " << info.particle_steps_per_second << ",\n";
  j << "  \"isosurface_seconds\": " << info.isosurface_seconds << ",\n";
  j << "  \"output_seconds\": " << info.output_seconds << ",\n";
  j << "  \"writer_seconds\": " << info.writer_seconds << ",\n";
  j << "  \"cfl_subdivided_frames\": " << info.profile.subdivided_frames << ",\n";
  j << "  \"stage_seconds\": {";
  for (int i = 0; i < kNumStages; ++i)
    j << (i ? ", " : "") << jsonString(stageName(static_cast<Stage>(i))) << ": "
      << info.profile.seconds[static_cast<std::size_t>(i)];
  j << "},\n";
  j << "  \"rigid_reduce_seconds\": " << info.profile.rigid_reduce_seconds << ",\n";
  // DFSPH solver (zero with solver wcsph): iterations, steps above the bound, largest errors reached
  j << "  \"dfsph\": {\"density_iterations\": " << info.profile.density_iterations
    << ", \"divergence_iterations\": " << info.profile.divergence_iterations
    << ", \"density_iterations_per_step\": "
    << (info.profile.steps ? double(info.profile.density_iterations) / double(info.profile.steps) : 0.0)
    << ", \"unconverged_steps\": " << info.profile.unconverged_steps
    << ", \"max_density_error\": " << info.profile.max_density_error
    << ", \"max_divergence_error\": " << info.profile.max_divergence_error << "},\n";
  j << "  \"scene\": " << (info.scene_json.empty() ? "null" : info.scene_json) << "\n";
  j << "}\n";

  writeFileAtomic(path, j.str());
}

}  // namespace sph::io

#include "io/run_json.h"

#include "io/atomic_file.h"

#include <algorithm>
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

void RunWarnings::add(const FrameReport& rep) {
  nonfinite += rep.nonfinite;
  nonfinite_frames += rep.nonfinite > 0;
  cfl_violations += rep.cfl_violations;
  cfl_violation_frames += rep.cfl_violations > 0;
  if (stepOverLimit(rep)) {
    ++cfl_step_frames;
    max_step_over_limit = std::max(max_step_over_limit, rep.dt / rep.dt_limit);
  }
  wall_crossings += rep.wall_crossings;
  wall_crossing_frames += rep.wall_crossings > 0;
  left_domain += rep.outside;
}

std::string RunWarnings::summary() const {
  std::ostringstream s;
  s.precision(3);
  const char* sep = "";
  if (nonfinite) s << sep << nonfinite << " NaN/inf particle(s) in " << nonfinite_frames << " frame(s)", sep = "; ";
  if (cfl_step_frames)
    s << sep << cfl_step_frames << " frame(s) stepped above the CFL limit (up to " << max_step_over_limit << " x)",
        sep = "; ";
  if (cfl_violations)
    s << sep << cfl_violations << " particle move(s) longer than h in one step in " << cfl_violation_frames << " frame(s)",
        sep = "; ";
  if (wall_crossings)
    s << sep << wall_crossings << " wall crossing(s) in " << wall_crossing_frames
      << " frame(s) (particles put back inside)",
        sep = "; ";
  if (left_domain) s << sep << left_domain << " particle-frame(s) outside the domain through open walls", sep = "; ";
  return s.str();
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
  const RunWarnings& w = info.warnings;
  j << "  \"warnings\": {\"nonfinite\": " << w.nonfinite << ", \"nonfinite_frames\": " << w.nonfinite_frames
    << ", \"cfl_violations\": " << w.cfl_violations << ", \"cfl_violation_frames\": " << w.cfl_violation_frames
    << ", \"cfl_step_frames\": " << w.cfl_step_frames << ", \"max_step_over_cfl_limit\": " << w.max_step_over_limit
    << ", \"wall_crossings\": " << w.wall_crossings << ", \"wall_crossing_frames\": " << w.wall_crossing_frames
    << ", \"left_domain\": " << w.left_domain << "},\n";
  j << "  \"stage_seconds\": {";
  for (int i = 0; i < kNumStages; ++i)
    j << (i ? ", " : "") << jsonString(stageName(static_cast<Stage>(i))) << ": "
      << info.profile.seconds[static_cast<std::size_t>(i)];
  j << "},\n";
  j << "  \"rigid_reduce_seconds\": " << info.profile.rigid_reduce_seconds << ",\n";
  j << "  \"neighbour_list_builds\": " << info.profile.grid_builds << ",\n";
  // The settle before t = 0 (simulation.settle_time; zero without one), apart from the run's steps
  j << "  \"settle\": {\"steps\": " << info.profile.settle_steps << ", \"wall_seconds\": " << info.profile.settle_seconds
    << ", \"max_speed_last_step\": " << info.profile.settle_max_speed << "},\n";
  // DFSPH solver (zero with solver wcsph): iterations, steps above the bound, largest errors reached
  j << "  \"dfsph\": {\"density_iterations\": " << info.profile.density_iterations
    << ", \"divergence_iterations\": " << info.profile.divergence_iterations
    << ", \"density_corrections\": " << info.profile.density_corrections
    << ", \"divergence_corrections\": " << info.profile.divergence_corrections
    << ", \"corrections_reused\": " << info.profile.corrections_reused
    << ", \"density_iterations_per_step\": "
    << (info.profile.steps ? double(info.profile.density_iterations) / double(info.profile.steps) : 0.0)
    << ", \"unconverged_steps\": " << info.profile.unconverged_steps
    << ", \"max_density_error\": " << info.profile.max_density_error
    << ", \"max_divergence_error\": " << info.profile.max_divergence_error
    << ", \"viscosity_iterations\": " << info.profile.viscosity_iterations
    << ", \"viscosity_unconverged_steps\": " << info.profile.viscosity_unconverged_steps
    << ", \"max_viscosity_residual\": " << info.profile.max_viscosity_residual << ", \"steps_limited_by\": {";
  // What set each step's length (Simulation::dfsphStepLimit): the largest step, CFL, a viscous limit
  for (int l = 0; l < kNumStepLimiters; ++l)
    j << (l ? ", " : "") << jsonString(stepLimiterName(static_cast<StepLimiter>(l))) << ": "
      << info.profile.dfsph_step_limiters[static_cast<std::size_t>(l)];
  // The steps against the pressure's own scale: dt sqrt(max p / rho) / dx (fluid.dfsph.pressure_cfl)
  j << "}, \"max_pressure_step_ratio\": " << info.profile.max_pressure_step_ratio
    << ", \"steps_over_pressure_scale\": " << info.profile.steps_over_pressure_scale << "},\n";
  j << "  \"scene\": " << (info.scene_json.empty() ? "null" : info.scene_json) << "\n";
  j << "}\n";

  writeFileAtomic(path, j.str());
}

}  // namespace sph::io

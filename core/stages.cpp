#include "core/stages.h"

namespace sph {

static const std::array<const char*, kNumStages> kStageNames = {
    "inflow", "grid", "density", "probes", "pressure", "divergence_solve", "viscosity", "colour_diffusion", "density_solve", "rigid_coupling", "haptics", "cloth_coupling", "integrate", "rigid_dynamics", "cloth", "diagnostics"};

const char* stageName(Stage s) { return kStageNames[static_cast<std::size_t>(s)]; }

std::optional<Stage> stageFromName(const std::string& name) {
  for (int i = 0; i < kNumStages; ++i)
    if (name == kStageNames[static_cast<std::size_t>(i)]) return static_cast<Stage>(i);
  return std::nullopt;
}

std::string stageNameList() {
  std::string s;
  for (const char* n : kStageNames) s += (s.empty() ? "" : ", ") + std::string(n);
  return s;
}

std::string StageMask::str() const {
  std::string s;
  for (int i = 0; i < kNumStages; ++i)
    if (on(static_cast<Stage>(i))) s += (s.empty() ? "" : ",") + std::string(kStageNames[static_cast<std::size_t>(i)]);
  return s;
}

}  // namespace sph

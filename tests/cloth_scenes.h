// Scene specs for the cloth tests (built in code, no file).
#pragma once

#include "core/scene_spec.h"

namespace sph::testing {

/// A scene with no fluid and one cloth: domain [0, 1]^3, gravity -z.
inline SceneSpec clothScene(const ClothSpec& c, double frame_rate, int substeps, double duration) {
  SceneSpec s;
  s.domain.min = Eigen::Vector3d::Zero();
  s.domain.max = Eigen::Vector3d::Ones();
  s.fluid.particle_spacing = 0.05;
  s.fluid.phases.resize(1);
  s.fluid.phases[0].name = "water";
  s.simulation.frame_rate = frame_rate;
  s.simulation.substeps = substeps;
  s.simulation.duration = duration;
  s.cloth.push_back(c);
  return s;
}

}  // namespace sph::testing

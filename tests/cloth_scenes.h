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

/// A square net of nodes x nodes over size x size metres centred at (0.5, 0.5, 0.5), its four edges
/// anchored, springs 10^4 / 10^3 / 1 N/m (stretch, shear, bend) with 1 N s/m dashpots: the sheet of
/// the ball-on-cloth tests.
inline ClothSpec anchoredSquare(const std::string& name, double size, int nodes, double areal_density, int iterations,
                                double air_damping) {
  ClothSpec c;
  c.name = name;
  c.width = c.length = size;
  c.resolution_x = c.resolution_y = nodes;
  c.position = Eigen::Vector3d(0.5, 0.5, 0.5);
  c.areal_density = areal_density;
  c.stretch_stiffness = 1e4;
  c.shear_stiffness = 1e3;
  c.bend_stiffness = 1;
  c.iterations = iterations;
  c.damping = 1.0;
  c.air_damping = air_damping;
  for (ClothEdge e : {ClothEdge::XMin, ClothEdge::XMax, ClothEdge::YMin, ClothEdge::YMax}) {
    ClothAnchorSpec an;
    an.type = AnchorType::Edge;
    an.edge = e;
    c.anchors.push_back(an);
  }
  return c;
}

/// A dynamic ball (sphere) of the given radius (m), centre (m) and density (kg/m^3).
inline RigidBodySpec dynamicBall(const std::string& name, double radius, const Eigen::Vector3d& position, double density) {
  RigidBodySpec b;
  b.name = name;
  b.shape = BodyShape::Sphere;
  b.radius = radius;
  b.position = position;
  b.density = density;
  b.dynamic = true;
  return b;
}

}  // namespace sph::testing

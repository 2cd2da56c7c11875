// What DFSPH's implicit viscosity (fluid.dfsph.viscosity_solve) needs of a scene's bodies, in one place for
// the loader, which refuses `implicit` set by hand without it (io/scene_loader.cpp), and the model, whose
// `auto` takes implicit only with it (core/model.cpp, resolveViscositySolve). Measured in docs/dfsph.md,
// session 38:
//  - free rigid bodies are unknowns of the solve only with the strong body coupling (their mobilities);
//    staggered, they would be held in it and take its reaction after it, which overshoots at long steps (a
//    ball released into syrup at 5 ms shot off or blew up);
//  - cloth, and soft bodies lighter than the liquid, rest in syrup only with their own XPBD step split into
//    substeps of at most kImplicitViscosityXpbdStep (in one 5 ms step the light hammocks read their anchors up
//    to 39 % off or blew up; at 0.5 ms within 1 %, as the explicit solve). The automatic max_time_step (0)
//    chooses them (core/model.cpp).
#pragma once

#include "core/scene_spec.h"

#include <algorithm>
#include <string>

namespace sph {

/// Whether a cloth's or soft body's step is XPBD in substeps of at most kImplicitViscosityXpbdStep; 0 is
/// automatic, which chooses them under the implicit viscosity.
inline bool implicitViscositySubsteps(ClothSolver solver, double max_time_step) {
  return solver == ClothSolver::Xpbd && max_time_step >= 0.0 && max_time_step <= kImplicitViscosityXpbdStep * (1.0 + 1e-9);
}

/// The densest liquid's rest density (the default phase's when the scene lists none) (unit: kg/m^3).
inline double densestLiquid(const FluidSpec& fluid) {
  if (fluid.phases.empty()) return PhaseSpec().rest_density;
  double rho = 0.0;
  for (const PhaseSpec& p : fluid.phases) rho = std::max(rho, p.rest_density);
  return rho;
}

/// Whether a soft body is lighter than the liquid (rho_liquid: densestLiquid): such a body, as every cloth,
/// needs the substeps under the implicit viscosity; a denser one rests in it in one step.
inline bool lighterThanLiquid(const SoftBodySpec& b, double rho_liquid) { return b.density < rho_liquid; }

/// Free rigid bodies with the staggered body coupling: the implicit viscosity cannot move them in its solve.
inline bool implicitViscosityStaggeredBodies(const SceneSpec& s) {
  return s.fluid.dfsph.body_coupling == DfsphCoupling::Staggered &&
         std::any_of(s.rigid_bodies.begin(), s.rigid_bodies.end(), [](const RigidBodySpec& b) { return b.dynamic; });
}

/// The first cloth, then soft body lighter than the liquid, whose step is not in the substeps the implicit
/// viscosity needs.
struct ImplicitViscosityLightBody {
  bool cloth = false, soft = false;
  std::string name;
  double density = 0.0, liquid_density = 0.0;  ///< a soft body's, the densest liquid's (unit: kg/m^3)
  explicit operator bool() const { return cloth || soft; }
};
inline ImplicitViscosityLightBody implicitViscosityLightBody(const SceneSpec& s) {
  ImplicitViscosityLightBody r;
  r.liquid_density = densestLiquid(s.fluid);
  for (const ClothSpec& c : s.cloth)
    if (!implicitViscositySubsteps(c.solver, c.max_time_step)) {
      r.cloth = true;
      r.name = c.name;
      return r;
    }
  for (const SoftBodySpec& b : s.soft_bodies)
    if (lighterThanLiquid(b, r.liquid_density) && !implicitViscositySubsteps(b.solver, b.max_time_step)) {
      r.soft = true;
      r.name = b.name;
      r.density = b.density;
      return r;
    }
  return r;
}

}  // namespace sph

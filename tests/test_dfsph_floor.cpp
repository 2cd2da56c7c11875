// DEBUG harness (temporary)
#include "core/model.h"
#include "core/simulation.h"
#include "core/cl_context.h"
#include "io/scene_loader.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <deque>
#include <map>

using namespace sph;

TEST_CASE("debug floor", "[.debug]") {
  SceneSpec spec = io::loadScene(std::string(SPHAPTICS_SOURCE_DIR) + "/scenes/tests/dfsph_floor.yaml");
  const Compiled comp = compile(spec);
  ClContext cl;
  Simulation sim(comp.model, comp.initial, cl);
  const double dt = 0.003;
  std::map<int64_t, std::deque<std::string>> hist;
  int shown = 0;
  for (int s = 0; s < 160 && shown < 5; ++s) {
    sim.step(dt);
    const ParticleFrame f = sim.readFrame();
    for (std::size_t p = 0; p < f.size(); ++p) {
      char buf[256];
      std::snprintf(buf, sizeof buf, "  step %3d t %.3f id %3lld x/dx %.3f y/dx %.3f z/dx %.3f vz %.3f vx %.3f rho %.1f p %.1f", s, sim.time(),
                    (long long)f.id[p], f.x[p] / 0.01, f.y[p] / 0.01, f.z[p] / 0.01, f.vz[p], f.vx[p], f.density[p], f.pressure[p]);
      auto& h = hist[f.id[p]];
      h.push_back(buf);
      if (h.size() > 40) h.pop_front();
      if (f.z[p] < 3e-6 && shown < 5) {
        ++shown;
        std::printf("crossing id %lld at step %d\n", (long long)f.id[p], s);
        for (std::size_t q = h.size() > 12 ? h.size() - 12 : 0; q < h.size(); ++q) std::printf("%s\n", h[q].c_str());
      }
    }
  }
}

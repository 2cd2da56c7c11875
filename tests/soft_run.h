// A hand-made run folder with a soft body's surface sequence soft_<name>_NNNN.obj (the soft-body
// exporter's naming and format: the cloth OBJ's, `v x y z r g b` with the body's colour): for the
// viewer and Blender tests that check the sequence is picked up and drawn where it is.
#pragma once

#include "tests/temp_dir.h"

#include <Eigen/Core>

#include <cstdio>
#include <string>

namespace sph::testing {

/// The soft body: a green cube of side kSoftSide whose centre moves along x from frame to frame.
constexpr float kSoftSide = 0.06f;  ///< (unit: m)
inline Eigen::Vector3f softCentre(int frame) { return {0.06f + 0.04f * static_cast<float>(frame), 0.05f, 0.05f}; }
constexpr int kSoftFrames = 3;

/// Writes run.json (domain 0.2 x 0.1 x 0.2 m, soft_bodies: jelly, green) and soft_jelly_0000.obj
/// to soft_jelly_0002.obj into `dir` (a TempDir's folder).
inline void writeSoftRun(const TempDir& dir) {
  dir.write("run.json", R"({"status": "complete", "scene": {"domain": {"min": [0, 0, 0], "max": [0.2, 0.1, 0.2]},
    "simulation": {"frame_rate": 20}, "soft_bodies": [{"name": "jelly", "colour": [0.1, 0.8, 0.2]}]}})");
  for (int f = 0; f < kSoftFrames; ++f) {
    const Eigen::Vector3f c = softCentre(f);
    const float h = 0.5f * kSoftSide;
    std::string obj = "# soft body jelly, world coordinates\n";
    char line[160];
    for (int i = 0; i < 8; ++i) {
      std::snprintf(line, sizeof line, "v %.6f %.6f %.6f 0.1 0.8 0.2\n", c.x() + (i & 1 ? h : -h), c.y() + (i & 2 ? h : -h),
                    c.z() + (i & 4 ? h : -h));
      obj += line;
    }
    // Twelve triangles, counter-clockwise seen from outside (1-based vertex indices).
    obj += "f 1 3 4\nf 1 4 2\nf 5 6 8\nf 5 8 7\nf 1 2 6\nf 1 6 5\nf 3 7 8\nf 3 8 4\nf 1 5 7\nf 1 7 3\nf 2 4 8\nf 2 8 6\n";
    std::snprintf(line, sizeof line, "soft_jelly_%04d.obj", f);
    dir.write(line, obj);
  }
}

/// Soft-body green under any shading; background, floor and box outline are grey.
inline bool isSoftGreen(const uint8_t* c) { return c[1] > c[0] + 60 && c[1] > c[2] + 60; }

}  // namespace sph::testing

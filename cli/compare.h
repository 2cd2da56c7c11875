// `sphaptics compare A B`: OBJ sequences (folders) or single OBJ files, frame by frame, within
// tolerances in units of the particle spacing. What regression tests use.
#pragma once

#include <ostream>
#include <string>

namespace sph::app {

struct CompareOptions {
  std::string a, b;          ///< OBJ files, or folders whose *.obj files are matched by name
  double hausdorff = 1.0;    ///< symmetric Hausdorff distance tolerance (unit: particle spacings)
  double volume = 0.25;      ///< |V_A - V_B| / mean area tolerance: a mean surface offset (unit: particle spacings)
  double area = 0.05;        ///< |A_A - A_B| / max(A_A, A_B) tolerance (unit: 1)
  double spacing = 0;        ///< particle spacing (unit: m); 0 = read "particle_spacing:" from the OBJ header
  bool quiet = false;        ///< only the summary line
};

/// Prints a per-frame table; returns 0 when every frame is within tolerance, 1 when not (or
/// when the frame sets differ), 2 when an input is missing or unreadable.
int compareCommand(const CompareOptions& opt, std::ostream& out, std::ostream& err);

}  // namespace sph::app

// Measurements on particle frames shared by the benchmark and the tests: the dam-break surge
// front and its error against Martin & Moyce (1952), and pressure probes.
#pragma once

#include "core/particle_frame.h"

#include <string>
#include <vector>

namespace sph::app {

/// Leading edge of the fluid along +x (unit: m): the largest x such that at least `min_row`
/// particles lie in the slice [x - dx, x], i.e. a full row of particles across the tank rather
/// than a droplet jetted ahead of the surge (SPH tips shed single particles; Martin & Moyce read
/// the front of the water body from photographs). min_row = 1 gives the largest x of any particle.
double surgeFront(const ParticleFrame& f, double dx, std::size_t min_row);

/// A (T, Z) reference table read from a CSV file whose '#' lines are comments and whose first
/// other line is a header (the format of shared/reference/). Throws InputError on a bad file.
struct Table {
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;
  std::vector<double> column(const std::string& name) const;
};
Table readCsvTable(const std::string& path);

/// Dam-break front error against Martin & Moyce: for each experimental point (T_e, Z_e) with
/// zmin <= Z_e <= zmax, the simulated front Z_s at T_e - shift (linear interpolation of the
/// simulated series; T = t sqrt(2 g / a), Z = x / a). Returns the largest and mean relative error
/// |Z_s - Z_e| / Z_e, and the number of points compared (0 if the run is too short).
struct FrontPoint {
  double T_exp = 0, Z_exp = 0;  ///< the measurement (unit: 1)
  double Z_sim = 0;             ///< the simulated front at T_exp - shift (unit: 1)
  double rel = 0;               ///< |Z_sim - Z_exp| / Z_exp (unit: 1)
};
struct FrontError {
  double max_rel = 0, mean_rel = 0;
  int points = 0;
  std::vector<FrontPoint> detail;  ///< each point compared, in the table's order
};
FrontError frontError(const std::vector<double>& T_sim, const std::vector<double>& Z_sim,
                      const std::vector<double>& T_exp, const std::vector<double>& Z_exp, double shift,
                      double zmin, double zmax);

}  // namespace sph::app

// The small commands: validate, schema, devices, and the benchmark.
#pragma once

#include <iostream>
#include <string>
#include <vector>

namespace sph::app {

/// Loads and compiles each scene; prints every problem; returns 0 if all are valid, 2 otherwise.
/// `max_memory`: refuse scenes whose estimated memory exceeds it (unit: bytes; 0 = the machine's).
int validateCommand(const std::vector<std::string>& files, double max_memory = 0, std::ostream& out = std::cout,
                    std::ostream& err = std::cerr);
/// "8G", "512M", "2GiB", "1e9" -> bytes (k, M, G, T: powers of 1000; Ki, Mi, Gi, Ti: of 1024; an
/// optional trailing B). Returns a negative value when the text is not such a size.
double parseBytes(const std::string& text);
/// Prints the schema table.
int schemaCommand();
/// Prints every OpenCL device with its index; returns 3 if there is none.
int devicesCommand();

struct BenchOptions {
  std::string out = "bench";
  std::string device;
  std::vector<long> sizes{10000, 50000, 100000};
  std::vector<int> substeps{2, 4};
  int frames = 3;   // ~150 steps each at 50k: CFL control sets the steps, not the frames
  int repeats = 3;
  bool speed_only = false;
  bool accuracy_only = false;
  std::vector<long> iso_sizes{50000};  // particle counts for the isosurface table (its target size)
  bool iso = true;        // the isosurface table (off / on / on + export)
  bool iso_only = false;  // only the isosurface table
  bool cloth = true;       // the cloth stability sweep (stiffness x step, both solvers)
  bool cloth_only = false; // only the cloth sweep
  bool forces = true;        // the force checks of bodies in water (issue 15)
  bool forces_only = false;  // only the force checks
  std::vector<std::string> force_solvers{"wcsph"};  // fluid.solver values for the force checks (dfsph-ghost:
                                                   // dfsph with boundary_velocity ghost)
  // which groups of force checks to run (forceCheckGroups() in cli/bench.cpp lists them); empty: all
  std::vector<std::string> force_checks;
  bool force_long_tank = true;  // the force checks' Re-20 rows in the 80 cm tank (DFSPH; minutes per run)
  bool impact = true;        // the impact pressure on the far wall, both solvers (with the accuracy table)
  bool impact_only = false;  // only the impact pressure
  long impact_size = 12000;  // particles of the impact runs (the accuracy table's middle resolution)
  // The accuracy table's runs: particle counts, solvers (wcsph, dfsph with the scene's walls, or
  // dfsph-mirrored / dfsph-single / dfsph-extrapolated), Courant numbers and WCSPH's equations of state.
  std::vector<long> accuracy_sizes{4000, 12000, 30000};
  std::vector<std::string> accuracy_solvers{"wcsph", "dfsph"};
  std::vector<double> accuracy_cfls{0.4, 0.2};
  std::vector<std::string> accuracy_eos{"linear", "tait"};
  // Scene overrides (KEY=VALUE, as run --set) added to every accuracy run after the bench's own:
  // to compare one setting's front against the default's.
  std::vector<std::string> accuracy_sets;
  double accuracy_until = 3.6;  ///< end of the accuracy runs in T = t sqrt(2 g / a) (unit: 1)
};

/// Speed table (dam break at several sizes and substep counts) and accuracy-versus-time table
/// (dam-break front against Martin & Moyce 1952); prints both and writes CSV files.
int benchCommand(const BenchOptions& opt);

}  // namespace sph::app

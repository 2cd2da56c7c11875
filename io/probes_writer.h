// probes.csv (scene section `probes`): one row per sample, one column group per probe and gauge.
#pragma once

#include "core/probes.h"
#include "core/scene_spec.h"

#include <fstream>
#include <string>
#include <vector>

namespace sph::io {

/// probes.csv: opens with '#' lines (what each column is, units), then a header row
/// `time,<probe>_pressure,<probe>_density,<probe>_vx,<probe>_vy,<probe>_vz,...,<gauge>_height,...`,
/// then one row per sample. A dry probe (not in the fluid) reads nan.
class ProbesCsvWriter {
 public:
  /// Creates (truncates) the file. Throws std::runtime_error naming it when it cannot be opened.
  ProbesCsvWriter(const std::string& path, const ProbesSpec& spec);
  void write(const std::vector<ProbeSample>& samples);
  void close();

 private:
  std::string path_;
  std::ofstream out_;
};

/// The header comment and column row of probes.csv for these probes.
std::string probesCsvHeader(const ProbesSpec& spec);

}  // namespace sph::io

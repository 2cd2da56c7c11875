#include "cli/analysis.h"

#include "core/errors.h"

#include <algorithm>
#include <functional>
#include <cmath>
#include <fstream>
#include <sstream>

namespace sph::app {

double surgeFront(const ParticleFrame& f, double dx, std::size_t min_row) {
  std::vector<double> xs(f.x.begin(), f.x.end());
  if (xs.empty()) return -INFINITY;
  std::sort(xs.begin(), xs.end(), std::greater<double>());
  min_row = std::max<std::size_t>(min_row, 1);
  // Two pointers over x in decreasing order: the slice [xs[i] - dx, xs[i]] holds xs[i..j].
  std::size_t j = 0;
  for (std::size_t i = 0; i < xs.size(); ++i) {
    j = std::max(j, i);
    while (j + 1 < xs.size() && xs[j + 1] >= xs[i] - dx) ++j;
    if (j - i + 1 >= min_row) return xs[i];
  }
  return xs.back();
}

std::vector<double> Table::column(const std::string& name) const {
  auto it = std::find(columns.begin(), columns.end(), name);
  SPH_ASSERT(it != columns.end(), "no column '" + name + "'");
  const std::size_t c = static_cast<std::size_t>(it - columns.begin());
  std::vector<double> v;
  for (const auto& r : rows) v.push_back(r[c]);
  return v;
}

Table readCsvTable(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, 0, "cannot open the reference table");
  Table t;
  std::string line;
  int lineno = 0;
  auto split = [](const std::string& s) {
    std::vector<std::string> out;
    std::stringstream ss(s);
    std::string cell;
    while (std::getline(ss, cell, ',')) out.push_back(cell);
    return out;
  };
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty() || line[0] == '#') continue;
    if (t.columns.empty()) {
      t.columns = split(line);
      continue;
    }
    std::vector<double> row;
    for (const std::string& cell : split(line)) {
      try {
        row.push_back(std::stod(cell));
      } catch (...) {
        throw InputError(path, lineno, 1, "not a number: '" + cell + "'");
      }
    }
    if (row.size() != t.columns.size()) throw InputError(path, lineno, 1, "wrong number of columns");
    t.rows.push_back(row);
  }
  if (t.rows.empty()) throw InputError(path, 0, 0, "the table has no data");
  return t;
}

FrontError frontError(const std::vector<double>& T_sim, const std::vector<double>& Z_sim,
                      const std::vector<double>& T_exp, const std::vector<double>& Z_exp, double shift,
                      double zmin, double zmax) {
  FrontError e;
  double sum = 0;
  for (std::size_t k = 0; k < T_exp.size(); ++k) {
    if (Z_exp[k] < zmin || Z_exp[k] > zmax) continue;
    const double T = T_exp[k] - shift;  // simulated time that corresponds to this measurement
    // linear interpolation in the simulated series
    auto it = std::lower_bound(T_sim.begin(), T_sim.end(), T);
    if (it == T_sim.end() || it == T_sim.begin()) continue;
    const std::size_t i = static_cast<std::size_t>(it - T_sim.begin());
    const double w = (T - T_sim[i - 1]) / (T_sim[i] - T_sim[i - 1]);
    const double Z = Z_sim[i - 1] + w * (Z_sim[i] - Z_sim[i - 1]);
    const double rel = std::abs(Z - Z_exp[k]) / Z_exp[k];
    e.max_rel = std::max(e.max_rel, rel);
    e.detail.push_back({T_exp[k], Z_exp[k], Z, rel});
    sum += rel;
    ++e.points;
  }
  e.mean_rel = e.points ? sum / e.points : 0.0;
  return e;
}

}  // namespace sph::app

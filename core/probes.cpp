#include "core/probes.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sph {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kWet = 0.5;  // fill at the free surface (see core/probes.h)
}  // namespace

double probeFill(const float* s) {
  // Inside a wall the non-wall part of the kernel vanishes: keep the ratio finite there.
  const double open = std::max(1.0 - static_cast<double>(s[7]), 0.05);
  return static_cast<double>(s[6]) / open;
}

ProbeSample::Point probeValue(const float* s) {
  ProbeSample::Point p;
  if (!(s[0] > 0.0f) || probeFill(s) < kWet) {
    p.pressure = p.density = kNaN;
    p.velocity = Eigen::Vector3d::Constant(kNaN);
    return p;
  }
  const double S = s[0];
  p.pressure = s[1] / S;
  p.density = s[2] / S;
  p.velocity = Eigen::Vector3d(s[3], s[4], s[5]) / S;
  return p;
}

double gaugeHeight(const float* sums, std::size_t count, double dz) {
  if (count == 0 || probeFill(sums) < kWet) return 0.0;  // dry at the foot: no column
  for (std::size_t k = 1; k < count; ++k) {
    const double below = probeFill(sums + 8 * (k - 1)), here = probeFill(sums + 8 * k);
    if (here < kWet) return dz * (static_cast<double>(k - 1) + (below - kWet) / (below - here));
  }
  return dz * static_cast<double>(count - 1);  // wet to the top
}

ProbeSampler::ProbeSampler(const Model& model, ClContext& cl) : rate_(model.spec.probes.rate) {
  const ProbesSpec& spec = model.spec.probes;
  for (const PointProbeSpec& p : spec.points) points_.emplace_back(p.position.cast<float>().homogeneous());
  num_point_probes_ = points_.size();
  // Gauges: a sample every dx/4 from the foot to the top of the line (or of the domain).
  dz_ = 0.25 * model.dx;
  const double top = model.spec.domain.max.z();
  for (const GaugeSpec& g : spec.gauges) {
    const double length = g.length > 0 ? std::min(g.length, top - g.position.z()) : top - g.position.z();
    const std::size_t n = static_cast<std::size_t>(std::floor(std::max(length, 0.0) / dz_ + 1e-9)) + 1;
    gauge_first_.push_back(points_.size());
    gauge_count_.push_back(n);
    for (std::size_t k = 0; k < n; ++k)
      points_.emplace_back(static_cast<float>(g.position.x()), static_cast<float>(g.position.y()),
                           static_cast<float>(g.position.z() + dz_ * static_cast<double>(k)), 1.0f);
  }
  const std::size_t n = std::max<std::size_t>(points_.size(), 1);
  clCall("allocating the probe buffers", [&] {
    point_buf_ = cl::Buffer(cl.context(), CL_MEM_READ_ONLY, n * 16);
    sum_buf_ = cl::Buffer(cl.context(), CL_MEM_WRITE_ONLY, n * 32);
    if (!points_.empty()) cl.queue().enqueueWriteBuffer(point_buf_, CL_TRUE, 0, points_.size() * 16, points_.data());
    return 0;
  });
}

bool ProbeSampler::due(double t) const {
  if (rate_ <= 0) return true;
  return t * rate_ >= static_cast<double>(next_index_) - 1e-9;
}

void ProbeSampler::taken(double t) {
  if (rate_ > 0) next_index_ = static_cast<long>(std::floor(t * rate_ + 1e-9)) + 1;
}

ProbeSample ProbeSampler::reduce(double t, const std::vector<float>& sums) const {
  ProbeSample s;
  s.time = t;
  for (std::size_t i = 0; i < num_point_probes_; ++i) s.points.push_back(probeValue(&sums[8 * i]));
  for (std::size_t g = 0; g < gauge_first_.size(); ++g)
    s.heights.push_back(gaugeHeight(&sums[8 * gauge_first_[g]], gauge_count_[g], dz_));
  return s;
}

}  // namespace sph

// Probes: the fluid sampled at fixed points and along vertical gauges, the way an experiment's
// pressure sensors and wave gauges read it, so that a run can be checked against measurements.
//
//   scene `probes` ──compile──► sample points (point probes, then each gauge's line every dx/4)
//        │                                   │ kernels/probes.cl, one work-item per point:
//        │                                   ▼ Shepard sums, fill field F, wall share B
//   every step (or at probes.rate) ──► ProbeSample{time, pressure/density/velocity per point,
//                                                   column height per gauge} ──► probes.csv
//
// Point probes (Shepard 1968 normalisation of the SPH interpolant):
//     A(x) = sum_j V_j A_j W(x - x_j) / sum_j V_j W(x - x_j),   V_j = m_j / rho_j
// exact for constant fields, and for linear ones where the neighbourhood is symmetric; against a
// wall it averages the fluid side only. A point is wet when the kernel's non-wall part is at least
// half full of fluid, fill = F / (1 - B) >= 1/2 with F = sum_j V0 W (the isosurface's field) and
// B = sum_b V_b W (walls and bodies); a dry point reads NaN.
// Gauges: fill is sampled every dx/4 from the foot up; the height is where it first falls
// through 1/2 (linear between samples), the same level as the isosurface's surface; a gauge whose
// foot is dry reads 0, one that is wet to its top reads its length.
#pragma once

#include "core/cl_context.h"
#include "core/model.h"

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace sph {

/// One sample of every probe and gauge, in scene order.
struct ProbeSample {
  struct Point {
    double pressure = 0;                                ///< (unit: Pa); NaN when dry
    double density = 0;                                 ///< (unit: kg/m^3); NaN when dry
    Eigen::Vector3d velocity = Eigen::Vector3d::Zero(); ///< (unit: m/s); NaN when dry
  };
  double time = 0;              ///< simulated time of the state sampled (unit: s)
  std::vector<Point> points;    ///< one per probes.points entry
  std::vector<double> heights;  ///< one per probes.gauges entry: column height above the foot (unit: m)
};

/// The kernel's eight sums at one sample point (kernels/probes.cl), reduced on the host.
/// sums: S, S_p, S_rho, S_v (3), F, B.
ProbeSample::Point probeValue(const float* sums);
/// How full of fluid the kernel's non-wall part is at a sample point: F / (1 - B) (unit: 1).
double probeFill(const float* sums);
/// Height above the first sample where the fill first drops below 1/2, from `count` samples
/// (8 sums each) spaced dz apart going up (unit: m).
double gaugeHeight(const float* sums, std::size_t count, double dz);

/// The probe stage: the sample points on the device and the read-back of their sums.
class ProbeSampler {
 public:
  ProbeSampler(const Model& model, ClContext& cl);
  /// True when a sample is due at time t (unit: s): every step with rate 0, else the first step
  /// at or after each multiple of 1 / rate.
  bool due(double t) const;
  /// Marks the sample at time t as taken.
  void taken(double t);
  std::size_t numPoints() const { return points_.size(); }
  const cl::Buffer& pointBuffer() const { return point_buf_; }
  const cl::Buffer& sumBuffer() const { return sum_buf_; }
  /// Turns the sums read back from sumBuffer() (8 per sample point) into a sample.
  ProbeSample reduce(double t, const std::vector<float>& sums) const;
  std::size_t bytes() const { return points_.size() * 48; }

 private:
  double rate_ = 0;                     // (unit: 1/s)
  long next_index_ = 0;                 // next multiple of 1 / rate to sample at
  std::size_t num_point_probes_ = 0;
  std::vector<std::size_t> gauge_first_, gauge_count_;  // each gauge's run of sample points
  double dz_ = 0;                       // gauge sample spacing (unit: m)
  std::vector<Eigen::Vector4f> points_; // every sample point (unit: m)
  cl::Buffer point_buf_, sum_buf_;
};

}  // namespace sph

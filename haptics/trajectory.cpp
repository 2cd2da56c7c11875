#include "haptics/trajectory.h"

#include <algorithm>
#include <cmath>

namespace sph::haptics {

static constexpr double kTwoPi = 6.283185307179586;

Trajectory::Trajectory(std::vector<Segment> segments, std::vector<ButtonEvent> events, Eigen::Vector3d rest)
    : segments_(std::move(segments)), events_(std::move(events)), rest_(rest) {
  // A waypoint list spans its first to its last time.
  for (Segment& s : segments_)
    if (s.kind == SegmentKind::Waypoints && !s.times.empty()) { s.t0 = s.times.front(); s.t1 = s.times.back(); }
  // Stable sorts: equal start times keep the scene's order.
  std::stable_sort(segments_.begin(), segments_.end(), [](const Segment& a, const Segment& b) { return a.t0 < b.t0; });
  std::stable_sort(events_.begin(), events_.end(), [](const ButtonEvent& a, const ButtonEvent& b) { return a.time < b.time; });
}

std::string Trajectory::check(const Segment& s) {
  switch (s.kind) {
    case SegmentKind::Waypoints:
      if (s.points.size() < 1 || s.points.size() != s.times.size()) return "waypoints need one time per point (at least one)";
      for (std::size_t i = 1; i < s.times.size(); ++i)
        if (!(s.times[i] > s.times[i - 1])) return "waypoint times must increase";
      return {};
    case SegmentKind::Line:
      return s.t1 > s.t0 ? std::string() : "a line needs end > start";
    case SegmentKind::Circle:
      if (!(s.radius > 0)) return "circle radius must be > 0";
      if (!(s.period > 0)) return "circle period must be > 0";
      if (s.axis.norm() < 1e-12) return "circle axis must not be zero";
      return s.t1 > s.t0 ? std::string() : "a circle needs end > start";
    case SegmentKind::Sine:
      if (!(s.f0 >= 0) || !(s.f1 >= 0)) return "sine frequencies must be >= 0";
      return s.t1 > s.t0 ? std::string() : "a sine sweep needs end > start";
  }
  return {};
}

PathPoint evaluate(const Segment& s, double t) {
  PathPoint p;
  switch (s.kind) {
    case SegmentKind::Waypoints: {
      // Straight lines between points; held before the first and after the last.
      const auto& ts = s.times;
      if (t <= ts.front()) { p.position = s.points.front(); return p; }
      if (t >= ts.back()) { p.position = s.points.back(); return p; }
      const std::size_t i = static_cast<std::size_t>(std::upper_bound(ts.begin(), ts.end(), t) - ts.begin()) - 1;
      const double h = ts[i + 1] - ts[i];
      p.velocity = (s.points[i + 1] - s.points[i]) / h;
      p.position = s.points[i] + (t - ts[i]) * p.velocity;
      return p;
    }
    case SegmentKind::Line: {
      const double u = std::clamp((t - s.t0) / (s.t1 - s.t0), 0.0, 1.0);
      p.position = s.from + u * (s.to - s.from);
      if (t > s.t0 && t < s.t1) p.velocity = (s.to - s.from) / (s.t1 - s.t0);
      return p;
    }
    case SegmentKind::Circle: {
      // An orthonormal pair (e1, e2) in the plane normal to the axis; angle phase + 2 pi u / period.
      const Eigen::Vector3d n = s.axis.normalized();
      const Eigen::Vector3d ref = std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
      const Eigen::Vector3d e1 = (ref - ref.dot(n) * n).normalized();
      const Eigen::Vector3d e2 = n.cross(e1);
      const double u = std::clamp(t, s.t0, s.t1) - s.t0;
      const double w = kTwoPi / s.period;
      const double th = s.phase + w * u;
      p.position = s.centre + s.radius * (std::cos(th) * e1 + std::sin(th) * e2);
      if (t > s.t0 && t < s.t1) p.velocity = s.radius * w * (-std::sin(th) * e1 + std::cos(th) * e2);
      return p;
    }
    case SegmentKind::Sine: {
      // Linear chirp: phase 2 pi (f0 u + (f1 - f0) u^2 / (2 D)), frequency f0 + (f1 - f0) u / D.
      const double d = s.t1 - s.t0;
      const double u = std::clamp(t, s.t0, s.t1) - s.t0;
      const double ph = kTwoPi * (s.f0 * u + (s.f1 - s.f0) * u * u / (2.0 * d));
      const double f = s.f0 + (s.f1 - s.f0) * u / d;
      p.position = s.centre + s.amplitude * std::sin(ph);
      if (t > s.t0 && t < s.t1) p.velocity = s.amplitude * (kTwoPi * f * std::cos(ph));
      return p;
    }
  }
  return p;
}

PathPoint Trajectory::at(double t) const {
  if (segments_.empty()) return PathPoint{rest_, Eigen::Vector3d::Zero()};
  // The latest segment that has started (the first one before any has).
  std::size_t k = 0;
  for (std::size_t i = 0; i < segments_.size(); ++i)
    if (segments_[i].t0 <= t) k = i;
  const Segment& s = segments_[k];
  if (s.kind == SegmentKind::Waypoints) return evaluate(s, t);
  return evaluate(s, std::max(t, s.t0));
}

uint32_t Trajectory::buttons(double t) const {
  uint32_t b = 0;
  for (const ButtonEvent& e : events_) {
    if (e.time > t) break;
    const uint32_t bit = 1u << static_cast<unsigned>(e.button);
    b = e.pressed ? (b | bit) : (b & ~bit);
  }
  return b;
}

}  // namespace sph::haptics

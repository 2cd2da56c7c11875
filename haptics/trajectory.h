// Scripted hand motion: a path through time made of segments (waypoints, lines, circles, sine
// sweeps) and button events. Used by the scripted device (the path is the device position) and by
// the simulated device (the path is the hand's target).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <string>
#include <vector>

namespace sph::haptics {

enum class SegmentKind { Waypoints, Line, Circle, Sine };

/// One piece of the path, active on [t0, t1]. Positions are in the device frame.
struct Segment {
  SegmentKind kind = SegmentKind::Line;
  double t0 = 0.0;                                   ///< start (unit: s)
  double t1 = 1.0;                                   ///< end; waypoints: the last point's time (unit: s)
  // Waypoints: straight lines between (time, position) pairs, times increasing.
  std::vector<double> times;                         ///< (unit: s)
  std::vector<Eigen::Vector3d> points;               ///< (unit: m)
  // Line: from -> to at constant speed.
  Eigen::Vector3d from = Eigen::Vector3d::Zero();    ///< (unit: m)
  Eigen::Vector3d to = Eigen::Vector3d::Zero();      ///< (unit: m)
  // Circle: centre, radius, axis (normal of the plane), period, starting phase; Sine: centre too.
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  ///< (unit: m)
  double radius = 0.02;                              ///< (unit: m)
  Eigen::Vector3d axis{0.0, 0.0, 1.0};               ///< circle plane normal (normalised on use)
  double period = 1.0;                               ///< one turn (unit: s)
  double phase = 0.0;                                ///< angle at t0 (unit: rad)
  // Sine sweep: centre + amplitude sin(2 pi (f0 u + (f1 - f0) u^2 / (2 (t1 - t0)))), u = t - t0
  // (a linear chirp from f0 to f1).
  Eigen::Vector3d amplitude{0.01, 0.0, 0.0};         ///< (unit: m)
  double f0 = 1.0;                                   ///< start frequency (unit: Hz)
  double f1 = 1.0;                                   ///< end frequency (unit: Hz)
};

/// A button pressed or released at a time.
struct ButtonEvent {
  double time = 0.0;    ///< (unit: s)
  int button = 0;       ///< 0 or 1
  bool pressed = true;
};

/// Position and velocity along the path.
struct PathPoint {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< (unit: m)
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< (unit: m/s)
};

class Trajectory {
 public:
  Trajectory() = default;
  /// Segments in any order (sorted by start time here); events likewise.
  Trajectory(std::vector<Segment> segments, std::vector<ButtonEvent> events,
             Eigen::Vector3d rest = Eigen::Vector3d::Zero());
  /// The path at time t: the latest segment that has started; after its end it holds the end
  /// position at rest; before the first segment, the first segment's start (or `rest` if none).
  PathPoint at(double t) const;
  /// Buttons held at time t (events at or before t applied in order).
  uint32_t buttons(double t) const;
  /// Checks a segment; returns an empty string or what is wrong ("circle radius must be > 0").
  static std::string check(const Segment& s);

 private:
  std::vector<Segment> segments_;
  std::vector<ButtonEvent> events_;
  Eigen::Vector3d rest_ = Eigen::Vector3d::Zero();
};

/// Position and velocity of one segment at time t (clamped to its interval).
PathPoint evaluate(const Segment& s, double t);

}  // namespace sph::haptics

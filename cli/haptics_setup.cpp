#include "cli/haptics_setup.h"

#include "core/mesh_distance.h"

#include <cmath>

namespace sph::app {

haptics::ServoConfig servoConfig(const HapticsSpec& h) {
  haptics::ServoConfig c;
  c.rate = h.servo_rate;
  c.peak_force = h.peak_force;
  c.continuous_force = h.continuous_force;
  c.ramp_time = h.ramp_time;
  c.watchdog = h.watchdog;
  c.lowpass = h.lowpass;
  c.passivity = h.passivity;
  c.smoothing = h.smoothing == HapticSmoothing::RollingAverage ? haptics::Smoothing::RollingAverage : haptics::Smoothing::Servo;
  c.rolling_window = h.rolling_window;
  return c;
}

haptics::Trajectory hapticPath(const HapticsSpec& h) {
  std::vector<haptics::Segment> segments;
  // Segments as written; waypoints (when there is no `path`) as one piecewise-linear segment.
  for (const PathSegmentSpec& p : h.path) {
    haptics::Segment s;
    s.kind = p.type == PathSegmentType::Line ? haptics::SegmentKind::Line
             : p.type == PathSegmentType::Circle ? haptics::SegmentKind::Circle
                                                 : haptics::SegmentKind::Sine;
    s.t0 = p.start;
    s.t1 = p.end;
    s.from = p.from;
    s.to = p.to;
    s.centre = p.centre;
    s.radius = p.radius;
    s.axis = p.axis;
    s.period = p.period;
    s.phase = p.phase;
    s.amplitude = p.amplitude;
    s.f0 = p.f0;
    s.f1 = p.f1;
    segments.push_back(s);
  }
  if (h.path.empty() && !h.waypoints.empty()) {
    haptics::Segment s;
    s.kind = haptics::SegmentKind::Waypoints;
    for (const WaypointSpec& w : h.waypoints) {
      s.times.push_back(w.time);
      s.points.push_back(w.position);
    }
    segments.push_back(s);
  }
  std::vector<haptics::ButtonEvent> events;
  for (const ButtonEventSpec& b : h.buttons) events.push_back({b.time, b.button, b.pressed});
  return haptics::Trajectory(std::move(segments), std::move(events));
}

haptics::Mapping hapticMapping(const SceneSpec& spec) {
  const HapticsSpec& h = spec.haptics;
  haptics::Mapping m;
  // The device's ~0.15 m workspace spans the scene's largest extent unless a scale is given.
  m.scale = h.scale > 0 ? h.scale : (spec.domain.max - spec.domain.min).maxCoeff() / 0.15;
  m.rotation = Eigen::AngleAxisd(h.rotation_angle * M_PI / 180.0, h.rotation_axis.normalized()).toRotationMatrix();
  m.offset = h.offset;
  return m;
}

namespace {

// The device backend on `clock`, and the grab controller, of a compiled model's `haptics` section.
std::unique_ptr<haptics::Device> makeDevice(const SceneSpec& spec, const haptics::Clock& clock,
                                            std::shared_ptr<haptics::MouseInput> mouse) {
  const HapticsSpec& h = spec.haptics;
  if (mouse) return std::make_unique<haptics::MouseDevice>(std::move(mouse), clock, hapticMapping(spec));
  if (h.backend == HapticBackend::Simulated) {
    haptics::SimulatedHand hand;
    hand.mass = h.hand_mass;
    hand.hand_stiffness = h.hand_stiffness;
    hand.hand_damping = h.hand_damping;
    return std::make_unique<haptics::SimulatedDevice>(hapticPath(h), clock, hand);
  }
  return std::make_unique<haptics::ScriptedDevice>(hapticPath(h), clock);
}

haptics::GrabController makeGrab(const Model& model) {
  const HapticsSpec& h = model.spec.haptics;
  // Grabbable dynamic bodies, each with a closest-surface-point query on its mesh (body frame).
  std::vector<haptics::Grabbable> candidates;
  for (std::size_t b = 0; b < model.bodies.size(); ++b) {
    const rigid::RigidBody& body = model.bodies[b];
    if (!body.spec.grabbable || body.kind != rigid::BodyKind::Dynamic) continue;
    auto index = std::make_shared<SurfaceIndex>(body.mesh);
    candidates.push_back({b, body.mass, [index](const Eigen::Vector3d& p) { return index->nearest(p).point; }, body.inertia});
  }
  haptics::GrabSettings g;
  g.gain = h.gain;
  g.stiffness = h.stiffness;
  g.damping = h.damping;
  g.damping_ratio = h.damping_ratio;
  g.reach = h.reach;
  g.ttl = h.watchdog;
  g.force_as_feed_forward = h.smoothing == HapticSmoothing::RollingAverage;
  g.hold_orientation = h.hold_orientation;
  return haptics::GrabController(hapticMapping(model.spec), g, std::move(candidates));
}

}  // namespace

std::unique_ptr<haptics::BatchSession> makeBatchSession(const Model& model, std::shared_ptr<haptics::MouseInput> mouse) {
  auto clock = std::make_shared<haptics::VirtualClock>();
  auto device = makeDevice(model.spec, *clock, std::move(mouse));
  return std::make_unique<haptics::BatchSession>(std::move(device), clock, servoConfig(model.spec.haptics), makeGrab(model));
}

std::unique_ptr<haptics::LiveSource> makeLiveSession(const Model& model, std::shared_ptr<haptics::MouseInput> mouse) {
  const HapticsSpec& h = model.spec.haptics;
  if (h.backend == HapticBackend::Bridge && !mouse) {
    haptics::BridgeSettings b;
    b.bridge_port = static_cast<uint16_t>(h.bridge_port);
    b.listen_port = static_cast<uint16_t>(h.listen_port);
    b.timeout = h.bridge_timeout;
    b.max_force = h.peak_force;
    return std::make_unique<haptics::BridgeSession>(b, servoConfig(h), makeGrab(model));
  }
  auto clock = std::make_shared<haptics::SteadyClock>();
  auto device = makeDevice(model.spec, *clock, std::move(mouse));
  return std::make_unique<haptics::LiveSession>(std::move(device), clock, servoConfig(h), makeGrab(model));
}

std::unique_ptr<haptics::ReplaySource> makeReplaySource(const Model& model, const haptics::Recording& rec) {
  return std::make_unique<haptics::ReplaySource>(rec.steps, rec.step_hashes, makeGrab(model));
}

}  // namespace sph::app

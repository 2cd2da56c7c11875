#include "haptics/record.h"

#include <cinttypes>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace sph::haptics {

void writeRecording(const std::string& path, const Recording& rec) {
  std::ofstream out(path, std::ios::trunc);
  if (!out) throw DeviceError("cannot write the recording " + path);
  out << "# sphaptics haptic recording v1\n";
  out << "scene " << rec.scene << "\n";
  for (const std::string& s : rec.sets) out << "set " << s << "\n";
  out << "frames " << rec.frames << "\n";
  char buf[512];
  for (const DeviceState& s : rec.steps) {
    std::snprintf(buf, sizeof buf, "step %.17g %.17g %.17g %.17g %.17g %.17g %.17g %u\n", s.time, s.position.x(),
                  s.position.y(), s.position.z(), s.velocity.x(), s.velocity.y(), s.velocity.z(), s.buttons);
    out << buf;
  }
  for (std::size_t f = 0; f < rec.hashes.size(); ++f) {
    std::snprintf(buf, sizeof buf, "hash %zu %016" PRIx64 "\n", f, rec.hashes[f]);
    out << buf;
  }
  if (!out) throw DeviceError("cannot write the recording " + path);
}

Recording readRecording(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw DeviceError(path + ": cannot open the recording");
  Recording rec;
  std::string line;
  int n = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++n;
    auto bad = [&](const std::string& what) { return DeviceError(path + ":" + std::to_string(n) + ":1: " + what); };
    if (n == 1) {
      header = line == "# sphaptics haptic recording v1";
      if (!header) throw bad("not a sphaptics haptic recording (first line must be '# sphaptics haptic recording v1')");
      continue;
    }
    std::istringstream s(line);
    std::string key;
    s >> key;
    if (key == "scene") {
      std::getline(s >> std::ws, rec.scene);
    } else if (key == "set") {
      std::string v;
      std::getline(s >> std::ws, v);
      rec.sets.push_back(v);
    } else if (key == "frames") {
      if (!(s >> rec.frames) || rec.frames < 0) throw bad("'frames' needs a count");
    } else if (key == "step") {
      DeviceState d;
      if (!(s >> d.time >> d.position.x() >> d.position.y() >> d.position.z() >> d.velocity.x() >> d.velocity.y() >>
            d.velocity.z() >> d.buttons))
        throw bad("'step' needs time, position (3), velocity (3) and buttons");
      rec.steps.push_back(d);
    } else if (key == "hash") {
      std::size_t frame;
      std::string hex;
      if (!(s >> frame >> hex) || frame != rec.hashes.size() || hex.size() != 16)
        throw bad("'hash' needs the next frame index and 16 hex digits");
      rec.hashes.push_back(std::stoull(hex, nullptr, 16));
    } else if (!key.empty() && key[0] != '#') {
      throw bad("unknown line '" + key + "'");
    }
  }
  if (!header) throw DeviceError(path + ": empty recording");
  if (rec.scene.empty()) throw DeviceError(path + ": no 'scene' line");
  if (static_cast<int>(rec.hashes.size()) != rec.frames)
    throw DeviceError(path + ": " + std::to_string(rec.hashes.size()) + " hashes for " + std::to_string(rec.frames) + " frames");
  return rec;
}

ReplaySource::ReplaySource(std::vector<DeviceState> steps, GrabController grab)
    : steps_(std::move(steps)), grab_(std::move(grab)) {}

void ReplaySource::apply(double, double, const std::vector<rigid::RigidBody>&, const std::vector<rigid::BodyState>& states,
                         std::vector<BodyWrench>& out) {
  // The reading of this step (the last one again if the recording ran out: the replay then differs
  // and the hash check says so).
  if (steps_.empty()) return;
  const DeviceState& s = steps_[std::min(next_, steps_.size() - 1)];
  ++next_;
  grab_.update(s, states, out);
}

}  // namespace sph::haptics

#include "haptics/record.h"

#include <cinttypes>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

namespace sph::haptics {

namespace {
const char* kHeaderV1 = "# sphaptics haptic recording v1";
const char* kHeaderV2 = "# sphaptics haptic recording v2";
}  // namespace

void writeRecording(const std::string& path, const Recording& rec) {
  // Written beside the target and renamed at the end, so a failed write never leaves a file that
  // looks like a complete recording.
  const std::string tmp = path + ".partial";
  std::ofstream out(tmp, std::ios::trunc);
  if (!out) throw RecordingError("cannot write the recording " + path);
  out << kHeaderV2 << "\n";
  out << "scene " << rec.scene << "\n";
  for (const std::string& s : rec.sets) out << "set " << s << "\n";
  out << "frames " << rec.frames << "\n";
  char buf[512];
  // Every tick's reading, then the tick each step used.
  for (const auto& [k, s] : rec.ticks) {
    std::snprintf(buf, sizeof buf, "tick %" PRIu64 " %.17g %.17g %.17g %.17g %.17g %.17g %.17g %u\n", k, s.time,
                  s.position.x(), s.position.y(), s.position.z(), s.velocity.x(), s.velocity.y(), s.velocity.z(), s.buttons);
    out << buf;
  }
  const bool step_hashes = rec.step_hashes.size() == rec.step_ticks.size();
  for (std::size_t i = 0; i < rec.step_ticks.size(); ++i) {
    if (step_hashes)
      std::snprintf(buf, sizeof buf, "step %" PRIu64 " %016" PRIx64 "\n", rec.step_ticks[i], rec.step_hashes[i]);
    else
      std::snprintf(buf, sizeof buf, "step %" PRIu64 "\n", rec.step_ticks[i]);
    out << buf;
  }
  for (const auto& [frame, s] : rec.settings) {
    std::snprintf(buf, sizeof buf, "settings %d %.17g %.17g %.17g %.17g %.17g %s %d\n", frame, s.gain, s.scale,
                  s.offset.x(), s.offset.y(), s.offset.z(),
                  s.smoothing == Smoothing::RollingAverage ? "rolling_average" : "servo", s.rolling_window);
    out << buf;
  }
  for (std::size_t f = 0; f < rec.hashes.size(); ++f) {
    std::snprintf(buf, sizeof buf, "hash %zu %016" PRIx64 "\n", f, rec.hashes[f]);
    out << buf;
  }
  out << "end " << rec.ticks.size() << " " << rec.step_ticks.size() << " " << rec.hashes.size() << "\n";
  out.close();
  std::error_code ec;
  if (out.fail()) {
    std::filesystem::remove(tmp, ec);
    throw RecordingError("cannot write the recording " + path);
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw RecordingError("cannot write the recording " + path + ": " + ec.message());
  }
}

Recording readRecording(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw RecordingError(path + ": cannot open the recording");
  Recording rec;
  std::string line;
  int n = 0, version = 0;
  bool ended = false;
  std::map<uint64_t, DeviceState> ticks;
  while (std::getline(in, line)) {
    ++n;
    auto bad = [&](const std::string& what) { return RecordingError(path + ":" + std::to_string(n) + ":1: " + what); };
    // The header names the format version.
    if (n == 1) {
      version = line == kHeaderV2 ? 2 : line == kHeaderV1 ? 1 : 0;
      if (version == 0) {
        if (line.rfind("# sphaptics haptic recording v", 0) == 0)
          throw bad("recording format '" + line.substr(29) + "' is not one this sphaptics reads (v1, v2)");
        throw bad("not a sphaptics haptic recording (first line must be '" + std::string(kHeaderV2) + "')");
      }
      continue;
    }
    if (ended) throw bad("text after the 'end' line");
    std::istringstream s(line);
    std::string key;
    s >> key;
    auto rest = [&]() {  // nothing may follow the last field
      std::string extra;
      if (s >> extra) throw bad("'" + key + "': unexpected '" + extra + "'");
    };
    if (key == "scene") {
      std::getline(s >> std::ws, rec.scene);
    } else if (key == "set") {
      std::string v;
      std::getline(s >> std::ws, v);
      rec.sets.push_back(v);
    } else if (key == "frames") {
      if (!(s >> rec.frames) || rec.frames < 0) throw bad("'frames' needs a count");
      rest();
    } else if (key == "tick" && version == 2) {
      uint64_t k = 0;
      DeviceState d;
      if (!(s >> k >> d.time >> d.position.x() >> d.position.y() >> d.position.z() >> d.velocity.x() >> d.velocity.y() >>
            d.velocity.z() >> d.buttons))
        throw bad("'tick' needs index, time, position (3), velocity (3) and buttons");
      rest();
      if (!rec.ticks.empty() && k <= rec.ticks.back().first) throw bad("'tick' indices must increase");
      rec.ticks.emplace_back(k, d);
      ticks[k] = d;
    } else if (key == "step" && version == 2) {
      uint64_t k = 0;
      if (!(s >> k)) throw bad("'step' needs the index of the tick it used");
      // An optional hash of the bodies' state: all steps have one or none do.
      std::string hex;
      if (s >> hex) {
        if (hex.size() != 16 || hex.find_first_not_of("0123456789abcdefABCDEF") != std::string::npos)
          throw bad("'step' hash must be 16 hex digits");
        if (rec.step_hashes.size() != rec.step_ticks.size()) throw bad("'step' lines must all have a hash or none");
        rec.step_hashes.push_back(std::stoull(hex, nullptr, 16));
      } else if (!rec.step_hashes.empty()) {
        throw bad("'step' lines must all have a hash or none");
      }
      rest();
      const auto it = ticks.find(k);
      if (it == ticks.end()) throw bad("'step' uses tick " + std::to_string(k) + ", which is not recorded before it");
      rec.step_ticks.push_back(k);
      rec.steps.push_back(it->second);
    } else if (key == "step" && version == 1) {
      DeviceState d;
      if (!(s >> d.time >> d.position.x() >> d.position.y() >> d.position.z() >> d.velocity.x() >> d.velocity.y() >>
            d.velocity.z() >> d.buttons))
        throw bad("'step' needs time, position (3), velocity (3) and buttons");
      rec.steps.push_back(d);
    } else if (key == "settings" && version == 2) {
      int frame = 0;
      LiveSettings st;
      std::string mode;
      if (!(s >> frame >> st.gain >> st.scale >> st.offset.x() >> st.offset.y() >> st.offset.z() >> mode >> st.rolling_window) ||
          frame < 0 || (mode != "servo" && mode != "rolling_average") || !(st.gain >= 0) || !(st.scale > 0))
        throw bad("'settings' needs frame, gain >= 0, scale > 0, offset (3), servo|rolling_average and a window");
      rest();
      st.smoothing = mode == "servo" ? Smoothing::Servo : Smoothing::RollingAverage;
      rec.settings.emplace_back(frame, st);
    } else if (key == "hash") {
      std::size_t frame;
      std::string hex;
      if (!(s >> frame >> hex) || frame != rec.hashes.size() || hex.size() != 16 ||
          hex.find_first_not_of("0123456789abcdefABCDEF") != std::string::npos)
        throw bad("'hash' needs the next frame index and 16 hex digits");
      rest();
      rec.hashes.push_back(std::stoull(hex, nullptr, 16));
    } else if (key == "end" && version == 2) {
      std::size_t nt = 0, ns = 0, nh = 0;
      if (!(s >> nt >> ns >> nh)) throw bad("'end' needs the counts of ticks, steps and hashes");
      rest();
      if (nt != rec.ticks.size() || ns != rec.step_ticks.size() || nh != rec.hashes.size())
        throw bad("'end' counts " + std::to_string(nt) + " ticks, " + std::to_string(ns) + " steps, " +
                  std::to_string(nh) + " hashes; the file holds " + std::to_string(rec.ticks.size()) + ", " +
                  std::to_string(rec.step_ticks.size()) + ", " + std::to_string(rec.hashes.size()));
      ended = true;
    } else if (!key.empty() && key[0] != '#') {
      throw bad("unknown line '" + key + "'");
    }
  }
  // Whole-file checks: header, scene, one hash per frame, the end marker (v2).
  if (version == 0) throw RecordingError(path + ": empty recording");
  if (version == 2 && !ended)
    throw RecordingError(path + ":" + std::to_string(n) + ":1: truncated recording (no 'end' line after line " +
                         std::to_string(n) + ")");
  if (rec.scene.empty()) throw RecordingError(path + ": no 'scene' line");
  if (static_cast<int>(rec.hashes.size()) != rec.frames)
    throw RecordingError(path + ": " + std::to_string(rec.hashes.size()) + " hashes for " + std::to_string(rec.frames) + " frames");
  return rec;
}

ReplaySource::ReplaySource(std::vector<DeviceState> steps, std::vector<uint64_t> step_hashes, GrabController grab)
    : steps_(std::move(steps)), step_hashes_(std::move(step_hashes)), grab_(std::move(grab)) {}

void ReplaySource::apply(double, double dt, const std::vector<rigid::RigidBody>&, const std::vector<rigid::BodyState>& states,
                         std::vector<BodyWrench>& out) {
  // The reading of this step (the last one again if the recording ran out: the replay then differs
  // and the hash check says so).
  if (steps_.empty()) return;
  if (first_diff_ == 0 && next_ < step_hashes_.size() && rigid::hashStates(states) != step_hashes_[next_])
    first_diff_ = next_ + 1;
  const DeviceState& s = steps_[std::min(next_, steps_.size() - 1)];
  ++next_;
  grab_.update(s, states, out, dt);
}

}  // namespace sph::haptics

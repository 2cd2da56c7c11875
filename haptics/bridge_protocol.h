// The bridge protocol: UDP datagrams between the simulation and a bridge program next to a real
// device (../shared/haptics.md, "Bridge protocol"). Little-endian, packed, fixed sizes:
//
//   header (16 bytes): magic "SPHB", version u16, type u16, sequence u32, flags u32
//   State      (bridge -> sim, 1 kHz): time, position[3], orientation[4] (w x y z), velocity[3],
//              force[3] (f64 each), buttons u32, servo_rate f64, overruns u32       = 16 + 128 bytes
//   LocalModel (sim -> bridge, per frame): state_sequence u32 (the last State seen, for the round
//              trip time), state_time, anchor[3], anchor_velocity[3], feed_forward[3], stiffness,
//              damping, max_force, ttl (f64 each), coupled u32, reserved u32        = 16 + 124 bytes
//
// A receiver rejects any datagram of the wrong size, magic, version or type, or with a non-finite
// number, and keeps only packets newer than the newest it accepted (SequenceFilter): stale and
// duplicated ones are dropped. The bridge never trusts the simulation: sanitize() caps a
// LocalModel to the device's spec before the servo sees it.
#pragma once

#include "haptics/device.h"
#include "haptics/servo.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace sph::haptics::bridge {

inline constexpr uint32_t kMagic = 0x42485053u;  // "SPHB" read as a little-endian u32
inline constexpr uint16_t kVersion = 1;
enum class PacketType : uint16_t { State = 1, LocalModel = 2 };
inline constexpr std::size_t kHeaderBytes = 16;
inline constexpr std::size_t kStateBytes = kHeaderBytes + 8 + 24 + 32 + 24 + 24 + 4 + 8 + 4;  // 144
inline constexpr std::size_t kLocalModelBytes = kHeaderBytes + 4 + 8 + 72 + 32 + 4 + 4;  // 140

struct Header {
  uint16_t version = kVersion;
  PacketType type = PacketType::State;
  uint32_t sequence = 0;
  uint32_t flags = 0;
};

/// State: the device as the bridge's servo last read it.
struct StatePacket {
  Header header;
  DeviceState state;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  ///< force applied (unit: N)
  double servo_rate = 0;                            ///< measured (unit: Hz)
  uint32_t overruns = 0;                            ///< servo periods missed so far
};

/// LocalModel: what the simulation asks the bridge's servo to render.
struct LocalModelPacket {
  Header header;
  uint32_t state_sequence = 0;  ///< the last State the simulation saw
  double state_time = 0;        ///< its time (unit: s)
  LocalModel model;             ///< stamp unused on the wire (the bridge stamps on arrival)
  double max_force = 3.0;       ///< the simulation's force limit (unit: N)
};

enum class DecodeError { None, Short, Long, BadMagic, BadVersion, BadType, NonFinite };
const char* decodeErrorName(DecodeError e);

std::vector<uint8_t> encode(const StatePacket& p);
std::vector<uint8_t> encode(const LocalModelPacket& p);
/// The type of a datagram (after checking size, magic and version), or an error.
DecodeError peekType(const uint8_t* data, std::size_t n, PacketType& type);
DecodeError decode(const uint8_t* data, std::size_t n, StatePacket& out);
DecodeError decode(const uint8_t* data, std::size_t n, LocalModelPacket& out);

/// Newest wins: accepts a sequence number only if it is after the last accepted one (serial
/// number arithmetic, RFC 1982, so the 32-bit counter may wrap).
class SequenceFilter {
 public:
  bool accept(uint32_t sequence);
  uint64_t accepted() const { return accepted_; }
  uint64_t dropped() const { return dropped_; }

 private:
  bool any_ = false;
  uint32_t last_ = 0;
  uint64_t accepted_ = 0, dropped_ = 0;
};

/// The bridge's guard: stiffness, damping, feed-forward and force limit capped by the device spec;
/// a ttl capped at 0.1 s. `stamp`: the (bridge clock) time of the state the model describes;
/// `received`: when it arrived (< 0: at `stamp`) (unit: s).
LocalModel sanitize(const LocalModelPacket& p, const DeviceSpec& spec, double stamp, double received = -1);

}  // namespace sph::haptics::bridge

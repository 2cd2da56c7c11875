#include "haptics/bridge_protocol.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace sph::haptics::bridge {

namespace {

// Little-endian writer and reader of fixed-size fields (independent of the host's byte order).
struct Writer {
  std::vector<uint8_t> bytes;
  void u16(uint16_t v) { for (int i = 0; i < 2; ++i) bytes.push_back(static_cast<uint8_t>(v >> (8 * i))); }
  void u32(uint32_t v) { for (int i = 0; i < 4; ++i) bytes.push_back(static_cast<uint8_t>(v >> (8 * i))); }
  void u64(uint64_t v) { for (int i = 0; i < 8; ++i) bytes.push_back(static_cast<uint8_t>(v >> (8 * i))); }
  void f64(double v) {
    uint64_t u;
    std::memcpy(&u, &v, 8);
    u64(u);
  }
  void vec(const Eigen::Vector3d& v) { f64(v.x()), f64(v.y()), f64(v.z()); }
  void header(const Header& h) {
    u32(kMagic);
    u16(h.version);
    u16(static_cast<uint16_t>(h.type));
    u32(h.sequence);
    u32(h.flags);
  }
};

struct Reader {
  const uint8_t* p;
  bool finite = true;
  uint64_t uint(int n) {
    uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= static_cast<uint64_t>(p[i]) << (8 * i);
    p += n;
    return v;
  }
  uint16_t u16() { return static_cast<uint16_t>(uint(2)); }
  uint32_t u32() { return static_cast<uint32_t>(uint(4)); }
  double f64() {
    const uint64_t u = uint(8);
    double v;
    std::memcpy(&v, &u, 8);
    finite = finite && std::isfinite(v);
    return v;
  }
  Eigen::Vector3d vec() {
    const double x = f64(), y = f64(), z = f64();
    return {x, y, z};
  }
};

// Size, magic, version and type of a datagram that should be of `type` and `size` bytes.
DecodeError check(const uint8_t* data, std::size_t n, PacketType want, std::size_t size, Header& h) {
  PacketType type;
  const DecodeError e = peekType(data, n, type);
  if (e != DecodeError::None) return e;
  if (type != want) return DecodeError::BadType;
  if (n < size) return DecodeError::Short;
  if (n > size) return DecodeError::Long;
  Reader r{data + 4};
  h.version = r.u16();
  h.type = static_cast<PacketType>(r.u16());
  h.sequence = r.u32();
  h.flags = r.u32();
  return DecodeError::None;
}

}  // namespace

const char* decodeErrorName(DecodeError e) {
  switch (e) {
    case DecodeError::None: return "ok";
    case DecodeError::Short: return "too short";
    case DecodeError::Long: return "too long";
    case DecodeError::BadMagic: return "wrong magic";
    case DecodeError::BadVersion: return "wrong version";
    case DecodeError::BadType: return "wrong type";
    case DecodeError::NonFinite: return "non-finite number";
  }
  return "?";
}

std::vector<uint8_t> encode(const StatePacket& p) {
  Writer w;
  Header h = p.header;
  h.type = PacketType::State;
  w.header(h);
  w.f64(p.state.time);
  w.vec(p.state.position);
  w.f64(p.state.orientation.w()), w.f64(p.state.orientation.x()), w.f64(p.state.orientation.y()),
      w.f64(p.state.orientation.z());
  w.vec(p.state.velocity);
  w.vec(p.force);
  w.u32(p.state.buttons);
  w.f64(p.servo_rate);
  w.u32(p.overruns);
  return w.bytes;
}

std::vector<uint8_t> encode(const LocalModelPacket& p) {
  Writer w;
  Header h = p.header;
  h.type = PacketType::LocalModel;
  w.header(h);
  w.u32(p.state_sequence);
  w.f64(p.state_time);
  w.vec(p.model.anchor);
  w.vec(p.model.anchor_velocity);
  w.vec(p.model.feed_forward);
  w.f64(p.model.stiffness);
  w.f64(p.model.damping);
  w.f64(p.max_force);
  w.f64(p.model.ttl);
  w.u32(p.model.coupled ? 1u : 0u);
  w.u32(0);  // reserved
  return w.bytes;
}

DecodeError peekType(const uint8_t* data, std::size_t n, PacketType& type) {
  if (data == nullptr || n < kHeaderBytes) return DecodeError::Short;
  Reader r{data};
  if (r.u32() != kMagic) return DecodeError::BadMagic;
  if (r.u16() != kVersion) return DecodeError::BadVersion;
  const uint16_t t = r.u16();
  if (t != static_cast<uint16_t>(PacketType::State) && t != static_cast<uint16_t>(PacketType::LocalModel))
    return DecodeError::BadType;
  type = static_cast<PacketType>(t);
  return DecodeError::None;
}

DecodeError decode(const uint8_t* data, std::size_t n, StatePacket& out) {
  StatePacket p;
  if (const DecodeError e = check(data, n, PacketType::State, kStateBytes, p.header); e != DecodeError::None) return e;
  Reader r{data + kHeaderBytes};
  p.state.time = r.f64();
  p.state.position = r.vec();
  const double w = r.f64(), x = r.f64(), y = r.f64(), z = r.f64();
  p.state.orientation = Eigen::Quaterniond(w, x, y, z);
  p.state.velocity = r.vec();
  p.force = r.vec();
  p.state.buttons = r.u32();
  p.servo_rate = r.f64();
  p.overruns = r.u32();
  if (!r.finite) return DecodeError::NonFinite;
  out = p;
  return DecodeError::None;
}

DecodeError decode(const uint8_t* data, std::size_t n, LocalModelPacket& out) {
  LocalModelPacket p;
  if (const DecodeError e = check(data, n, PacketType::LocalModel, kLocalModelBytes, p.header); e != DecodeError::None)
    return e;
  Reader r{data + kHeaderBytes};
  p.state_sequence = r.u32();
  p.state_time = r.f64();
  p.model.anchor = r.vec();
  p.model.anchor_velocity = r.vec();
  p.model.feed_forward = r.vec();
  p.model.stiffness = r.f64();
  p.model.damping = r.f64();
  p.max_force = r.f64();
  p.model.ttl = r.f64();
  p.model.coupled = r.u32() != 0;
  if (!r.finite) return DecodeError::NonFinite;
  out = p;
  return DecodeError::None;
}

bool SequenceFilter::accept(uint32_t sequence) {
  // Serial number arithmetic: newer when 0 < sequence - last < 2^31.
  if (any_ && static_cast<int32_t>(sequence - last_) <= 0) {
    ++dropped_;
    return false;
  }
  any_ = true;
  last_ = sequence;
  ++accepted_;
  return true;
}

LocalModel sanitize(const LocalModelPacket& p, const DeviceSpec& spec, double stamp, double received) {
  LocalModel m = p.model;
  m.stamp = stamp;
  m.received = received >= 0 ? std::max(received, stamp) : -1.0;
  m.stiffness = std::clamp(m.stiffness, 0.0, spec.max_stiffness);
  m.damping = std::clamp(m.damping, 0.0, spec.max_damping);
  // Feed-forward within both force limits (the device's and the one the simulation asked for).
  const double fmax = std::clamp(p.max_force, 0.0, spec.max_force);
  if (m.feed_forward.norm() > fmax) m.feed_forward *= fmax / m.feed_forward.norm();
  m.ttl = std::clamp(m.ttl, 0.0, 0.1);
  return m;
}

}  // namespace sph::haptics::bridge

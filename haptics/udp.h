// A UDP socket on the loopback interface (127.0.0.1 only) for the bridge protocol: non-blocking
// sends, receives with a timeout. POSIX sockets.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace sph::haptics {

class UdpSocket {
 public:
  /// Binds 127.0.0.1:`port` (0 = any free port); throws DeviceError on failure.
  explicit UdpSocket(uint16_t port = 0);
  ~UdpSocket();
  UdpSocket(const UdpSocket&) = delete;
  UdpSocket& operator=(const UdpSocket&) = delete;
  uint16_t port() const { return port_; }
  /// Sends one datagram to 127.0.0.1:`port`; false when the kernel refused it.
  bool send(uint16_t port, const std::vector<uint8_t>& bytes);
  /// Waits up to `timeout_ms` for one datagram; its size, 0 on timeout. Datagrams longer than the
  /// buffer are reported with their full length (so a receiver can reject them as too long).
  std::size_t receive(std::vector<uint8_t>& buffer, int timeout_ms);

 private:
  int fd_ = -1;
  uint16_t port_ = 0;
};

}  // namespace sph::haptics

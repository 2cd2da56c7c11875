#include "haptics/udp.h"

#include "haptics/device.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace sph::haptics {

namespace {
sockaddr_in loopback(uint16_t port) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  return a;
}
}  // namespace

UdpSocket::UdpSocket(uint16_t port) {
  fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
  if (fd_ < 0) throw DeviceError(std::string("udp: socket: ") + std::strerror(errno));
  sockaddr_in a = loopback(port);
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    const std::string err = std::strerror(errno);
    ::close(fd_);
    throw DeviceError("udp: cannot bind 127.0.0.1:" + std::to_string(port) + ": " + err);
  }
  socklen_t len = sizeof a;
  ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
  port_ = ntohs(a.sin_port);
}

UdpSocket::~UdpSocket() {
  if (fd_ >= 0) ::close(fd_);
}

bool UdpSocket::send(uint16_t port, const std::vector<uint8_t>& bytes) {
  const sockaddr_in a = loopback(port);
  const ssize_t n = ::sendto(fd_, bytes.data(), bytes.size(), MSG_DONTWAIT, reinterpret_cast<const sockaddr*>(&a), sizeof a);
  return n == static_cast<ssize_t>(bytes.size());
}

std::size_t UdpSocket::receive(std::vector<uint8_t>& buffer, int timeout_ms) {
  pollfd p{fd_, POLLIN, 0};
  if (::poll(&p, 1, timeout_ms) <= 0 || !(p.revents & POLLIN)) return 0;
  if (buffer.size() < 2048) buffer.resize(2048);
  // MSG_TRUNC: the datagram's real length even when it did not fit.
  const ssize_t n = ::recv(fd_, buffer.data(), buffer.size(), MSG_TRUNC);
  return n > 0 ? static_cast<std::size_t>(n) : 0;
}

}  // namespace sph::haptics

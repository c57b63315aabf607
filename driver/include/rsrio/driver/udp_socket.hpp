// A UDP socket for the DCA1000 ports: bind, send, receive with a timeout, and batched receive
// (recvmmsg) into buffers allocated once, so the receive loop never allocates.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/uio.h>

namespace rsrio {

/// IPv4 address and port, host byte order.
struct Endpoint {
  std::uint32_t ip = 0;
  std::uint16_t port = 0;
  bool operator==(const Endpoint&) const = default;
  std::string to_string() const;  // "192.168.33.180:4096"
  std::string ip_string() const;  // "192.168.33.180"
  /// "192.168.33.180" or "192.168.33.180:4096"; throws std::invalid_argument naming the text.
  static Endpoint parse(const std::string& text, std::uint16_t default_port);
};

class UdpSocket {
 public:
  UdpSocket() = default;
  /// Binds to `local` (port 0: any free port). Throws std::system_error with the address.
  explicit UdpSocket(const Endpoint& local, int receive_buffer_bytes = 0);
  ~UdpSocket();
  UdpSocket(UdpSocket&& other) noexcept;
  UdpSocket& operator=(UdpSocket&& other) noexcept;
  UdpSocket(const UdpSocket&) = delete;
  UdpSocket& operator=(const UdpSocket&) = delete;

  bool valid() const { return fd_ >= 0; }
  int fd() const { return fd_; }
  Endpoint local() const;

  /// Sends one datagram; false on failure (errno kept).
  bool send_to(const Endpoint& to, std::span<const std::uint8_t> data);
  /// Waits up to `timeout` for one datagram; returns its size, 0 on timeout, -1 on error.
  long receive(std::span<std::uint8_t> buffer, Endpoint& from, std::chrono::milliseconds timeout);
  /// The socket receive buffer the kernel granted (may be below what was asked: net.core.rmem_max).
  int receive_buffer_bytes() const;

 private:
  int fd_ = -1;
};

/// Receives up to `capacity` datagrams per call with one recvmmsg; buffers allocated at
/// construction.
class DatagramBatch {
 public:
  DatagramBatch(std::size_t capacity, std::size_t max_datagram);
  /// Waits up to `timeout` for the socket to be readable, then takes what is queued (without
  /// blocking). Returns the number of datagrams, 0 on timeout, -1 on error.
  int receive(const UdpSocket& socket, std::chrono::milliseconds timeout);
  std::span<const std::uint8_t> datagram(int i) const;
  Endpoint source(int i) const;
  /// Datagrams cut short because they exceeded max_datagram.
  bool truncated(int i) const;
  /// Datagrams the kernel dropped on this socket since it was opened because its receive buffer
  /// was full (SO_RXQ_OVFL, as of the last datagram received): the receiver fell behind. These are
  /// not the sender's losses, though the frame assembler sees both as sequence gaps.
  std::uint32_t kernel_drops() const { return kernel_drops_; }

 private:
  std::size_t max_datagram_;
  std::vector<std::uint8_t> storage_;
  std::vector<struct mmsghdr> headers_;
  std::vector<struct iovec> iovecs_;
  std::vector<sockaddr_in> addresses_;
  std::vector<std::uint8_t> control_;  // one SO_RXQ_OVFL control message per datagram
  std::uint32_t kernel_drops_ = 0;
};

}  // namespace rsrio

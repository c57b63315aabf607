#include "rsrio/driver/udp_socket.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>

#include <arpa/inet.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

namespace rsrio {

namespace {

sockaddr_in to_sockaddr(const Endpoint& e) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(e.ip);
  a.sin_port = htons(e.port);
  return a;
}

Endpoint from_sockaddr(const sockaddr_in& a) { return {ntohl(a.sin_addr.s_addr), ntohs(a.sin_port)}; }

bool wait_readable(int fd, std::chrono::milliseconds timeout) {
  pollfd p{fd, POLLIN, 0};
  int r;
  do {
    r = ::poll(&p, 1, static_cast<int>(timeout.count()));
  } while (r < 0 && errno == EINTR);
  return r > 0 && (p.revents & POLLIN);
}

}  // namespace

std::string Endpoint::ip_string() const {
  in_addr a{htonl(ip)};
  char buf[INET_ADDRSTRLEN] = {};
  ::inet_ntop(AF_INET, &a, buf, sizeof buf);
  return buf;
}

std::string Endpoint::to_string() const { return ip_string() + ":" + std::to_string(port); }

Endpoint Endpoint::parse(const std::string& text, std::uint16_t default_port) {
  std::string host = text;
  std::uint16_t port = default_port;
  if (const auto colon = text.rfind(':'); colon != std::string::npos) {
    host = text.substr(0, colon);
    const std::string p = text.substr(colon + 1);
    char* end = nullptr;
    const long v = std::strtol(p.c_str(), &end, 10);
    if (p.empty() || *end != '\0' || v < 0 || v > 65535)
      throw std::invalid_argument("'" + text + "': the port must be a number in [0, 65535]");
    port = static_cast<std::uint16_t>(v);
  }
  in_addr a{};
  if (::inet_pton(AF_INET, host.c_str(), &a) != 1)
    throw std::invalid_argument("'" + text + "': expected an IPv4 address like 192.168.33.180[:port]");
  return {ntohl(a.s_addr), port};
}

UdpSocket::UdpSocket(const Endpoint& local, int receive_buffer_bytes) {
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::system_error(errno, std::generic_category(), "socket()");
  const int one = 1;
  ::setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  // Each datagram then carries the count of datagrams the kernel dropped for a full buffer.
  ::setsockopt(fd_, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof one);
  if (receive_buffer_bytes > 0) {
    // SO_RCVBUFFORCE passes net.core.rmem_max when we may (CAP_NET_ADMIN); else the capped ask.
    if (::setsockopt(fd_, SOL_SOCKET, SO_RCVBUFFORCE, &receive_buffer_bytes, sizeof receive_buffer_bytes) != 0)
      ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &receive_buffer_bytes, sizeof receive_buffer_bytes);
  }
  const sockaddr_in a = to_sockaddr(local);
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0) {
    const int e = errno;
    ::close(fd_);
    fd_ = -1;
    throw std::system_error(e, std::generic_category(), "bind " + local.to_string());
  }
}

UdpSocket::~UdpSocket() {
  if (fd_ >= 0) ::close(fd_);
}

UdpSocket::UdpSocket(UdpSocket&& o) noexcept : fd_(o.fd_) { o.fd_ = -1; }

UdpSocket& UdpSocket::operator=(UdpSocket&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = o.fd_;
    o.fd_ = -1;
  }
  return *this;
}

Endpoint UdpSocket::local() const {
  sockaddr_in a{};
  socklen_t len = sizeof a;
  ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
  return from_sockaddr(a);
}

bool UdpSocket::send_to(const Endpoint& to, std::span<const std::uint8_t> data) {
  const sockaddr_in a = to_sockaddr(to);
  return ::sendto(fd_, data.data(), data.size(), 0, reinterpret_cast<const sockaddr*>(&a), sizeof a) ==
         static_cast<ssize_t>(data.size());
}

long UdpSocket::receive(std::span<std::uint8_t> buffer, Endpoint& from, std::chrono::milliseconds timeout) {
  if (!wait_readable(fd_, timeout)) return 0;
  sockaddr_in a{};
  socklen_t len = sizeof a;
  const ssize_t n = ::recvfrom(fd_, buffer.data(), buffer.size(), MSG_DONTWAIT, reinterpret_cast<sockaddr*>(&a), &len);
  if (n < 0) return (errno == EAGAIN || errno == EWOULDBLOCK) ? 0 : -1;
  from = from_sockaddr(a);
  return n;
}

int UdpSocket::receive_buffer_bytes() const {
  int v = 0;
  socklen_t len = sizeof v;
  ::getsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &v, &len);
  return v;
}

namespace {
constexpr std::size_t kControlBytes = CMSG_SPACE(sizeof(std::uint32_t));
}  // namespace

DatagramBatch::DatagramBatch(std::size_t capacity, std::size_t max_datagram)
    : max_datagram_(max_datagram), storage_(capacity * max_datagram), headers_(capacity), iovecs_(capacity),
      addresses_(capacity), control_(capacity * kControlBytes) {
  for (std::size_t i = 0; i < capacity; ++i) {
    iovecs_[i] = {storage_.data() + i * max_datagram, max_datagram};
    headers_[i].msg_hdr = {};
    headers_[i].msg_hdr.msg_iov = &iovecs_[i];
    headers_[i].msg_hdr.msg_iovlen = 1;
    headers_[i].msg_hdr.msg_name = &addresses_[i];
    headers_[i].msg_hdr.msg_namelen = sizeof(sockaddr_in);
  }
}

int DatagramBatch::receive(const UdpSocket& socket, std::chrono::milliseconds timeout) {
  if (!wait_readable(socket.fd(), timeout)) return 0;
  for (std::size_t i = 0; i < headers_.size(); ++i) {
    auto& h = headers_[i];
    h.msg_hdr.msg_namelen = sizeof(sockaddr_in);
    h.msg_hdr.msg_control = control_.data() + i * kControlBytes;
    h.msg_hdr.msg_controllen = kControlBytes;
    h.msg_hdr.msg_flags = 0;
    h.msg_len = 0;
  }
  const int n = ::recvmmsg(socket.fd(), headers_.data(), static_cast<unsigned>(headers_.size()), MSG_DONTWAIT, nullptr);
  if (n < 0) return (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) ? 0 : -1;
  // The kernel attaches the drop count only once it is non-zero; it only grows.
  for (int i = 0; i < n; ++i) {
    msghdr& m = headers_[static_cast<std::size_t>(i)].msg_hdr;
    for (cmsghdr* c = CMSG_FIRSTHDR(&m); c; c = CMSG_NXTHDR(&m, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL) {
        std::uint32_t drops = 0;
        std::memcpy(&drops, CMSG_DATA(c), sizeof drops);
        kernel_drops_ = std::max(kernel_drops_, drops);
      }
    }
  }
  return n;
}

std::span<const std::uint8_t> DatagramBatch::datagram(int i) const {
  return {storage_.data() + static_cast<std::size_t>(i) * max_datagram_, headers_[i].msg_len};
}

Endpoint DatagramBatch::source(int i) const { return from_sockaddr(addresses_[i]); }

bool DatagramBatch::truncated(int i) const { return (headers_[i].msg_hdr.msg_flags & MSG_TRUNC) != 0; }

}  // namespace rsrio

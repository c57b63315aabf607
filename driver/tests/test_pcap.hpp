// Reads UDP datagrams out of a classic libpcap file (Ethernet / IPv4 / UDP), for tests that replay
// the real DCA1000 captures in shared/data/dca1000-pcap/.
#pragma once

#include <cstdint>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

namespace rsrio::test {

struct PcapDatagram {
  std::uint32_t src_ip = 0, dst_ip = 0;
  std::uint16_t src_port = 0, dst_port = 0;
  std::vector<std::uint8_t> payload;
};

inline std::vector<PcapDatagram> read_pcap_udp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("cannot open " + path);
  const std::vector<std::uint8_t> d((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  auto u32le = [&](std::size_t o) {
    return std::uint32_t(d[o]) | std::uint32_t(d[o + 1]) << 8 | std::uint32_t(d[o + 2]) << 16 | std::uint32_t(d[o + 3]) << 24;
  };
  auto u16be = [&](std::size_t o) { return static_cast<std::uint16_t>(d[o] << 8 | d[o + 1]); };
  auto u32be = [&](std::size_t o) { return std::uint32_t(u16be(o)) << 16 | u16be(o + 2); };
  if (d.size() < 24 || u32le(0) != 0xa1b2c3d4u) throw std::runtime_error(path + ": not a little-endian libpcap file");
  std::vector<PcapDatagram> out;
  for (std::size_t off = 24; off + 16 <= d.size();) {
    const std::size_t caplen = u32le(off + 8), pkt = off + 16;
    if (pkt + caplen > d.size()) throw std::runtime_error(path + ": truncated record");
    off = pkt + caplen;
    if (caplen < 14 + 20 + 8 || u16be(pkt + 12) != 0x0800) continue;  // IPv4 only
    const std::size_t ip = pkt + 14, ihl = (d[ip] & 0x0F) * 4u, udp = ip + ihl;
    if (d[ip + 9] != 17) continue;  // UDP only
    PcapDatagram g;
    g.src_ip = u32be(ip + 12);
    g.dst_ip = u32be(ip + 16);
    g.src_port = u16be(udp);
    g.dst_port = u16be(udp + 2);
    const std::size_t len = u16be(udp + 4) - 8u;
    g.payload.assign(d.begin() + static_cast<long>(udp + 8), d.begin() + static_cast<long>(udp + 8 + len));
    out.push_back(std::move(g));
  }
  return out;
}

}  // namespace rsrio::test

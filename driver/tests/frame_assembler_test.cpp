// Frame assembly by byte count: the real capture, then a long synthetic stream with injected
// loss, reordering and duplication where every expectation is computed from the injected faults.
#include "rsrio/driver/frame_assembler.hpp"

#include <algorithm>
#include <map>
#include <random>
#include <set>

#include <catch2/catch_test_macros.hpp>

#include "rsrio/driver/dca1000_protocol.hpp"
#include "test_pcap.hpp"

using rsrio::AssembledFrame;
using rsrio::FrameAssembler;

namespace {

struct Packet {
  std::uint32_t seq;
  std::uint64_t byte_count;
  std::vector<std::uint8_t> datagram;
};

// A DCA1000 stream of `frames` frames of random bytes, cut into packets of `payload` bytes.
std::vector<Packet> make_stream(const std::vector<std::uint8_t>& stream, std::size_t payload) {
  std::vector<Packet> out;
  std::uint32_t seq = 1;
  for (std::size_t pos = 0; pos < stream.size(); pos += payload, ++seq) {
    const std::size_t n = std::min(payload, stream.size() - pos);
    Packet p{seq, pos, std::vector<std::uint8_t>(rsrio::dca1000::kDataHeaderSize + n)};
    rsrio::dca1000::write_data_header({seq, pos}, std::span<std::uint8_t, 10>(p.datagram.data(), 10));
    std::copy_n(stream.begin() + static_cast<long>(pos), n, p.datagram.begin() + 10);
    out.push_back(std::move(p));
  }
  return out;
}

std::vector<AssembledFrame> drain(FrameAssembler& a) {
  std::vector<AssembledFrame> out;
  while (AssembledFrame* f = a.next_ready()) {
    out.push_back(*f);
    a.release(f);
  }
  return out;
}

}  // namespace

TEST_CASE("the real DCA1000 capture assembles into its 16384 bytes", "[frame_assembler]") {
  FrameAssembler a(16384);
  std::vector<std::uint8_t> expected;
  for (const auto& g : rsrio::test::read_pcap_udp("../shared/data/dca1000-pcap/test_one_frame.pcap")) {
    if (g.dst_port != rsrio::dca1000::kDataPort) continue;
    a.on_datagram(g.payload, 1000);
    expected.insert(expected.end(), g.payload.begin() + 10, g.payload.end());
  }
  const auto frames = drain(a);
  REQUIRE(frames.size() == 1);
  CHECK(frames[0].flags == 0);
  CHECK(frames[0].bytes == expected);
  CHECK(a.counters().packets == 12);
  CHECK(a.counters().lost_packets == 0);
  CHECK(a.counters().good_frames == 1);
}

TEST_CASE("loss, reordering and duplicates: damaged frames flagged, good frames exact, counters right",
          "[frame_assembler]") {
  constexpr std::size_t kFrameBytes = 40'000;  // not a multiple of 1456: packets straddle frames
  constexpr std::size_t kFrames = 60;
  std::mt19937_64 rng(1234);
  std::vector<std::uint8_t> stream(kFrameBytes * kFrames);
  for (auto& b : stream) b = static_cast<std::uint8_t>(rng());
  const auto packets = make_stream(stream, 1456);

  // Inject faults: 10 % lost, 5 % moved 1-8 places later, 2 % sent twice.
  std::bernoulli_distribution lose(0.10), reorder(0.05), dup(0.02);
  std::uniform_int_distribution<int> shift(1, 8);
  std::vector<const Packet*> sent;
  std::set<std::uint32_t> lost;
  std::size_t duplicates = 0;
  for (const auto& p : packets) {
    if (lose(rng)) {
      lost.insert(p.seq);
      continue;
    }
    sent.push_back(&p);
    if (dup(rng)) {
      sent.push_back(&p);
      ++duplicates;
    }
  }
  for (std::size_t i = 0; i + 1 < sent.size(); ++i)
    if (reorder(rng)) std::swap(sent[i], sent[std::min(sent.size() - 1, i + static_cast<std::size_t>(shift(rng)))]);
  // Out of order = arrives while a higher sequence number has already arrived (first copies only).
  std::size_t out_of_order = 0;
  {
    std::uint32_t max_seq = 0;
    std::set<std::uint32_t> seen;
    for (const Packet* p : sent) {
      if (!seen.insert(p->seq).second) continue;
      if (p->seq < max_seq) ++out_of_order;
      max_seq = std::max(max_seq, p->seq);
    }
  }
  // A frame is damaged when a lost packet overlaps it.
  std::set<std::uint64_t> damaged_expected;
  for (const auto& p : packets)
    if (lost.count(p.seq)) {
      const std::uint64_t first = p.byte_count / kFrameBytes;
      const std::uint64_t last = (p.byte_count + p.datagram.size() - 10 - 1) / kFrameBytes;
      for (std::uint64_t f = first; f <= last; ++f) damaged_expected.insert(f);
    }
  REQUIRE(!damaged_expected.empty());
  REQUIRE(damaged_expected.size() < kFrames);

  FrameAssembler a(kFrameBytes, 6);
  std::vector<AssembledFrame> frames;
  std::int64_t t = 0;
  for (const Packet* p : sent) {
    a.on_datagram(p->datagram, t += 1000);
    for (auto& f : drain(a)) frames.push_back(std::move(f));
  }
  a.flush_all(t);
  for (auto& f : drain(a)) frames.push_back(std::move(f));

  std::set<std::uint64_t> numbers;
  for (const auto& f : frames) {
    INFO("frame " << f.frame_number);
    REQUIRE(numbers.insert(f.frame_number).second);  // each frame once, in order
    const bool should_be_damaged = damaged_expected.count(f.frame_number) > 0;
    CHECK(((f.flags & rsrio::kFrameDamaged) != 0) == should_be_damaged);
    const auto begin = stream.begin() + static_cast<long>(f.frame_number * kFrameBytes);
    if (!should_be_damaged) {
      CHECK(std::equal(f.bytes.begin(), f.bytes.end(), begin));
      CHECK(f.lost_bytes == 0);
    } else {
      // received bytes are right, missing ones are zero, and they add up to lost_bytes
      std::size_t zeros_where_data_differs = 0;
      for (std::size_t i = 0; i < kFrameBytes; ++i)
        if (f.bytes[i] != begin[static_cast<long>(i)]) {
          CHECK(f.bytes[i] == 0);
          ++zeros_where_data_differs;
        }
      CHECK(f.lost_bytes >= zeros_where_data_differs);
      CHECK(f.lost_bytes > 0);
    }
  }
  CHECK(frames.size() == kFrames);
  CHECK(std::is_sorted(frames.begin(), frames.end(),
                       [](const auto& x, const auto& y) { return x.frame_number < y.frame_number; }));
  const auto& c = a.counters();
  // Sequence numbers reveal a loss once a later packet arrives; packets lost at the very end of
  // the stream show only as the damaged last frame.
  const std::uint32_t last_sent = (*std::max_element(sent.begin(), sent.end(), [](auto* x, auto* y) {
                                    return x->seq < y->seq;
                                  }))->seq;
  CHECK(c.lost_packets == static_cast<std::size_t>(std::count_if(lost.begin(), lost.end(),
                                                                 [&](std::uint32_t s) { return s < last_sent; })));
  CHECK(c.duplicate_packets == duplicates);
  CHECK(c.out_of_order_packets == out_of_order);
  CHECK(c.damaged_frames == damaged_expected.size());
  CHECK(c.good_frames == kFrames - damaged_expected.size());
  CHECK(c.malformed_packets == 0);
  CHECK(c.pool_exhausted == 0);
}

TEST_CASE("garbage and truncated datagrams never crash and are counted", "[frame_assembler]") {
  FrameAssembler a(4096, 4);
  std::mt19937 rng(99);
  std::uniform_int_distribution<int> len(0, 3000), byte(0, 255);
  std::size_t expected_malformed = 0;
  for (int i = 0; i < 20000; ++i) {
    std::vector<std::uint8_t> d(static_cast<std::size_t>(len(rng)));
    for (auto& b : d) b = static_cast<std::uint8_t>(byte(rng));
    const bool bad = d.size() <= 10 || d.size() > rsrio::dca1000::kMaxDatagram ||
                     (d[0] | d[1] | d[2] | d[3]) == 0;
    expected_malformed += bad;
    a.on_datagram(d, i);
    if (i % 7 == 0)
      while (AssembledFrame* f = a.next_ready()) a.release(f);
  }
  a.flush_all(1);
  while (AssembledFrame* f = a.next_ready()) a.release(f);
  CHECK(a.counters().malformed_packets == expected_malformed);
  CHECK(a.counters().packets + a.counters().duplicate_packets + a.counters().malformed_packets == 20000);
}

TEST_CASE("a consumer that never returns frames exhausts the pool, counted, not crashed", "[frame_assembler]") {
  std::vector<std::uint8_t> stream(1000 * 10, 7);
  const auto packets = make_stream(stream, 500);
  FrameAssembler a(1000, 3, 0);
  for (const auto& p : packets) a.on_datagram(p.datagram, 0);
  CHECK(a.counters().good_frames == 3);
  CHECK(a.counters().pool_exhausted > 0);
  AssembledFrame* f = a.next_ready();
  REQUIRE(f);
  CHECK(f->frame_number == 0);
}

TEST_CASE("a stall closes the open frame as damaged", "[frame_assembler]") {
  std::vector<std::uint8_t> stream(3000, 1);
  const auto packets = make_stream(stream, 1000);
  FrameAssembler a(3000);
  a.on_datagram(packets[0].datagram, 0);
  a.on_datagram(packets[1].datagram, 10);
  CHECK(a.next_ready() == nullptr);
  a.flush_stale(50'000'000, 100'000'000);  // not stale yet
  CHECK(a.next_ready() == nullptr);
  a.flush_stale(200'000'000, 100'000'000);
  AssembledFrame* f = a.next_ready();
  REQUIRE(f);
  CHECK(f->flags == rsrio::kFrameDamaged);
  CHECK(f->lost_bytes == 1000);
  CHECK(f->completed_ns == 200'000'000);
}

TEST_CASE("a pool of pool_frames_needed() never runs out with small frames and 10 % loss", "[frame_assembler]") {
  // 8000-byte frames are 5.5 packets: with 10 % loss about half stay open until the stream is a
  // reorder window (64 packets, ~12 frames) past them. A consumer that drains after every batch
  // of 64 datagrams then needs ~27 buffers; the old fixed 6 dropped good packets (pool_exhausted).
  constexpr std::size_t kFrame = 8000, kFrames = 200, kBatch = 64;
  std::mt19937_64 rng(3);
  std::vector<std::uint8_t> stream(kFrame * kFrames);
  for (auto& b : stream) b = static_cast<std::uint8_t>(rng());
  const auto packets = make_stream(stream, 1456);
  const std::size_t pool =
      FrameAssembler::pool_frames_needed(kFrame, rsrio::kDefaultReorderWindowBytes, kBatch * 1456);
  CHECK(pool > 6);
  FrameAssembler a(kFrame, pool);
  std::bernoulli_distribution lose(0.10);
  std::set<std::uint64_t> frames_with_loss;
  std::map<std::uint64_t, AssembledFrame> got;
  std::size_t in_batch = 0;
  for (const auto& p : packets) {
    if (lose(rng)) {
      for (std::uint64_t b = p.byte_count; b < p.byte_count + p.datagram.size() - 10; b += 1)
        frames_with_loss.insert(b / kFrame);
      continue;
    }
    a.on_datagram(p.datagram, 0);
    if (++in_batch == kBatch) {
      in_batch = 0;
      for (auto& f : drain(a)) got[f.frame_number] = std::move(f);
    }
  }
  a.flush_all(0);
  for (auto& f : drain(a)) got[f.frame_number] = std::move(f);
  CHECK(a.counters().pool_exhausted == 0);
  CHECK(got.size() == kFrames);
  for (const auto& [n, f] : got) {
    INFO("frame " << n);
    CHECK(((f.flags & rsrio::kFrameDamaged) != 0) == (frames_with_loss.count(n) == 1));
  }
  CHECK(a.counters().damaged_frames == frames_with_loss.size());
}

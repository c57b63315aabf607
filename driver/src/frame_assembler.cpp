#include "rsrio/driver/frame_assembler.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <stdexcept>

#include "rsrio/driver/dca1000_protocol.hpp"

namespace rsrio {

namespace {

// Sets bits [begin, end) and returns how many were not set before.
std::size_t set_range(std::vector<std::uint64_t>& bits, std::size_t begin, std::size_t end) {
  std::size_t newly = 0;
  while (begin < end) {
    const std::size_t word = begin / 64, bit = begin % 64;
    const std::size_t n = std::min<std::size_t>(64 - bit, end - begin);
    const std::uint64_t mask = (n == 64 ? ~0ull : ((1ull << n) - 1)) << bit;
    newly += static_cast<std::size_t>(std::popcount(mask & ~bits[word]));
    bits[word] |= mask;
    begin += n;
  }
  return newly;
}

}  // namespace

FrameAssembler::FrameAssembler(std::size_t frame_bytes, std::size_t pool_frames, std::size_t reorder_window_bytes)
    : frame_bytes_(frame_bytes), reorder_window_bytes_(reorder_window_bytes), slots_(pool_frames),
      seq_seen_(kSeqWindow / 64, 0) {
  if (frame_bytes == 0) throw std::invalid_argument("frame size must be > 0");
  if (pool_frames < 3) throw std::invalid_argument("the frame pool needs at least 3 buffers");
  for (auto& s : slots_) {
    s.frame.bytes.assign(frame_bytes, 0);
    s.covered.assign((frame_bytes + 63) / 64, 0);
  }
}

std::size_t FrameAssembler::pool_frames_needed(std::size_t frame_bytes, std::size_t reorder_window_bytes,
                                              std::size_t batch_bytes, std::size_t held_by_consumer) {
  if (frame_bytes == 0) throw std::invalid_argument("frame size must be > 0");
  const auto frames_in = [&](std::size_t bytes) { return (bytes + frame_bytes - 1) / frame_bytes + 1; };
  return std::max<std::size_t>(3, frames_in(reorder_window_bytes) + frames_in(batch_bytes) + held_by_consumer);
}

void FrameAssembler::track_sequence(std::uint32_t seq, bool& duplicate, bool& out_of_order) {
  duplicate = out_of_order = false;
  auto bit = [&](std::uint32_t s) -> std::uint64_t& { return seq_seen_[(s % kSeqWindow) / 64]; };
  auto mask = [](std::uint32_t s) { return 1ull << (s % 64); };
  if (!started_) {
    max_sequence_ = seq;
    bit(seq) |= mask(seq);
    return;
  }
  if (seq > max_sequence_) {
    const std::uint64_t gap = std::uint64_t(seq) - max_sequence_ - 1;
    counters_.lost_packets += gap;  // until they turn up late
    if (gap >= kSeqWindow) {
      std::fill(seq_seen_.begin(), seq_seen_.end(), 0);
    } else {
      for (std::uint32_t s = max_sequence_ + 1; s < seq; ++s) bit(s) &= ~mask(s);
    }
    bit(seq) |= mask(seq);
    max_sequence_ = seq;
    return;
  }
  if (max_sequence_ - seq >= kSeqWindow || (bit(seq) & mask(seq))) {
    duplicate = true;  // seen, or too old to tell: either way not placed again
    return;
  }
  bit(seq) |= mask(seq);
  out_of_order = true;
  if (counters_.lost_packets > 0) --counters_.lost_packets;
}

void FrameAssembler::on_datagram(std::span<const std::uint8_t> datagram, std::int64_t now_ns) {
  const auto header = dca1000::parse_data_header(datagram);
  const std::size_t payload_len = datagram.size() - std::min(datagram.size(), dca1000::kDataHeaderSize);
  if (!header || payload_len == 0 || payload_len > dca1000::kMaxDatagram - dca1000::kDataHeaderSize ||
      header->sequence == 0) {
    ++counters_.malformed_packets;
    return;
  }
  bool duplicate = false, out_of_order = false;
  if (!started_ && header->byte_count < frame_bytes_) {
    // A recording starts at sequence 1, byte 0: packets before the first one seen were lost
    // (when joining a running stream later on, earlier sequence numbers are simply not ours).
    started_ = true;
    max_sequence_ = 0;
  }
  track_sequence(header->sequence, duplicate, out_of_order);
  started_ = true;
  if (duplicate) {
    ++counters_.duplicate_packets;
    return;
  }
  if (out_of_order) ++counters_.out_of_order_packets;
  ++counters_.packets;
  counters_.payload_bytes += payload_len;

  const std::span<const std::uint8_t> payload = datagram.subspan(dca1000::kDataHeaderSize);
  std::uint64_t position = header->byte_count;
  const std::uint64_t end = position + payload_len;
  max_position_ = std::max(max_position_, end);

  std::size_t consumed = 0;
  while (position < end) {
    const std::uint64_t frame_number = position / frame_bytes_;
    const std::size_t offset = static_cast<std::size_t>(position % frame_bytes_);
    const std::size_t n = std::min<std::size_t>(frame_bytes_ - offset, static_cast<std::size_t>(end - position));
    place(frame_number, offset, payload.subspan(consumed, n), now_ns);
    position += n;
    consumed += n;
  }
  // Frames the stream has left far enough behind will get nothing more: close them.
  for (auto& s : slots_)
    if (s.state == Slot::State::kOpen &&
        (s.frame.frame_number + 1) * frame_bytes_ + reorder_window_bytes_ <= max_position_)
      close(s, now_ns);
}

FrameAssembler::Slot* FrameAssembler::open_slot(std::uint64_t frame_number, std::int64_t now_ns) {
  for (auto& s : slots_) {
    if (s.state != Slot::State::kFree) continue;
    s.state = Slot::State::kOpen;
    s.frame.frame_number = frame_number;
    s.frame.flags = 0;
    s.frame.lost_bytes = 0;
    std::memset(s.frame.bytes.data(), 0, s.frame.bytes.size());  // missing bytes read as zero
    std::fill(s.covered.begin(), s.covered.end(), 0);
    s.filled = 0;
    s.last_packet_ns = now_ns;
    return &s;
  }
  return nullptr;
}

void FrameAssembler::place(std::uint64_t frame_number, std::size_t offset, std::span<const std::uint8_t> data,
                           std::int64_t now_ns) {
  Slot* slot = nullptr;
  for (auto& s : slots_)
    if (s.state != Slot::State::kFree && s.frame.frame_number == frame_number) slot = &s;
  if (slot && slot->state != Slot::State::kOpen) {
    ++counters_.late_packets;  // its frame was already closed and passed on as damaged
    return;
  }
  if (!slot) {
    if (frame_number < next_frame_to_emit_) {
      ++counters_.late_packets;
      return;
    }
    slot = open_slot(frame_number, now_ns);
    if (!slot) {
      ++counters_.pool_exhausted;
      return;
    }
  }
  std::memcpy(slot->frame.bytes.data() + offset, data.data(), data.size());
  slot->filled += set_range(slot->covered, offset, offset + data.size());
  slot->last_packet_ns = now_ns;
  if (slot->filled == frame_bytes_) close(*slot, now_ns);
}

void FrameAssembler::close(Slot& s, std::int64_t now_ns) {
  s.state = Slot::State::kReady;
  s.frame.completed_ns = now_ns;
  if (s.filled < frame_bytes_) {
    s.frame.flags |= kFrameDamaged;
    s.frame.lost_bytes = static_cast<std::uint32_t>(frame_bytes_ - s.filled);
    counters_.zero_filled_bytes += frame_bytes_ - s.filled;
    ++counters_.damaged_frames;
  } else {
    ++counters_.good_frames;
  }
}

void FrameAssembler::flush_stale(std::int64_t now_ns, std::int64_t stale_ns) {
  for (auto& s : slots_)
    if (s.state == Slot::State::kOpen && now_ns - s.last_packet_ns >= stale_ns) close(s, now_ns);
}

void FrameAssembler::flush_all(std::int64_t now_ns) {
  for (auto& s : slots_)
    if (s.state == Slot::State::kOpen) close(s, now_ns);
}

AssembledFrame* FrameAssembler::next_ready() {
  // In frame order: a closed frame waits while an older one is still open.
  Slot* best = nullptr;
  for (auto& s : slots_)
    if ((s.state == Slot::State::kReady || s.state == Slot::State::kOpen) &&
        (!best || s.frame.frame_number < best->frame.frame_number))
      best = &s;
  if (!best || best->state != Slot::State::kReady) return nullptr;
  best->state = Slot::State::kHandedOut;
  if (emitted_any_ && best->frame.frame_number > next_frame_to_emit_)
    counters_.frames_skipped += best->frame.frame_number - next_frame_to_emit_;
  emitted_any_ = true;
  next_frame_to_emit_ = best->frame.frame_number + 1;
  return &best->frame;
}

void FrameAssembler::release(AssembledFrame* frame) {
  for (auto& s : slots_)
    if (&s.frame == frame) s.state = Slot::State::kFree;
}

}  // namespace rsrio

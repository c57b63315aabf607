// Assembles DCA1000 data packets into radar frames by byte count, into a preallocated pool.
//
// The DCA1000 numbers every datagram (sequence, from 1) and says how many payload bytes came
// before it (48-bit byte count). Recording starts before the radar, so byte 0 is the first byte
// of frame 0: a payload belongs at frame byte_count / frame_bytes, offset byte_count % frame_bytes,
// and may straddle two frames. Placing by byte count (never by arrival order) makes reordered
// packets land right; a per-byte coverage map makes duplicates and overlapping packets harmless.
//
// A frame leaves complete (every byte received: good, flags 0) or incomplete (closed because the
// stream moved `reorder_window_bytes` past its end, or by flush_stale() after a stall): then its
// missing bytes are zero, it carries FLAG_DAMAGED and lost_bytes, and it is counted. A damaged
// frame is never passed on as good. No allocation after construction.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace rsrio {

/// Every failure mode has a counter (PX4 style). Monotonic over the assembler's life.
struct AssemblerCounters {
  std::uint64_t packets = 0;             // datagrams accepted for placement
  std::uint64_t payload_bytes = 0;
  std::uint64_t malformed_packets = 0;   // too short, or payload larger than a DCA1000 sends
  std::uint64_t lost_packets = 0;        // sequence numbers skipped and never seen later
  std::uint64_t out_of_order_packets = 0;  // arrived after a higher sequence number, still placed
  std::uint64_t duplicate_packets = 0;   // sequence number seen before: dropped
  std::uint64_t late_packets = 0;        // belonged to a frame already passed on: dropped
  std::uint64_t good_frames = 0;
  std::uint64_t damaged_frames = 0;
  std::uint64_t zero_filled_bytes = 0;
  std::uint64_t frames_skipped = 0;      // frame numbers that never received a single byte
  std::uint64_t pool_exhausted = 0;      // packets dropped because every frame buffer was busy
};

struct AssembledFrame {
  std::uint64_t frame_number = 0;
  std::uint32_t flags = 0;            // rsrio_msgs RadarFrame flags: 1 = damaged (zero-filled)
  std::uint32_t lost_bytes = 0;
  std::int64_t completed_ns = 0;      // CLOCK_MONOTONIC when it was completed / closed
  std::vector<std::uint8_t> bytes;    // frame_bytes, allocated once
};

inline constexpr std::uint32_t kFrameDamaged = 1;  // == rsrio_msgs::msg::RadarFrame_Constants::FLAG_DAMAGED

inline constexpr std::size_t kDefaultReorderWindowBytes = 64 * 1456;  // 64 full DCA1000 packets

class FrameAssembler {
 public:
  /// `pool_frames` buffers of `frame_bytes` each (at least 3: two open frames and one handed out).
  FrameAssembler(std::size_t frame_bytes, std::size_t pool_frames = 6,
                 std::size_t reorder_window_bytes = kDefaultReorderWindowBytes);

  /// The smallest pool that never runs out while the consumer takes every ready frame after each
  /// batch of `batch_bytes` and holds at most `held_by_consumer` at a time. Frames stay open
  /// until the stream is `reorder_window_bytes` past their end, so the frames from the oldest open
  /// one to the newest span ceil(window / frame) + 1; one batch can finish ceil(batch / frame) + 1
  /// more before the consumer runs. With small frames this is far above 3: a pool below it drops
  /// whole frames' worth of good packets (pool_exhausted) whenever loss keeps a frame open.
  static std::size_t pool_frames_needed(std::size_t frame_bytes, std::size_t reorder_window_bytes,
                                        std::size_t batch_bytes, std::size_t held_by_consumer = 1);

  /// Places one data datagram (header included). `now_ns`: CLOCK_MONOTONIC of its arrival.
  void on_datagram(std::span<const std::uint8_t> datagram, std::int64_t now_ns);

  /// Closes open frames that received nothing for `stale_ns` (a stall or the end of a stream).
  void flush_stale(std::int64_t now_ns, std::int64_t stale_ns);
  /// Closes every open frame now (end of recording).
  void flush_all(std::int64_t now_ns);

  /// The oldest finished frame, or nullptr. It stays valid until release()d.
  AssembledFrame* next_ready();
  void release(AssembledFrame* frame);

  const AssemblerCounters& counters() const { return counters_; }
  std::size_t frame_bytes() const { return frame_bytes_; }

 private:
  struct Slot {
    AssembledFrame frame;
    std::vector<std::uint64_t> covered;  // one bit per byte
    std::size_t filled = 0;
    std::int64_t last_packet_ns = 0;
    enum class State { kFree, kOpen, kReady, kHandedOut } state = State::kFree;
  };

  Slot* open_slot(std::uint64_t frame_number, std::int64_t now_ns);
  void place(std::uint64_t frame_number, std::size_t offset, std::span<const std::uint8_t> data, std::int64_t now_ns);
  void close(Slot& slot, std::int64_t now_ns);
  void track_sequence(std::uint32_t sequence, bool& duplicate, bool& out_of_order);

  std::size_t frame_bytes_;
  std::size_t reorder_window_bytes_;
  std::vector<Slot> slots_;
  AssemblerCounters counters_;
  bool started_ = false;
  std::uint64_t max_position_ = 0;        // highest byte count + payload seen
  std::uint64_t next_frame_to_emit_ = 0;  // frames below this were passed on (or skipped)
  bool emitted_any_ = false;
  // Sequence tracking: highest sequence seen and a window of which recent ones arrived.
  static constexpr std::uint32_t kSeqWindow = 4096;
  std::uint32_t max_sequence_ = 0;
  std::vector<std::uint64_t> seq_seen_;  // kSeqWindow bits, indexed sequence % kSeqWindow
  std::uint64_t pending_missing_ = 0;    // skipped sequence numbers that may still arrive
};

}  // namespace rsrio

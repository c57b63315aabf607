// A bounded single-producer single-consumer queue for the pipeline's stage boundaries.
//
// Lock-free and allocation-free after construction: the slots are allocated once, push and pop
// are a few atomic loads and stores (rigtorp-style: each side caches the other's index and
// reloads it with acquire only when the queue looks full or empty). Neither side ever blocks or
// spins: try_push fails when full and the caller's drop policy decides, with the counters here
// recording it. Exactly one thread may push and exactly one thread may pop.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <type_traits>
#include <utility>

namespace rsrio {

// Fixed rather than std::hardware_destructive_interference_size, whose use in a header is a
// -Winterference-size warning (an error here) on GCC 14.
inline constexpr std::size_t kCacheLine = 64;

template <typename T>
class SpscQueue {
  static_assert(std::is_nothrow_move_constructible_v<T> && std::is_nothrow_move_assignable_v<T>,
                "queue elements move without throwing");

 public:
  /// Holds up to `capacity` elements (one slack slot is added internally).
  explicit SpscQueue(std::size_t capacity)
      : capacity_(capacity), size_(capacity + 1), slots_(std::make_unique<T[]>(capacity + 1)) {
    if (capacity == 0) throw std::invalid_argument("SpscQueue capacity must be > 0");
  }
  SpscQueue(const SpscQueue&) = delete;
  SpscQueue& operator=(const SpscQueue&) = delete;

  /// Producer side. False (and counted as a drop) when full; the value is left untouched then.
  bool try_push(T& value) noexcept {
    const std::size_t w = write_.load(std::memory_order_relaxed);
    const std::size_t next = w + 1 == size_ ? 0 : w + 1;
    if (next == read_cache_) {
      read_cache_ = read_.load(std::memory_order_acquire);
      if (next == read_cache_) {
        dropped_.fetch_add(1, std::memory_order_relaxed);
        return false;
      }
    }
    slots_[w] = std::move(value);
    write_.store(next, std::memory_order_release);
    pushed_.fetch_add(1, std::memory_order_relaxed);
    return true;
  }
  bool try_push(T&& value) noexcept { return try_push(value); }

  /// Consumer side. Moves the oldest element into `out`; false when empty.
  bool try_pop(T& out) noexcept {
    const std::size_t r = read_.load(std::memory_order_relaxed);
    if (r == write_cache_) {
      write_cache_ = write_.load(std::memory_order_acquire);
      if (r == write_cache_) return false;
    }
    out = std::move(slots_[r]);
    read_.store(r + 1 == size_ ? 0 : r + 1, std::memory_order_release);
    return true;
  }

  /// Approximate from any thread; exact from either side when the other is idle.
  std::size_t size() const noexcept {
    const std::size_t w = write_.load(std::memory_order_acquire);
    const std::size_t r = read_.load(std::memory_order_acquire);
    return w >= r ? w - r : size_ - r + w;
  }
  std::size_t capacity() const noexcept { return capacity_; }
  std::uint64_t pushed() const noexcept { return pushed_.load(std::memory_order_relaxed); }
  std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }

 private:
  const std::size_t capacity_;
  const std::size_t size_;
  std::unique_ptr<T[]> slots_;
  alignas(kCacheLine) std::atomic<std::size_t> write_{0};
  alignas(kCacheLine) std::size_t read_cache_ = 0;   // producer's copy of read_
  alignas(kCacheLine) std::atomic<std::size_t> read_{0};
  alignas(kCacheLine) std::size_t write_cache_ = 0;  // consumer's copy of write_
  alignas(kCacheLine) std::atomic<std::uint64_t> pushed_{0};
  std::atomic<std::uint64_t> dropped_{0};
};

}  // namespace rsrio

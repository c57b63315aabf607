// SpscQueue: FIFO order, bounded capacity with counted drops, and a two-thread stress run
// (run under the thread sanitizer by ./rsrio test).
#include "rsrio/common/spsc_queue.hpp"

#include <array>
#include <cstdint>
#include <thread>
#include <vector>

#include <catch2/catch_test_macros.hpp>

TEST_CASE("SpscQueue keeps FIFO order and its capacity", "[spsc_queue]") {
  rsrio::SpscQueue<int> q(3);
  CHECK(q.capacity() == 3);
  for (int i = 0; i < 3; ++i) CHECK(q.try_push(i));
  CHECK_FALSE(q.try_push(99));
  CHECK(q.dropped() == 1);
  CHECK(q.size() == 3);
  int v = -1;
  for (int i = 0; i < 3; ++i) {
    REQUIRE(q.try_pop(v));
    CHECK(v == i);
  }
  CHECK_FALSE(q.try_pop(v));
  CHECK(q.pushed() == 3);
  // wrap around many times
  for (int i = 0; i < 100; ++i) {
    REQUIRE(q.try_push(i));
    REQUIRE(q.try_pop(v));
    CHECK(v == i);
  }
  CHECK(q.size() == 0);
}

TEST_CASE("SpscQueue moves large elements without copying their payload", "[spsc_queue]") {
  rsrio::SpscQueue<std::vector<int>> q(2);
  std::vector<int> a(1000, 7);
  const int* data = a.data();
  REQUIRE(q.try_push(a));
  std::vector<int> out;
  REQUIRE(q.try_pop(out));
  CHECK(out.data() == data);
  CHECK(out.size() == 1000);
}

TEST_CASE("SpscQueue between two threads loses nothing it accepted and keeps order", "[spsc_queue][concurrency]") {
  constexpr std::uint64_t kItems = 2'000'000;
  struct Item {
    std::uint64_t seq;
    std::array<std::uint64_t, 3> payload;
  };
  rsrio::SpscQueue<Item> q(64);
  std::uint64_t accepted = 0;
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < kItems; ++i) {
      Item it{i, {i * 3, i * 5, i * 7}};
      if (q.try_push(it)) ++accepted;
    }
  });
  std::uint64_t received = 0, last = 0, bad = 0;
  bool first = true;
  bool done = false;
  while (!done) {
    Item it{};
    if (q.try_pop(it)) {
      if (!first && it.seq <= last) ++bad;
      if (it.payload[0] != it.seq * 3 || it.payload[2] != it.seq * 7) ++bad;
      last = it.seq;
      first = false;
      ++received;
    } else if (q.pushed() + q.dropped() == kItems && q.size() == 0) {
      done = true;
    }
  }
  producer.join();
  CHECK(bad == 0);
  CHECK(received == accepted);
  CHECK(q.pushed() == accepted);
  CHECK(q.dropped() == kItems - accepted);
}

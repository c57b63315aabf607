// KeyframeHandoff: the RIO thread hands the backend exactly the frames the backend's own rule makes
// keyframes, each with its predecessor and its images intact; a full hand-over drops and counts,
// and the next frame is a candidate again; two real threads pass candidates without tearing them
// (this test runs under the thread sanitizer too); hand_to_backend feeds a real backend.
#include "rsrio/runtime/keyframe_handoff.hpp"

#include <atomic>
#include <cmath>
#include <thread>
#include <vector>

#include <catch2/catch_test_macros.hpp>

#include "rsrio/common/radar_config.hpp"
#include "rsrio/dsp/processor.hpp"

namespace {

constexpr std::size_t kRa = 64, kRd = 32, kPoints = 8;

using FakeFrame = rsrio::DspImages;

FakeFrame frame_filled_with(float value, std::size_t points = 3) {
  FakeFrame f{std::vector<float>(kRa, value), std::vector<float>(kRd, -value), std::vector<rsrio::DspPoint>(points)};
  for (auto& p : f.points) p.range_m = value;
  return f;
}

Eigen::Isometry3d x_at(double x) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().x() = x;
  return T;
}

rsrio::splat::BackendOptions selection() {
  rsrio::splat::BackendOptions o;
  o.keyframe_distance_m = 0.4;
  o.keyframe_angle_deg = 10;
  o.keyframe_time_s = 1.0;
  return o;
}

}  // namespace

TEST_CASE("keyframe hand-over selects with the backend's rule and carries the predecessor", "[runtime][keyframes]") {
  rsrio::KeyframeHandoff handoff(8, kRa, kRd, kPoints, selection());
  // 0.15 m per frame at 10 Hz: the first frame only starts (no velocity yet); the second is the
  // first keyframe; then every third frame (0.45 m >= 0.4 m; 0.3 s < 1 s).
  std::vector<int> queued;
  for (int i = 0; i < 11; ++i) {
    const FakeFrame f = frame_filled_with(static_cast<float>(i));
    const auto r = handoff.offer(0.1 * i, x_at(0.15 * i), f.view());
    if (r == rsrio::KeyframeHandoff::Offer::kQueued) queued.push_back(i);
    else CHECK(r == rsrio::KeyframeHandoff::Offer::kNotDue);
  }
  CHECK(queued == std::vector<int>{1, 4, 7, 10});
  for (int expected : queued) {
    rsrio::KeyframeCandidate* c = handoff.next();
    REQUIRE(c != nullptr);
    CHECK(c->t == 0.1 * expected);
    CHECK(c->has_previous);
    CHECK(c->previous_t == 0.1 * (expected - 1));
    CHECK(c->previous_odom_T_body.translation().x() == 0.15 * (expected - 1));
    CHECK(c->ra.front() == static_cast<float>(expected));
    CHECK(c->rd.back() == -static_cast<float>(expected));
    REQUIRE(c->points.size() == 3);
    CHECK(c->points[2].range_m == static_cast<float>(expected));
    const rsrio::DspResult view = c->view();
    CHECK(view.ra.size() == kRa);
    CHECK(view.points.size() == 3);
    handoff.release(c);
  }
  CHECK(handoff.next() == nullptr);
  CHECK(handoff.dropped() == 0);

  SECTION("a turn on the spot and a pause are keyframes too") {
    rsrio::KeyframeHandoff h(4, kRa, kRd, kPoints, selection());
    const FakeFrame f = frame_filled_with(1);
    h.offer(0.0, x_at(0), f.view());
    CHECK(h.offer(0.1, x_at(0), f.view()) == rsrio::KeyframeHandoff::Offer::kQueued);
    Eigen::Isometry3d turned = x_at(0);
    turned.linear() = Eigen::AngleAxisd(11.0 * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    CHECK(h.offer(0.2, turned, f.view()) == rsrio::KeyframeHandoff::Offer::kQueued);
    CHECK(h.offer(0.3, turned, f.view()) == rsrio::KeyframeHandoff::Offer::kNotDue);
    CHECK(h.offer(1.25, turned, f.view()) == rsrio::KeyframeHandoff::Offer::kQueued);
  }
}

TEST_CASE("keyframe hand-over drops when the BA thread is behind, and offers the next frame again",
          "[runtime][keyframes]") {
  rsrio::KeyframeHandoff handoff(1, kRa, kRd, kPoints, selection());
  const FakeFrame f = frame_filled_with(1);
  handoff.offer(0.0, x_at(0), f.view());
  CHECK(handoff.offer(0.1, x_at(0.15), f.view()) == rsrio::KeyframeHandoff::Offer::kQueued);
  // Due (0.45 m) but the only slot is taken: dropped and counted.
  CHECK(handoff.offer(0.4, x_at(0.6), f.view()) == rsrio::KeyframeHandoff::Offer::kDropped);
  CHECK(handoff.dropped() == 1);
  rsrio::KeyframeCandidate* c = handoff.next();
  REQUIRE(c != nullptr);
  handoff.release(c);
  // The next frame is measured from the last frame HANDED OVER (0.15 m), so it is due at once.
  const FakeFrame g = frame_filled_with(2);
  CHECK(handoff.offer(0.5, x_at(0.65), g.view()) == rsrio::KeyframeHandoff::Offer::kQueued);
  c = handoff.next();
  REQUIRE(c != nullptr);
  CHECK(c->t == 0.5);
  CHECK(c->previous_t == 0.4);  // its predecessor is the dropped frame, which is the frame before it
  CHECK(c->ra[5] == 2.0f);
}

TEST_CASE("keyframe hand-over refuses images of the wrong size and cuts excess points", "[runtime][keyframes]") {
  rsrio::KeyframeHandoff handoff(2, kRa, kRd, kPoints, selection());
  const FakeFrame ok = frame_filled_with(1, kPoints + 5);
  FakeFrame wrong = frame_filled_with(1);
  wrong.ra.resize(kRa - 1);
  handoff.offer(0.0, x_at(0), ok.view());
  CHECK(handoff.offer(0.1, x_at(0.2), wrong.view()) == rsrio::KeyframeHandoff::Offer::kRejected);
  CHECK(handoff.offer(0.2, x_at(0.3), ok.view()) == rsrio::KeyframeHandoff::Offer::kQueued);
  rsrio::KeyframeCandidate* c = handoff.next();
  REQUIRE(c != nullptr);
  CHECK(c->points.size() == kPoints);
  CHECK(c->points_cut == 5);
}

TEST_CASE("keyframe hand-over between two threads: every candidate arrives whole or is counted as dropped",
          "[runtime][keyframes][concurrency]") {
  constexpr int kFrames = 3000;
  rsrio::KeyframeHandoff handoff(2, kRa, kRd, kPoints, selection());
  std::atomic<bool> producer_done{false};
  std::atomic<int> queued{0};
  std::atomic<int> torn{0};
  std::atomic<int> received{0};
  std::thread consumer([&] {
    while (true) {
      if (rsrio::KeyframeCandidate* c = handoff.next()) {
        const float v = c->ra.front();
        for (float x : c->ra) torn += x != v;
        for (float x : c->rd) torn += x != -v;
        torn += std::lround(c->t * 10) != std::lround(v);  // the frame index the producer wrote
        ++received;
        handoff.release(c);
        continue;
      }
      if (producer_done.load() && handoff.depth() == 0) break;  // pushed before done: seen
      std::this_thread::yield();
    }
  });
  std::thread producer([&] {
    FakeFrame f = frame_filled_with(0);
    for (int i = 0; i < kFrames; ++i) {
      std::fill(f.ra.begin(), f.ra.end(), static_cast<float>(i));
      std::fill(f.rd.begin(), f.rd.end(), -static_cast<float>(i));
      // 0.5 m per frame: every frame after the first is due.
      if (handoff.offer(0.1 * i, x_at(0.5 * i), f.view()) == rsrio::KeyframeHandoff::Offer::kQueued) ++queued;
    }
    producer_done = true;
  });
  producer.join();
  consumer.join();
  CHECK(torn == 0);
  CHECK(received == queued);
  CHECK(queued + static_cast<int>(handoff.dropped()) == kFrames - 1);
  CHECK(queued > 0);
}

TEST_CASE("keyframe hand-over: free_slots counts what an offer would find, and a producer that waits for one loses "
          "nothing (rsrio-replay --pipelined)",
          "[runtime][keyframes][concurrency]") {
  SECTION("one thread") {
    rsrio::KeyframeHandoff handoff(2, kRa, kRd, kPoints, selection());
    const FakeFrame f = frame_filled_with(1);
    CHECK(handoff.free_slots() == 2);
    handoff.offer(0.0, x_at(0), f.view());
    CHECK(handoff.free_slots() == 2);  // the first frame is only a predecessor
    CHECK(handoff.offer(0.1, x_at(0.5), f.view()) == rsrio::KeyframeHandoff::Offer::kQueued);
    CHECK(handoff.free_slots() == 1);
    CHECK(handoff.offer(0.2, x_at(1.0), f.view()) == rsrio::KeyframeHandoff::Offer::kQueued);
    CHECK(handoff.free_slots() == 0);
    CHECK(handoff.offer(0.3, x_at(1.5), f.view()) == rsrio::KeyframeHandoff::Offer::kDropped);
    rsrio::KeyframeCandidate* c = handoff.next();
    REQUIRE(c != nullptr);
    CHECK(handoff.free_slots() == 0);  // taken by the BA thread until released
    handoff.release(c);
    CHECK(handoff.free_slots() == 1);
  }
  SECTION("two threads, the producer waiting") {
    constexpr int kFrames = 2000;
    rsrio::KeyframeHandoff handoff(2, kRa, kRd, kPoints, selection());
    std::atomic<bool> producer_done{false};
    std::vector<int> order;  // consumer side only
    std::thread consumer([&] {
      while (true) {
        if (rsrio::KeyframeCandidate* c = handoff.next()) {
          order.push_back(static_cast<int>(std::lround(c->ra.front())));
          handoff.release(c);
          continue;
        }
        if (producer_done.load() && handoff.depth() == 0) break;  // pushed before done: seen
        std::this_thread::yield();
      }
    });
    int queued = 0;
    std::thread producer([&] {
      FakeFrame f = frame_filled_with(0);
      for (int i = 0; i < kFrames; ++i) {
        std::fill(f.ra.begin(), f.ra.end(), static_cast<float>(i));
        while (handoff.free_slots() == 0) std::this_thread::yield();
        if (handoff.offer(0.1 * i, x_at(0.5 * i), f.view()) == rsrio::KeyframeHandoff::Offer::kQueued) ++queued;
      }
      producer_done = true;
    });
    producer.join();
    consumer.join();
    CHECK(handoff.dropped() == 0);
    CHECK(queued == kFrames - 1);
    REQUIRE(order.size() == static_cast<std::size_t>(kFrames - 1));
    bool in_order = true;
    for (std::size_t i = 0; i < order.size(); ++i) in_order = in_order && order[i] == static_cast<int>(i) + 1;
    CHECK(in_order);
  }
}

TEST_CASE("keyframe hand-over feeds a real backend: the candidates become its keyframes, each slot comes back",
          "[runtime][keyframes]") {
  // The xwr1843's grids; flat images and no points (an empty map): what is checked is the
  // hand-over, not the optimisation. No time budgets, few iterations: deterministic and quick.
  rsrio::RadarConfig config = rsrio::radar_preset("xwr1843");
  config.loops = 32;
  const rsrio::DspGrids grids = rsrio::DspProcessor(config).grids();
  rsrio::splat::BackendOptions o = selection();
  o.pose.time_budget_s = o.mapping.time_budget_s = o.ba.time_budget_s = 0;
  o.pose.max_iterations = o.mapping.max_iterations = o.ba.max_iterations = 2;
  o.first_keyframe_mapping_iterations = 2;
  rsrio::splat::Backend backend(config, grids, o);
  const auto ra = static_cast<std::size_t>(grids.range_bins * grids.azimuth_bins);
  const auto rd = static_cast<std::size_t>(grids.range_bins * grids.doppler_bins);
  rsrio::KeyframeHandoff handoff(2, ra, rd, kPoints, o);
  const rsrio::DspImages f{std::vector<float>(ra, 1.0f), std::vector<float>(rd, 1.0f), {}};
  std::vector<double> handed;
  for (int i = 0; i < 8; ++i) {
    if (handoff.offer(0.1 * i, x_at(0.15 * i), f.view()) != rsrio::KeyframeHandoff::Offer::kQueued) continue;
    rsrio::KeyframeCandidate* c = handoff.next();
    REQUIRE(c != nullptr);
    handed.push_back(c->t);
    // The first candidate is a keyframe only because its predecessor went first (the backend
    // needs the velocity): without add_predecessor it would merely start the backend.
    CHECK(handoff.hand_to_backend(c, backend));
    CHECK(handoff.free_slots() == 2);
  }
  REQUIRE(handed.size() == 3);  // frames 1, 4, 7
  CHECK(backend.stats().keyframes == handed.size());
  const auto poses = backend.keyframe_poses();
  REQUIRE(poses.size() == handed.size());
  for (std::size_t i = 0; i < poses.size(); ++i) CHECK(poses[i].first == handed[i]);
}

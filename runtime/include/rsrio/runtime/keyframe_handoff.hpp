// The hand-over of keyframe candidates from the RIO thread to the bundle-adjustment thread.
//
// The RIO thread sees every frame; the backend optimises only keyframes (one every ~0.4 m or
// 1 s) and takes ~0.4 s each, far longer than a frame. So the RIO thread selects the frames the
// backend will make keyframes (splat::keyframe_due, the backend's own rule, measured from the last
// frame handed over), copies each one's RA / RD images and DSP points into a preallocated slot and
// pushes the slot's index; the BA thread pops it, optimises and gives the slot back. With each
// candidate goes the pose of the frame before it (the backend's velocity at the candidate).
//
// Allocation-free on the RIO side after construction. Drop policy: no free slot (the BA thread is
// behind) drops the candidate, counted in dropped(); the next frame is then a candidate again (it
// is due too), so the backend never misses a keyframe by more than a frame's motion.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "rsrio/common/spsc_queue.hpp"
#include "rsrio/dsp/processor.hpp"
#include "rsrio/splat/backend.hpp"

namespace rsrio {

/// The images and points (DspImages, sized once) of a frame the backend will make a keyframe.
struct KeyframeCandidate : DspImages {
  double t = 0;                   // the frame's measurement time (radar clock)
  Eigen::Isometry3d odom_T_body = Eigen::Isometry3d::Identity();
  double previous_t = 0;          // the frame before it (valid when has_previous)
  Eigen::Isometry3d previous_odom_T_body = Eigen::Isometry3d::Identity();
  bool has_previous = false;
  std::size_t points_cut = 0;     // points beyond the reserved capacity (not copied)
};

class KeyframeHandoff {
 public:
  /// `capacity` candidates in flight; images of `ra_size` / `rd_size` floats, at most
  /// `max_points` points each. Selection with the backend's keyframe thresholds.
  KeyframeHandoff(std::size_t capacity, std::size_t ra_size, std::size_t rd_size, std::size_t max_points,
                  const splat::BackendOptions& selection);

  enum class Offer { kNotDue, kQueued, kDropped, kRejected };
  /// RIO thread, every frame with a pose, in time order. kRejected: images of the wrong size.
  Offer offer(double t, const Eigen::Isometry3d& odom_T_body, const DspResult& dsp);

  /// BA thread: the oldest queued candidate, or null. Give it back with release().
  KeyframeCandidate* next();
  void release(KeyframeCandidate* candidate);
  /// BA thread: the candidate to `backend` (its predecessor's pose, then the frame) and its slot
  /// back, also when the backend throws (rethrown). True when the backend made it a keyframe.
  /// The daemon's BA thread and rsrio-replay --pipelined feed the backend only through this.
  bool hand_to_backend(KeyframeCandidate* candidate, splat::Backend& backend);

  /// RIO thread: slots free for the next candidate. Only the BA thread adds to it (release), so
  /// a non-zero count holds until the next offer(); a caller that must not drop (rsrio-replay
  /// --pipelined) waits for one before offering.
  std::size_t free_slots() const { return free_.size(); }
  std::size_t depth() const { return queue_.size(); }
  std::size_t capacity() const { return queue_.capacity(); }
  std::uint64_t pushed() const { return queue_.pushed(); }
  std::uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  splat::BackendOptions selection_;
  std::vector<KeyframeCandidate> slots_;
  SpscQueue<std::uint32_t> queue_;  // RIO -> BA: filled slots
  SpscQueue<std::uint32_t> free_;   // BA -> RIO: empty slots
  std::atomic<std::uint64_t> dropped_{0};
  // RIO side only.
  bool have_last_ = false, have_previous_ = false;
  double last_t_ = 0, previous_t_ = 0;
  Eigen::Isometry3d last_odom_T_body_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d previous_odom_T_body_ = Eigen::Isometry3d::Identity();
};

}  // namespace rsrio

#include "rsrio/runtime/keyframe_handoff.hpp"

#include <algorithm>

namespace rsrio {

KeyframeHandoff::KeyframeHandoff(std::size_t capacity, std::size_t ra_size, std::size_t rd_size,
                                 std::size_t max_points, const splat::BackendOptions& selection)
    : selection_(selection), slots_(capacity), queue_(capacity), free_(capacity) {
  for (std::uint32_t i = 0; i < slots_.size(); ++i) {
    slots_[i].ra.assign(ra_size, 0.0f);
    slots_[i].rd.assign(rd_size, 0.0f);
    slots_[i].points.reserve(max_points);
    std::uint32_t index = i;
    free_.try_push(index);
  }
}

KeyframeHandoff::Offer KeyframeHandoff::offer(double t, const Eigen::Isometry3d& odom_T_body, const DspResult& dsp) {
  // The frame before this one, whatever becomes of this one.
  const bool had_previous = have_previous_;
  const double previous_t = previous_t_;
  const Eigen::Isometry3d previous_pose = previous_odom_T_body_;
  have_previous_ = true;
  previous_t_ = t;
  previous_odom_T_body_ = odom_T_body;

  // The backend's first keyframe needs a predecessor (its velocity): the first frame is not due.
  if (!had_previous) return Offer::kNotDue;
  if (have_last_ && !splat::keyframe_due(selection_, t - last_t_, last_odom_T_body_.inverse() * odom_T_body))
    return Offer::kNotDue;
  if (slots_.empty() || dsp.ra.size() != slots_[0].ra.size() || dsp.rd.size() != slots_[0].rd.size())
    return Offer::kRejected;
  std::uint32_t index = 0;
  if (!free_.try_pop(index)) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return Offer::kDropped;
  }
  KeyframeCandidate& c = slots_[index];
  c.t = t;
  c.odom_T_body = odom_T_body;
  c.has_previous = true;
  c.previous_t = previous_t;
  c.previous_odom_T_body = previous_pose;
  std::copy(dsp.ra.begin(), dsp.ra.end(), c.ra.begin());
  std::copy(dsp.rd.begin(), dsp.rd.end(), c.rd.begin());
  const std::size_t n = std::min(dsp.points.size(), c.points.capacity());
  c.points.assign(dsp.points.begin(), dsp.points.begin() + static_cast<std::ptrdiff_t>(n));  // within capacity
  c.points_cut = dsp.points.size() - n;
  queue_.try_push(index);  // cannot fail: no more indices than slots
  have_last_ = true;
  last_t_ = t;
  last_odom_T_body_ = odom_T_body;
  return Offer::kQueued;
}

KeyframeCandidate* KeyframeHandoff::next() {
  std::uint32_t index = 0;
  return queue_.try_pop(index) ? &slots_[index] : nullptr;
}

void KeyframeHandoff::release(KeyframeCandidate* candidate) {
  auto index = static_cast<std::uint32_t>(candidate - slots_.data());
  free_.try_push(index);
}

bool KeyframeHandoff::hand_to_backend(KeyframeCandidate* candidate, splat::Backend& backend) {
  bool made = false;
  try {
    if (candidate->has_previous)
      backend.add_predecessor(candidate->previous_t, gtsam::Pose3(candidate->previous_odom_T_body.matrix()));
    const DspResult view = candidate->view();
    made = backend.add_frame({candidate->t, gtsam::Pose3(candidate->odom_T_body.matrix()), &view});
  } catch (...) {
    release(candidate);  // the slot is the RIO thread's again whatever the backend did with it
    throw;
  }
  release(candidate);
  return made;
}

}  // namespace rsrio

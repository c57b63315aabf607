// Radar ego-velocity from one frame's detections (paper eq. 2, as in christopherdoer/reve):
// RANSAC over minimal sets, then least squares on the inliers, with the covariance.
//
// SIGN CONVENTION (the one place it is pinned down): radar drivers and our DSP report Doppler
// velocity positive for a RECEDING target (range increasing). A static point in unit direction r
// (radar frame), seen from a radar moving with velocity v (radar frame), recedes at -r^T v, so
//
//     v_d = -r^T v        (the paper's r^T v = v_d holds for the scene's velocity, -v).
//
// Moving people and multipath ghosts do not follow this model; RANSAC sets them aside.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include <Eigen/Core>

namespace rsrio::rio {

struct DopplerMeasurement {
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  // unit vector radar -> point, radar frame
  double doppler_mps = 0;                                // positive receding
};

struct EgoVelocityOptions {
  int dimensions = 3;              // 3: full velocity; 2: planar (v_z = 0, radars without elevation)
  int min_points = 6;              // fewer detections: reject the frame
  int min_inliers = 5;
  double min_inlier_ratio = 0.4;   // below: the scene is mostly moving, do not guess
  double inlier_threshold_mps = 0.15;  // |v_d + r^T v| for a RANSAC inlier (about one Doppler bin)
  double ransac_success_probability = 0.999;
  int max_iterations = 200;
  double max_condition_number = 1e4;   // of A^T A on the inliers: beyond, the geometry is degenerate
  double max_speed_mps = 5.0;          // a walking robot indoors
  double doppler_sigma_floor_mps = 0.02;  // never claim better than this per point
  std::uint64_t seed = 1;              // RANSAC is deterministic per (seed, frame)
};

enum class EgoVelocityStatus { kOk, kTooFewPoints, kTooFewInliers, kDegenerate, kImplausible };
const char* to_string(EgoVelocityStatus s);

struct EgoVelocity {
  EgoVelocityStatus status = EgoVelocityStatus::kTooFewPoints;
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();    // radar frame, m/s
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  int points = 0;
  int inliers = 0;
  double residual_rms_mps = 0;
  double condition_number = 0;
  bool ok() const { return status == EgoVelocityStatus::kOk; }
};

/// `frame_index` varies the RANSAC sampling from frame to frame while staying deterministic.
/// Allocation-free for up to `capacity` measurements when given a scratch estimator.
class EgoVelocityEstimator {
 public:
  explicit EgoVelocityEstimator(const EgoVelocityOptions& options = {}, std::size_t capacity = 4096);
  EgoVelocity estimate(std::span<const DopplerMeasurement> points, std::uint64_t frame_index = 0);
  const EgoVelocityOptions& options() const { return options_; }

 private:
  EgoVelocityOptions options_;
  std::vector<std::uint8_t> inlier_;  // scratch, sized once
};

}  // namespace rsrio::rio

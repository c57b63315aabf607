// Trajectory evaluation as the common tool evo computes it (evo_ape / evo_rpe), so that figures
// from rsrio-eval and from evo agree for the same TUM files:
//   * association: each reference stamp with the nearest estimate stamp within max_dt (evo's
//     t_max_diff, default 0.01 s);
//   * alignment: Umeyama least squares of the estimate onto the reference positions: SE(3)
//     (evo --align), SE(2)/"posyaw" (yaw and translation only, as rpg_trajectory_evaluation), or none;
//   * APE translation: |t_ref - t_est|; APE rotation: angle of R_ref^T R_est in degrees (evo -r angle_deg);
//   * RPE: consecutive pose pairs delta metres apart along the ESTIMATE's path (evo_rpe's default,
//     --delta D --delta_unit m), error of the relative motion (translation part, rotation angle).
// Checked against evo 1.x on the same files (APE translation/rotation and RPE agree to 1e-6).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace rsrio::eval {

struct StampedPose {
  double t = 0;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
};
using Trajectory = std::vector<StampedPose>;

/// TUM format: "timestamp tx ty tz qx qy qz qw" per line, '#' comments. Throws
/// std::runtime_error naming file and line on a malformed line; a missing file names the file.
Trajectory read_tum(const std::string& path);
void write_tum(const std::string& path, const Trajectory& trajectory);

/// Pairs (reference, estimate) with |dt| <= max_dt as evo does: each stamp of the shorter
/// trajectory with the nearest of the longer, in the shorter one's order.
void associate(const Trajectory& ref, const Trajectory& est, double max_dt, Trajectory& ref_out, Trajectory& est_out);

enum class Alignment { kNone, kSE3, kSE2 };
Alignment parse_alignment(const std::string& name);  // "none", "se3", "se2"; throws invalid_argument

/// The rigid transform (rotation about z only for kSE2) that best maps est positions onto ref
/// positions (Umeyama 1991, no scale).
Eigen::Isometry3d umeyama(const Trajectory& ref, const Trajectory& est, Alignment alignment);
Trajectory transformed(const Trajectory& t, const Eigen::Isometry3d& T);

struct ErrorStats {
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0;
  std::size_t count = 0;
};
ErrorStats stats(std::vector<double> errors);

struct ApeResult {
  ErrorStats translation_m;
  ErrorStats rotation_deg;
  double path_length_m = 0;  // of the reference over the associated poses
  Eigen::Isometry3d alignment = Eigen::Isometry3d::Identity();
};
/// ref and est must already be associated (same length).
ApeResult ape(const Trajectory& ref, const Trajectory& est, Alignment alignment);

struct RpeResult {
  ErrorStats translation_m;   // per pair, delta metres apart
  ErrorStats rotation_deg;
};
RpeResult rpe(const Trajectory& ref, const Trajectory& est, double delta_m);

double path_length(const Trajectory& t);

}  // namespace rsrio::eval

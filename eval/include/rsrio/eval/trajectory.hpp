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

/// The trajectory at the given stamps (increasing): position linear, rotation slerped between the
/// two poses around each stamp. A stamp outside the trajectory, or between two poses more than
/// max_gap_s apart, gets no pose. The nearest-stamp association above pairs a 10 Hz estimate with a
/// 200 Hz ground truth up to 2.5 ms apart (1.9 ms on every frame of the simulated recordings), a
/// heading 0.1 deg off in a 51 deg/s turn; a reference resampled at the estimate's stamps pairs
/// exactly, in evo too.
Trajectory resampled(const Trajectory& t, const std::vector<double>& stamps, double max_gap_s);

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
  // The rotation error split about the world's vertical (swing-twist of R_est R_ref^T, the error
  // in the world frame): heading_deg, its signed twist about z (positive: the estimate turned
  // anticlockwise of the reference); tilt_deg, the angle between the two poses' up axes (roll and
  // pitch errors, and what an alignment that tilts the whole estimate adds to them). For small
  // errors rotation^2 = heading^2 + tilt^2. A planar radar backend refines the first; the second
  // is its frontend's, and SE(3) alignment of a frontend whose height drifts puts its tilt here.
  ErrorStats heading_deg, tilt_deg;
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

/// Where an aligned estimate's position error lies against the reference's direction of travel,
/// in the plane: along the track (positive: the estimate is ahead) and across it (positive: to
/// the left of the direction of travel). Only poses where the reference moves at min_speed_mps
/// or more count (the direction is the central difference of the reference's positions). A mean
/// along-track error is a lead or lag that the alignment cannot take out; a mean cross-track one
/// on a closed loop is a loop drawn too small (left of a counter-clockwise walk is inwards).
struct TrackErrors {
  ErrorStats along_m, across_m;  // signed: mean is the bias, rmse the size
};
/// ref and est associated (same length) and est already aligned (transformed by ApeResult::alignment).
TrackErrors track_errors(const Trajectory& ref, const Trajectory& est_aligned, double min_speed_mps = 0.2);

/// A straight stretch of the reference: moving (planar speed at least stop_speed_mps) with its
/// direction of travel within max_turn_deg of the direction at the stretch's start, so that stops
/// and turns end it; and the distance both trajectories cover over it, end to end in the plane.
/// est/ref below 1 on a leg is a walk drawn short there: a scale error of the speed the estimate
/// integrates, which no rigid alignment takes out and which one overall scale would hide where it
/// differs between legs.
struct Leg {
  double t_begin = 0, t_end = 0;  // reference stamps
  double heading_deg = 0;         // of the reference's displacement
  double ref_m = 0, est_m = 0;
};
/// ref and est associated (same length); legs shorter than min_duration_s are left out.
std::vector<Leg> straight_legs(const Trajectory& ref, const Trajectory& est, double stop_speed_mps = 0.05,
                               double max_turn_deg = 15.0, double min_duration_s = 3.0);

}  // namespace rsrio::eval

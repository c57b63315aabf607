// Revisit alignment for the backend (not in the paper). The paper's radius window lets the
// keyframes of an earlier pass tie a revisit to the map they built, but only inside the image
// loss's basin: a pose must start within about a range bin of where the map puts it. A frontend
// whose heading drifts slowly (a gyro bias error of 0.02 deg/s: 2 deg after a 90 s loop) brings
// the robot back 0.4 m and 2 deg away from its first pass, far outside that basin, and the radius
// BA then refits the old map to the drifted poses instead of correcting them (measured on
// sequence 2: the backend's heading followed the frontend's to within 0.1 deg through the
// revisit). Two pieces close that gap:
//
// 1. match_planar: a correlative scan match (Olson, "Real-time correlative scan matching", 2009)
//    of the static CFAR points of the newest keyframes (the query) against those of the earlier
//    pass's keyframes (the reference), both in the world frame: an exhaustive search over a
//    planar rigid correction (translation and yaw about the query's centroid) of a likelihood
//    field built from the reference points. It reports how well the best candidate explains the
//    query and how far the near-best candidates spread, so that a corridor's along-track
//    ambiguity is recognised and not taken as a correction.
// 2. close_loops: the accepted matches as loop constraints in a planar pose graph (GTSAM Pose2)
//    over the keyframes, with the current relative poses between consecutive keyframes as
//    odometry: the correction spreads along the chain since the earlier pass instead of jumping
//    at the newest keyframe.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace rsrio::splat {

struct PlanarMatchOptions {
  double search_m = 0.8;      // +- translation searched along x and y
  double search_deg = 4.0;    // +- yaw searched
  double cell_m = 0.05;       // likelihood-field cell, also the translation step
  double step_deg = 0.25;     // yaw step
  double sigma_m = 0.15;      // a reference point's spread in the field (radar angle and range blur)
  // Candidates scoring at least this fraction of the best make the spread (ambiguity) figures.
  double near_best_fraction = 0.9;
  std::size_t max_query_points = 800;  // evenly subsampled beyond this
  // Place the best candidate between grid steps: along yaw, x and y in turn, the vertex of the
  // parabola through the best score and its two neighbours (within half a step). Off: the
  // correction is on the grid, up to half a cell and half a yaw step (2.5 cm, 0.125 deg) from
  // the score's peak, which is what a loop constraint taken from the match alone inherits.
  bool refine_peak = true;
};

/// A planar correction q' = R(dyaw) (q - pivot) + pivot + (dx, dy) of world points.
struct PlanarCorrection {
  double dx = 0, dy = 0, dyaw = 0;
  Eigen::Vector2d pivot = Eigen::Vector2d::Zero();
  /// The correction as a world_T_world isometry (a rotation about the vertical and a horizontal
  /// translation: heights, roll and pitch are kept).
  Eigen::Isometry3d isometry() const;
};

struct PlanarMatch {
  bool valid = false;                 // both clouds non-empty and within the search's reach
  PlanarCorrection correction;        // the best candidate (between grid steps with refine_peak)
  double score = 0;                   // mean field value of the query points at the best, in [0, 1]
  double score_at_zero = 0;           // ... with no correction
  // Spread of the near-best candidates (weighted by their score above the near-best threshold):
  // sqrt of the largest eigenvalue of their translations' covariance, and their yaws' std.
  double spread_m = 0, spread_deg = 0;
};

/// Finds the planar correction of `query` that best fits `reference` (both world x, y).
/// Throws std::invalid_argument for unusable options (non-positive steps, sigma, search).
PlanarMatch match_planar(std::span<const Eigen::Vector2d> reference, std::span<const Eigen::Vector2d> query,
                         const PlanarMatchOptions& options);

/// One loop constraint: the planar pose (x, y, yaw) of keyframe `to` in the frame of keyframe
/// `from` (from < to), as a match measured it.
struct LoopConstraint {
  std::size_t from = 0, to = 0;
  Eigen::Vector3d relative = Eigen::Vector3d::Zero();
};

// Sigmas per consecutive keyframe pair (the correction spreads evenly over them) and per loop.
// The odometry's are what the chain's drift adds up to: a heading drift of 2 deg over ~150
// keyframes is 0.16 deg each as a random walk. The loops' are what the scan match and the RA
// alignment are good to (a few centimetres, a few tenths of a degree): met exactly (0.005 m /
// 0.01 deg before), two revisits of one place that disagree by half a degree bend the chain
// between the keyframes they were measured against and carry the bend round the loop
// (sequence 2's end-of-run rotation error: 0.85 deg; with these 0.25-0.29 deg in two runs).
// A loose heading sigma has its price: turning the chain moves its end by the lever arm times the
// turn without straining any step's translation, so a loop's misfit in position is partly taken
// as turns (a 1 % length misfit round a 23 m square: keyframes up to 0.30 deg off with 0.15 deg,
// 0.06 with 0.05: loop_closure_test; sequence 4's first revisit, 0.2 m, turned the chain after it
// by up to 0.34 deg). The backend's loop_graph options set these.
struct PoseGraphOptions {
  double odometry_sigma_m = 0.02;
  double odometry_sigma_deg = 0.15;
  double loop_sigma_m = 0.05;
  double loop_sigma_deg = 0.3;
  // The graph holds at most the newest max_keyframes keyframes, or from the newest constraint's
  // `from` if that lies further back (0: every keyframe since the oldest constraint). Each closure
  // solves the graph again: over an hour of laps (9000 keyframes, 96 loops) the whole chain took
  // 223-326 ms, the newest 2000 25 ms (rsrio-splat-bench); the older keyframes keep what earlier
  // closures made of them.
  std::size_t max_keyframes = 2000;
};

/// The planar poses (x, y, yaw) of a keyframe chain after the loop constraints (the newest last):
/// a Pose2 graph of the keyframes from the oldest constraint's `from` (held fixed) to the newest,
/// the current relative poses of consecutive keyframes as odometry, solved with
/// Levenberg-Marquardt. With options.max_keyframes the graph starts no earlier than that many
/// keyframes before the newest, unless the newest constraint reaches further; constraints from
/// before its first keyframe are left out (what they corrected is in the poses). Poses before its
/// first keyframe are returned unchanged. Throws std::invalid_argument for a constraint outside
/// the chain or with from >= to, and for a sigma that is not positive.
std::vector<Eigen::Vector3d> close_loops(std::span<const Eigen::Vector3d> poses,
                                         std::span<const LoopConstraint> loops, const PoseGraphOptions& options);

/// (x, y, yaw) of b in the frame of a.
Eigen::Vector3d planar_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b);

}  // namespace rsrio::splat

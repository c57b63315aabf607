#include "rsrio/splat/loop_closure.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <gtsam/geometry/Pose2.h>
#include <gtsam/inference/Symbol.h>
#include <gtsam/nonlinear/LevenbergMarquardtOptimizer.h>
#include <gtsam/nonlinear/NonlinearFactorGraph.h>
#include <gtsam/nonlinear/Values.h>
#include <gtsam/slam/BetweenFactor.h>
#include <gtsam/slam/PriorFactor.h>

namespace rsrio::splat {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

gtsam::Pose2 pose2(const Eigen::Vector3d& p) { return gtsam::Pose2(p.x(), p.y(), p.z()); }

}  // namespace

Eigen::Isometry3d PlanarCorrection::isometry() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Matrix3d R = Eigen::AngleAxisd(dyaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.linear() = R;
  const Eigen::Vector3d c(pivot.x(), pivot.y(), 0.0);
  T.translation() = c - R * c + Eigen::Vector3d(dx, dy, 0.0);
  return T;
}

PlanarMatch match_planar(std::span<const Eigen::Vector2d> reference, std::span<const Eigen::Vector2d> query,
                         const PlanarMatchOptions& o) {
  if (!(o.cell_m > 0) || !(o.step_deg > 0) || !(o.sigma_m > 0) || !(o.search_m >= 0) || !(o.search_deg >= 0) ||
      !(o.near_best_fraction > 0 && o.near_best_fraction < 1) || o.max_query_points == 0)
    throw std::invalid_argument("match_planar: steps, sigma and max_query_points must be positive, "
                                "searches >= 0, near_best_fraction in (0, 1)");
  PlanarMatch m;
  if (reference.empty() || query.empty()) return m;

  // The query, evenly subsampled, and its centroid (the pivot of the yaw search).
  std::vector<Eigen::Vector2d> q;
  const std::size_t stride = (query.size() + o.max_query_points - 1) / o.max_query_points;
  for (std::size_t i = 0; i < query.size(); i += stride) q.push_back(query[i]);
  Eigen::Vector2d pivot = Eigen::Vector2d::Zero();
  for (const auto& p : q) pivot += p;
  pivot /= static_cast<double>(q.size());

  // Likelihood field over where the moved query can land (its bounding box grown by the search,
  // the yaw search's swing at its farthest point, and the kernel), cut to the reference's box so
  // grown: memory follows the radar's range, not how far apart the reference keyframes' points
  // lie. Each cell holds the largest exp(-d^2 / 2 sigma^2) over the reference points (the max,
  // not the sum, so that a densely sampled wall does not outweigh a sparse one).
  double reach_q = 0;
  Eigen::Vector2d q_lo = q[0], q_hi = q[0];
  for (const auto& p : q) {
    q_lo = q_lo.cwiseMin(p);
    q_hi = q_hi.cwiseMax(p);
    reach_q = std::max(reach_q, (p - pivot).norm());
  }
  const double kernel = 3 * o.sigma_m + o.cell_m;
  const double swing = o.search_m + reach_q * std::sin(std::min(90.0, o.search_deg) * kDeg) + kernel;
  Eigen::Vector2d lo = reference[0], hi = reference[0];
  for (const auto& p : reference) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  lo = (lo - Eigen::Vector2d::Constant(kernel)).cwiseMax(q_lo - Eigen::Vector2d::Constant(swing));
  hi = (hi + Eigen::Vector2d::Constant(kernel)).cwiseMin(q_hi + Eigen::Vector2d::Constant(swing));
  // Disjoint boxes: no query point can reach a reference point.
  if (!(lo.x() <= hi.x() && lo.y() <= hi.y())) return m;
  const int nx = static_cast<int>(std::ceil((hi.x() - lo.x()) / o.cell_m)) + 1;
  const int ny = static_cast<int>(std::ceil((hi.y() - lo.y()) / o.cell_m)) + 1;
  std::vector<float> field(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny), 0.0f);
  const int reach = static_cast<int>(std::ceil(3 * o.sigma_m / o.cell_m));
  const double inv2s2 = 1.0 / (2 * o.sigma_m * o.sigma_m);
  for (const auto& p : reference) {
    const int cx = static_cast<int>(std::lround((p.x() - lo.x()) / o.cell_m));
    const int cy = static_cast<int>(std::lround((p.y() - lo.y()) / o.cell_m));
    for (int ix = std::max(0, cx - reach); ix <= std::min(nx - 1, cx + reach); ++ix)
      for (int iy = std::max(0, cy - reach); iy <= std::min(ny - 1, cy + reach); ++iy) {
        const double ddx = lo.x() + ix * o.cell_m - p.x(), ddy = lo.y() + iy * o.cell_m - p.y();
        const float v = static_cast<float>(std::exp(-(ddx * ddx + ddy * ddy) * inv2s2));
        float& f = field[static_cast<std::size_t>(ix) * static_cast<std::size_t>(ny) + static_cast<std::size_t>(iy)];
        f = std::max(f, v);
      }
  }

  // Exhaustive search: per yaw, the rotated query's cells once, then every integer cell shift.
  const int shifts = static_cast<int>(std::floor(o.search_m / o.cell_m));
  const int yaws = static_cast<int>(std::floor(o.search_deg / o.step_deg));
  const int side = 2 * shifts + 1;
  std::vector<float> scores(static_cast<std::size_t>(2 * yaws + 1) * static_cast<std::size_t>(side * side), 0.0f);
  std::vector<int> cx(q.size()), cy(q.size());
  const double inv_n = 1.0 / static_cast<double>(q.size());
  for (int a = -yaws; a <= yaws; ++a) {
    const double yaw = a * o.step_deg * kDeg;
    const Eigen::Rotation2Dd R(yaw);
    for (std::size_t i = 0; i < q.size(); ++i) {
      const Eigen::Vector2d p = R * (q[i] - pivot) + pivot;
      cx[i] = static_cast<int>(std::lround((p.x() - lo.x()) / o.cell_m));
      cy[i] = static_cast<int>(std::lround((p.y() - lo.y()) / o.cell_m));
    }
    float* out = &scores[static_cast<std::size_t>(a + yaws) * static_cast<std::size_t>(side * side)];
    for (int sx = -shifts; sx <= shifts; ++sx)
      for (int sy = -shifts; sy <= shifts; ++sy) {
        double s = 0;
        for (std::size_t i = 0; i < q.size(); ++i) {
          const int ix = cx[i] + sx, iy = cy[i] + sy;
          // Outside the field: nothing of the reference is near.
          if (ix < 0 || iy < 0 || ix >= nx || iy >= ny) continue;
          s += field[static_cast<std::size_t>(ix) * static_cast<std::size_t>(ny) + static_cast<std::size_t>(iy)];
        }
        out[(sx + shifts) * side + (sy + shifts)] = static_cast<float>(s * inv_n);
      }
  }

  auto unpack = [&](std::size_t idx, int& a, int& sx, int& sy) {
    a = static_cast<int>(idx / static_cast<std::size_t>(side * side)) - yaws;
    const int rest = static_cast<int>(idx % static_cast<std::size_t>(side * side));
    sx = rest / side - shifts;
    sy = rest % side - shifts;
  };
  const std::size_t best = static_cast<std::size_t>(std::max_element(scores.begin(), scores.end()) - scores.begin());
  int ba = 0, bx = 0, by = 0;
  unpack(best, ba, bx, by);
  m.valid = true;
  m.score = scores[best];
  m.score_at_zero = scores[static_cast<std::size_t>(yaws) * static_cast<std::size_t>(side * side) +
                           static_cast<std::size_t>(shifts * side + shifts)];
  // The parabola's vertex through the best score and its neighbours along one axis of the grid,
  // in steps from the best; 0 at the search's edge or where the scores do not curve down.
  auto vertex = [&](int da, int dx, int dy) {
    const int a0 = ba - da, a1 = ba + da, x0 = bx - dx, x1 = bx + dx, y0 = by - dy, y1 = by + dy;
    if (a0 < -yaws || a1 > yaws || x0 < -shifts || x1 > shifts || y0 < -shifts || y1 > shifts) return 0.0;
    auto at = [&](int a, int sx, int sy) {
      return static_cast<double>(scores[static_cast<std::size_t>(a + yaws) * static_cast<std::size_t>(side * side) +
                                        static_cast<std::size_t>((sx + shifts) * side + (sy + shifts))]);
    };
    const double lo_s = at(a0, x0, y0), mid = at(ba, bx, by), hi_s = at(a1, x1, y1);
    const double curvature = lo_s - 2 * mid + hi_s;
    if (!(curvature < 0)) return 0.0;
    return std::clamp(0.5 * (lo_s - hi_s) / curvature, -0.5, 0.5);
  };
  const double fa = o.refine_peak ? vertex(1, 0, 0) : 0.0;
  const double fx = o.refine_peak ? vertex(0, 1, 0) : 0.0;
  const double fy = o.refine_peak ? vertex(0, 0, 1) : 0.0;
  m.correction.dx = (bx + fx) * o.cell_m;
  m.correction.dy = (by + fy) * o.cell_m;
  m.correction.dyaw = (ba + fa) * o.step_deg * kDeg;
  m.correction.pivot = pivot;

  // Spread of the near-best candidates about the best.
  const double threshold = o.near_best_fraction * m.score;
  double w_sum = 0, yaw2 = 0;
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  if (m.score > 0) {
    for (std::size_t idx = 0; idx < scores.size(); ++idx) {
      if (scores[idx] < threshold) continue;
      int a = 0, sx = 0, sy = 0;
      unpack(idx, a, sx, sy);
      const double w = (scores[idx] - threshold) / (m.score - threshold + 1e-12);
      const Eigen::Vector2d d((sx - bx) * o.cell_m, (sy - by) * o.cell_m);
      cov += w * d * d.transpose();
      yaw2 += w * std::pow((a - ba) * o.step_deg, 2);
      w_sum += w;
    }
  }
  if (w_sum > 0) {
    cov /= w_sum;
    m.spread_m = std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov).eigenvalues().maxCoeff()));
    m.spread_deg = std::sqrt(yaw2 / w_sum);
  }
  return m;
}

Eigen::Vector3d planar_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const gtsam::Pose2 r = pose2(a).between(pose2(b));
  return {r.x(), r.y(), r.theta()};
}

std::vector<Eigen::Vector3d> close_loops(std::span<const Eigen::Vector3d> poses, std::span<const LoopConstraint> loops,
                                         const PoseGraphOptions& o) {
  if (!(o.odometry_sigma_m > 0) || !(o.odometry_sigma_deg > 0) || !(o.loop_sigma_m > 0) || !(o.loop_sigma_deg > 0))
    throw std::invalid_argument("close_loops: sigmas must be positive");
  std::vector<Eigen::Vector3d> out(poses.begin(), poses.end());
  if (loops.empty()) return out;
  std::size_t first = poses.size();
  for (const LoopConstraint& c : loops) {
    if (c.from >= c.to || c.to >= poses.size())
      throw std::invalid_argument("close_loops: a constraint needs from < to < the number of poses");
    first = std::min(first, c.from);
  }
  if (o.max_keyframes > 0 && poses.size() > o.max_keyframes)
    first = std::max(first, std::min(loops.back().from, poses.size() - o.max_keyframes));
  using gtsam::symbol_shorthand::X;
  gtsam::NonlinearFactorGraph graph;
  gtsam::Values values;
  const auto odometry = gtsam::noiseModel::Diagonal::Sigmas(
      gtsam::Vector3(o.odometry_sigma_m, o.odometry_sigma_m, o.odometry_sigma_deg * kDeg));
  const auto loop =
      gtsam::noiseModel::Diagonal::Sigmas(gtsam::Vector3(o.loop_sigma_m, o.loop_sigma_m, o.loop_sigma_deg * kDeg));
  graph.addPrior(X(first), pose2(poses[first]), gtsam::noiseModel::Constrained::All(3));
  for (std::size_t i = first; i < poses.size(); ++i) {
    values.insert(X(i), pose2(poses[i]));
    if (i > first)
      graph.emplace_shared<gtsam::BetweenFactor<gtsam::Pose2>>(X(i - 1), X(i), pose2(poses[i - 1]).between(pose2(poses[i])),
                                                               odometry);
  }
  for (const LoopConstraint& c : loops)
    if (c.from >= first)
      graph.emplace_shared<gtsam::BetweenFactor<gtsam::Pose2>>(X(c.from), X(c.to), pose2(c.relative), loop);
  const gtsam::Values result = gtsam::LevenbergMarquardtOptimizer(graph, values).optimize();
  for (std::size_t i = first; i < poses.size(); ++i) {
    const gtsam::Pose2 p = result.at<gtsam::Pose2>(X(i));
    // Keep the yaw continuous with the input (Pose2 wraps it into (-pi, pi]).
    const double yaw = poses[i].z() + std::remainder(p.theta() - poses[i].z(), 2 * std::numbers::pi);
    out[i] = Eigen::Vector3d(p.x(), p.y(), yaw);
  }
  return out;
}

}  // namespace rsrio::splat

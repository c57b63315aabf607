#include "rsrio/rio/ego_velocity.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

namespace rsrio::rio {

const char* to_string(EgoVelocityStatus s) {
  switch (s) {
    case EgoVelocityStatus::kOk: return "ok";
    case EgoVelocityStatus::kTooFewPoints: return "too few points";
    case EgoVelocityStatus::kTooFewInliers: return "too few inliers (mostly moving scene?)";
    case EgoVelocityStatus::kDegenerate: return "degenerate geometry";
    case EgoVelocityStatus::kImplausible: return "implausible speed";
  }
  return "?";
}

EgoVelocityEstimator::EgoVelocityEstimator(const EgoVelocityOptions& options, std::size_t capacity)
    : options_(options), inlier_(capacity, 0) {}

namespace {

// Rows a_i = -r_i (first `dims` components) so that a_i^T v = v_d.
inline Eigen::Vector3d row(const DopplerMeasurement& m, int dims) {
  Eigen::Vector3d a = -m.direction;
  if (dims == 2) a.z() = 0;
  return a;
}

// Least squares over the flagged points; false when A^T A is singular.
bool solve(std::span<const DopplerMeasurement> pts, const std::uint8_t* use, int dims, Eigen::Vector3d& v,
           Eigen::Matrix3d& ata, double& cond) {
  ata.setZero();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (use && !use[i]) continue;
    const Eigen::Vector3d a = row(pts[i], dims);
    ata += a * a.transpose();
    atb += a * pts[i].doppler_mps;
  }
  if (dims == 2) ata(2, 2) = 1.0;  // v_z fixed at zero: keep the system regular
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(ata, Eigen::EigenvaluesOnly);
  const double lo = eig.eigenvalues()(0), hi = eig.eigenvalues()(2);
  cond = lo > 0 ? hi / lo : INFINITY;
  if (!(lo > 1e-12)) return false;
  v = ata.ldlt().solve(atb);
  if (dims == 2) v.z() = 0;
  return v.allFinite();
}

}  // namespace

EgoVelocity EgoVelocityEstimator::estimate(std::span<const DopplerMeasurement> pts, std::uint64_t frame_index) {
  const auto& o = options_;
  EgoVelocity out;
  out.points = static_cast<int>(pts.size());
  const int dims = o.dimensions == 2 ? 2 : 3;
  const std::size_t n = std::min(pts.size(), inlier_.size());
  pts = pts.first(n);
  if (static_cast<int>(n) < std::max(o.min_points, dims + 1)) {
    out.status = EgoVelocityStatus::kTooFewPoints;
    return out;
  }

  // RANSAC on minimal sets of `dims` points; the iteration count adapts to the inlier ratio.
  std::mt19937_64 rng(o.seed * 0x9E3779B97F4A7C15ull + frame_index);
  std::uniform_int_distribution<std::size_t> pick(0, n - 1);
  int best_count = -1;
  Eigen::Vector3d best = Eigen::Vector3d::Zero();
  int needed = o.max_iterations;
  for (int it = 0; it < std::min(needed, o.max_iterations); ++it) {
    std::size_t idx[3];
    for (int k = 0; k < dims; ++k) {
      bool fresh;
      do {
        idx[k] = pick(rng);
        fresh = true;
        for (int j = 0; j < k; ++j) fresh &= idx[j] != idx[k];
      } while (!fresh);
    }
    Eigen::Matrix3d A = Eigen::Matrix3d::Identity();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    for (int k = 0; k < dims; ++k) {
      A.row(k) = row(pts[idx[k]], dims).transpose();
      b(k) = pts[idx[k]].doppler_mps;
    }
    if (dims == 2) A.row(2) = Eigen::RowVector3d(0, 0, 1);
    const Eigen::FullPivLU<Eigen::Matrix3d> lu(A);
    if (!lu.isInvertible()) continue;
    const Eigen::Vector3d v = lu.solve(b);
    if (!v.allFinite() || v.norm() > 2 * o.max_speed_mps) continue;
    int count = 0;
    for (std::size_t i = 0; i < n; ++i)
      count += std::abs(row(pts[i], dims).dot(v) - pts[i].doppler_mps) < o.inlier_threshold_mps;
    if (count > best_count) {
      best_count = count;
      best = v;
      const double w = std::clamp(double(count) / double(n), 1e-3, 1.0 - 1e-9);
      const double p_fail = 1.0 - std::pow(w, dims);
      needed = p_fail <= 0 ? 1 : static_cast<int>(std::ceil(std::log(1 - o.ransac_success_probability) / std::log(p_fail)));
    }
  }

  if (best_count < 0) {  // no minimal set was solvable: every point says the same thing
    out.status = EgoVelocityStatus::kDegenerate;
    return out;
  }
  // Least squares on the inliers, then once more on the inliers of the refined solution.
  Eigen::Vector3d v = best;
  Eigen::Matrix3d ata;
  double cond = INFINITY;
  int inliers = 0;
  for (int pass = 0; pass < 2; ++pass) {
    inliers = 0;
    for (std::size_t i = 0; i < n; ++i) {
      inlier_[i] = std::abs(row(pts[i], dims).dot(v) - pts[i].doppler_mps) < o.inlier_threshold_mps;
      inliers += inlier_[i];
    }
    if (inliers < std::max(o.min_inliers, dims + 1) || inliers < o.min_inlier_ratio * double(n)) {
      out.status = EgoVelocityStatus::kTooFewInliers;
      out.inliers = inliers;
      return out;
    }
    if (!solve(pts, inlier_.data(), dims, v, ata, cond)) {
      out.status = EgoVelocityStatus::kDegenerate;
      out.inliers = inliers;
      return out;
    }
  }
  double ss = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (inlier_[i]) ss += std::pow(row(pts[i], dims).dot(v) - pts[i].doppler_mps, 2);
  out.inliers = inliers;
  out.residual_rms_mps = std::sqrt(ss / inliers);
  out.condition_number = cond;
  if (cond > o.max_condition_number) {
    out.status = EgoVelocityStatus::kDegenerate;
    return out;
  }
  if (v.norm() > o.max_speed_mps) {
    out.status = EgoVelocityStatus::kImplausible;
    return out;
  }
  const double sigma2 = std::max(ss / std::max(1, inliers - dims), o.doppler_sigma_floor_mps * o.doppler_sigma_floor_mps);
  out.covariance = sigma2 * ata.inverse();
  if (dims == 2) {
    out.covariance.row(2).setZero();
    out.covariance.col(2).setZero();
    out.covariance(2, 2) = 1e6;  // unobserved: z is not estimated in planar mode
  }
  out.velocity = v;
  out.status = EgoVelocityStatus::kOk;
  return out;
}

}  // namespace rsrio::rio

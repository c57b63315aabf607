#include "rsrio/rio/frontend.hpp"

#include <algorithm>
#include <iterator>

#include <gtsam/inference/Symbol.h>
#include <gtsam/linear/GaussianFactorGraph.h>
#include <gtsam/linear/VectorValues.h>
#include <gtsam/nonlinear/LevenbergMarquardtOptimizer.h>
#include <gtsam/nonlinear/LinearContainerFactor.h>
#include <gtsam/nonlinear/Marginals.h>
#include <gtsam/slam/PriorFactor.h>

#include "rsrio/rio/first_estimate_factor.hpp"
#include "rsrio/rio/radar_velocity_factor.hpp"

namespace rsrio::rio {

const char* to_string(FrontendOptions::ImuInterpolation m) {
  return m == FrontendOptions::ImuInterpolation::kHold ? "hold" : "linear";
}

bool imu_interpolation_from_string(const std::string& name, FrontendOptions::ImuInterpolation& m) {
  for (auto c : {FrontendOptions::ImuInterpolation::kLinear, FrontendOptions::ImuInterpolation::kHold})
    if (name == to_string(c)) {
      m = c;
      return true;
    }
  return false;
}

using gtsam::symbol_shorthand::B;
using gtsam::symbol_shorthand::V;
using gtsam::symbol_shorthand::X;

RioFrontend::RioFrontend(const FrontendOptions& o) : options_(o) {
  params_ = gtsam::PreintegrationCombinedParams::MakeSharedU(o.gravity);
  params_->accelerometerCovariance = gtsam::I_3x3 * o.accel_noise_density * o.accel_noise_density;
  params_->gyroscopeCovariance = gtsam::I_3x3 * o.gyro_noise_density * o.gyro_noise_density;
  params_->integrationCovariance = gtsam::I_3x3 * 1e-8;
  params_->biasAccCovariance = gtsam::I_3x3 * o.accel_bias_random_walk * o.accel_bias_random_walk;
  params_->biasOmegaCovariance = gtsam::I_3x3 * o.gyro_bias_random_walk * o.gyro_bias_random_walk;
  // GTSAM 4.2 adds biasAccOmegaInt to both white noises at every sample (its default I_6x6 would
  // swamp them): the window takes the options' (extra noise, frontend.hpp), the batch none.
  whole_params_ = boost::make_shared<gtsam::PreintegrationCombinedParams>(*params_);
  params_->biasAccOmegaInt = gtsam::I_6x6 * o.bias_acc_omega_int;
  whole_params_->biasAccOmegaInt = gtsam::Matrix6::Zero();
}

void RioFrontend::add_imu(const ImuSample& s) {
  if ((!imu_.empty() && s.t <= imu_.back().t) || (!window_.empty() && s.t < window_.back().second)) {
    ++imu_ignored_;
    return;
  }
  imu_.push_back(s);
  // Keep what the oldest state of the window may still need, and the initialisation window.
  const double keep_from = window_.empty() ? s.t - 2 * options_.init_imu_window_s - 1.0 : window_.front().second - 0.5;
  while (imu_.size() > 2 && imu_[1].t < keep_from) imu_.pop_front();
}

gtsam::Vector3 RioFrontend::gyro_at(double t) const {
  if (imu_.empty()) return gtsam::Vector3::Zero();
  // add_imu keeps the stamps strictly increasing: the first sample at or after t, by bisection
  // (called twice a frame: the radar factor and the published state).
  const auto b = std::lower_bound(std::next(imu_.begin()), imu_.end(), t,
                                  [](const ImuSample& s, double time) { return s.t < time; });
  if (b == imu_.end()) return imu_.back().gyro;
  const auto& a = *std::prev(b);
  const double w = std::clamp((t - a.t) / (b->t - a.t), 0.0, 1.0);
  return (1 - w) * a.gyro + w * b->gyro;
}

template <class F>
void RioFrontend::for_each_imu_piece(double t0, double t1, F&& f) const {
  for (std::size_t i = 0; i < imu_.size(); ++i) {
    const bool has_next = i + 1 < imu_.size();
    const double a = std::max(imu_[i].t, t0);
    const double b = std::min(has_next ? imu_[i + 1].t : t1, t1);
    if (b <= a + 1e-9) continue;
    if (!has_next || options_.imu_interpolation == FrontendOptions::ImuInterpolation::kHold) {
      f(imu_[i].accel, imu_[i].gyro, b - a);
      continue;
    }
    // A straight line integrates over [a, b] as its value at the middle (the trapezoid rule, cut
    // exactly at t0 and t1).
    const double w = (0.5 * (a + b) - imu_[i].t) / (imu_[i + 1].t - imu_[i].t);
    f((1 - w) * imu_[i].accel + w * imu_[i + 1].accel, (1 - w) * imu_[i].gyro + w * imu_[i + 1].gyro, b - a);
  }
}

void RioFrontend::preintegrate(double t0, double t1, gtsam::PreintegratedCombinedMeasurements& pim,
                               gtsam::PreintegratedCombinedMeasurements* also) const {
  const auto integrate = [&](const gtsam::Vector3& accel, const gtsam::Vector3& gyro, double dt) {
    pim.integrateMeasurement(accel, gyro, dt);
    if (also != nullptr) also->integrateMeasurement(accel, gyro, dt);
  };
  for_each_imu_piece(t0, t1, integrate);
  if (pim.deltaTij() < 1e-9) integrate(imu_.back().accel, imu_.back().gyro, std::max(t1 - t0, 1e-6));
}

bool RioFrontend::initialise(double t, const EgoVelocity& ego) {
  gtsam::Vector3 mean_acc = gtsam::Vector3::Zero();
  int n = 0;
  for (const auto& s : imu_)
    if (s.t <= t && s.t >= t - options_.init_imu_window_s) {
      mean_acc += s.accel;
      ++n;
    }
  if (n == 0) return false;
  mean_acc /= n;
  // Roll and pitch put the measured specific force (gravity reaction) along body z; yaw is the gauge.
  const double roll = std::atan2(mean_acc.y(), mean_acc.z());
  const double pitch = std::atan2(-mean_acc.x(), std::hypot(mean_acc.y(), mean_acc.z()));
  const gtsam::Pose3 pose(gtsam::Rot3::Ypr(0, pitch, roll), gtsam::Point3::Zero());
  gtsam::Vector3 v_world = gtsam::Vector3::Zero();
  if (ego.ok()) {
    const gtsam::Rot3& R_BR = options_.body_T_radar.rotation();
    const gtsam::Vector3 v_body =
        R_BR.rotate(ego.velocity) - gyro_at(t).cross(options_.body_T_radar.translation());
    v_world = pose.rotation().rotate(v_body);
  }
  const std::uint64_t k = next_++;
  values_.insert(X(k), pose);
  values_.insert(V(k), v_world);
  values_.insert(B(k), gtsam::imuBias::ConstantBias());
  gtsam::Vector6 pose_sigmas;
  pose_sigmas << gtsam::Vector3::Constant(options_.prior_rotation_sigma), gtsam::Vector3::Constant(options_.prior_position_sigma);
  add_factor(boost::make_shared<gtsam::PriorFactor<gtsam::Pose3>>(X(k), pose,
                                                                  gtsam::noiseModel::Diagonal::Sigmas(pose_sigmas)));
  add_factor(boost::make_shared<gtsam::PriorFactor<gtsam::Vector3>>(
      V(k), v_world, gtsam::noiseModel::Isotropic::Sigma(3, options_.prior_velocity_sigma)));
  gtsam::Vector6 bias_sigmas;
  bias_sigmas << gtsam::Vector3::Constant(options_.prior_accel_bias_sigma),
      gtsam::Vector3::Constant(options_.prior_gyro_bias_sigma);
  add_factor(boost::make_shared<gtsam::PriorFactor<gtsam::imuBias::ConstantBias>>(
      B(k), gtsam::imuBias::ConstantBias(), gtsam::noiseModel::Diagonal::Sigmas(bias_sigmas)));
  window_.emplace_back(k, t);
  if (options_.whole_run_smoother) whole_times_.emplace_back(k, t - options_.radar_time_offset_s);
  add_radar_factor(k, t, ego);
  return true;
}

void RioFrontend::add_radar_factor(std::uint64_t k, double t, const EgoVelocity& ego) {
  if (!options_.use_radar || !ego.ok()) {
    ++frames_without_radar_;
    return;
  }
  const double s2 = options_.radar_velocity_sigma_scale * options_.radar_velocity_sigma_scale;
  auto gaussian = gtsam::noiseModel::Gaussian::Covariance(ego.covariance * s2 + gtsam::I_3x3 * 1e-6);
  auto robust = gtsam::noiseModel::Robust::Create(gtsam::noiseModel::mEstimator::Huber::Create(options_.huber_k), gaussian);
  add_factor(boost::make_shared<RadarVelocityFactor>(X(k), V(k), B(k), ego.velocity, gyro_at(t), options_.body_T_radar,
                                                     robust));
}

void RioFrontend::add_zero_rate_factor(std::uint64_t k, double t0, double t1, const EgoVelocity& ego) {
  if (!options_.zero_rate_update || !options_.use_radar) return;
  StillInterval cur;
  cur.k = k;
  gtsam::Vector3 sum = gtsam::Vector3::Zero();
  for_each_imu_piece(t0, t1, [&](const gtsam::Vector3&, const gtsam::Vector3& gyro, double dt) {
    sum += gyro * dt;
    cur.dt += dt;
  });
  if (cur.dt > 1e-3) cur.mean = sum / cur.dt;
  // Still: the radar sees no motion and the gyro shows nothing beyond the bias we believe in.
  const gtsam::Vector3 bias = values_.at<gtsam::imuBias::ConstantBias>(B(k)).gyroscope();
  cur.candidate = cur.dt > 1e-3 && ego.ok() && ego.velocity.norm() < options_.still_speed_mps &&
                  (cur.mean - bias).norm() < options_.still_gyro_rate;
  const std::size_t n = 2 * static_cast<std::size_t>(options_.still_neighbours) + 1;
  still_.push_back(cur);
  while (still_.size() > n) still_.pop_front();
  // An interval counts only between still neighbours: the first and last tenths of a second of a
  // turn on the spot turn slower than the gate, and a rig that has just stopped still sways (a few
  // mrad/s, far above still_rate_sigma, under the gate): neither must be taken for standing.
  if (still_.size() < n) return;
  for (const StillInterval& s : still_)
    if (!s.candidate) return;
  const StillInterval& mid = still_[n / 2];
  if (!values_.exists(B(mid.k))) return;
  // gyro = bias + rate + noise with rate ~ 0: the mean over dt measures the bias.
  const double sg = std::sqrt(options_.gyro_noise_density * options_.gyro_noise_density / mid.dt +
                              options_.still_rate_sigma * options_.still_rate_sigma);
  gtsam::Vector6 sigmas;
  sigmas << gtsam::Vector3::Constant(1e3), gtsam::Vector3::Constant(sg);  // accel part: unconstrained
  const auto b_mid = values_.at<gtsam::imuBias::ConstantBias>(B(mid.k));
  add_factor(boost::make_shared<gtsam::PriorFactor<gtsam::imuBias::ConstantBias>>(
      B(mid.k), gtsam::imuBias::ConstantBias(b_mid.accelerometer(), mid.mean), gtsam::noiseModel::Diagonal::Sigmas(sigmas)));
  ++zero_rate_updates_;
}

void RioFrontend::marginalise_oldest() {
  const std::uint64_t j = window_.front().first;
  const gtsam::KeyVector old{X(j), V(j), B(j)};
  gtsam::NonlinearFactorGraph involved, kept;
  for (const auto& f : graph_) {
    if (!f) continue;
    bool touches = false;
    for (gtsam::Key key : f->keys()) touches |= std::find(old.begin(), old.end(), key) != old.end();
    (touches ? involved : kept).push_back(f);
  }
  // p(old, rest) = p(old | rest) p(rest): keep p(rest) as a linear prior at today's estimate.
  const auto linear = involved.linearize(values_);
  const auto [bayes_tree, marginal] = linear->eliminatePartialMultifrontal(old);
  for (const auto& gf : *marginal)
    if (gf) kept.push_back(boost::make_shared<gtsam::LinearContainerFactor>(gf, values_));
  if (options_.first_estimate_jacobians) {
    // The marginal's variables at its linearisation point: every factor that reaches them, now
    // and later (add_factor), takes its Jacobians there.
    first_estimates_.clear();
    for (const auto& gf : *marginal)
      if (gf)
        for (gtsam::Key key : gf->keys())
          if (!first_estimates_.exists(key)) first_estimates_.insert(key, values_.at(key));
    for (auto& f : kept)
      if (f && !boost::dynamic_pointer_cast<gtsam::LinearContainerFactor>(f)) f = at_first_estimates(f);
  }
  graph_ = kept;
  if (options_.whole_run_smoother)
    for (gtsam::Key key : old) whole_values_.insert(key, values_.at(key));
  for (gtsam::Key key : old) values_.erase(key);
  window_.pop_front();
}

gtsam::NonlinearFactor::shared_ptr RioFrontend::at_first_estimates(const gtsam::NonlinearFactor::shared_ptr& factor) const {
  for (gtsam::Key key : factor->keys())
    if (first_estimates_.exists(key)) return boost::make_shared<FirstEstimateFactor>(factor, first_estimates_);
  return factor;
}

void RioFrontend::add_factor(const gtsam::NonlinearFactor::shared_ptr& factor) {
  graph_.push_back(at_first_estimates(factor));  // (first_estimates_ is empty without the option)
  if (options_.whole_run_smoother) whole_graph_.push_back(factor);
}

gtsam::PreintegratedCombinedMeasurements RioFrontend::add_imu_factor(std::uint64_t prev, std::uint64_t k, double t0,
                                                                      double t1, const gtsam::imuBias::ConstantBias& bias) {
  gtsam::PreintegratedCombinedMeasurements pim(params_, bias);
  if (!options_.whole_run_smoother) {
    preintegrate(t0, t1, pim);
  } else {
    gtsam::PreintegratedCombinedMeasurements own(whole_params_, bias);
    preintegrate(t0, t1, pim, &own);  // one walk over the samples for both
    whole_graph_.push_back(boost::make_shared<gtsam::CombinedImuFactor>(X(prev), V(prev), X(k), V(k), B(prev), B(k), own));
  }
  graph_.push_back(boost::make_shared<gtsam::CombinedImuFactor>(X(prev), V(prev), X(k), V(k), B(prev), B(k), pim));
  return pim;
}

double RioFrontend::heading_gauge_information() const {
  // A turn by d about the world's z through the origin: R -> Rz R = R Exp(R^T z d), t -> t + (z x t) d,
  // v -> v + (z x v) d, biases unchanged; in GTSAM's tangents (rotation, then translation in the
  // body frame for Pose3). Its information is d^T H d for unit d, H the window's Hessian.
  const gtsam::Vector3 z = gtsam::Vector3::UnitZ();
  gtsam::VectorValues d;
  gtsam::Ordering ordering;
  for (const auto& [k, t] : window_) {
    const gtsam::Pose3& pose = values_.at<gtsam::Pose3>(X(k));
    gtsam::Vector6 xi;
    xi << pose.rotation().unrotate(z), pose.rotation().unrotate(z.cross(pose.translation()));
    d.insert(X(k), xi);
    d.insert(V(k), gtsam::Vector3(z.cross(values_.at<gtsam::Vector3>(V(k)))));
    d.insert(B(k), gtsam::Vector6::Zero());
    ordering.push_back(X(k));
    ordering.push_back(V(k));
    ordering.push_back(B(k));
  }
  const auto [H, eta] = graph_.linearize(values_)->hessian(ordering);
  const gtsam::Vector dv = d.vector(ordering);
  return dv.dot(H * dv);
}

std::vector<SmoothedState> RioFrontend::smooth_whole_run(int max_iterations) const {
  std::vector<SmoothedState> out;
  if (!options_.whole_run_smoother || whole_times_.empty()) return out;
  // The states that left the window at their estimate then, the window's at today's.
  gtsam::Values initial = whole_values_;
  initial.insert(values_);
  gtsam::LevenbergMarquardtParams lm;
  lm.setMaxIterations(max_iterations);
  lm.setVerbosityLM("SILENT");
  const gtsam::Values solved = gtsam::LevenbergMarquardtOptimizer(whole_graph_, initial, lm).optimize();
  out.reserve(whole_times_.size());
  for (const auto& [k, t] : whole_times_)
    out.push_back({t, solved.at<gtsam::Pose3>(X(k)), solved.at<gtsam::Vector3>(V(k)),
                   solved.at<gtsam::imuBias::ConstantBias>(B(k))});
  return out;
}

FrontendState RioFrontend::state(std::uint64_t k, double t_radar, bool radar_used) {
  FrontendState s;
  s.t = t_radar;
  const gtsam::Pose3 estimate = values_.at<gtsam::Pose3>(X(k));
  if (options_.continuous_odometry && zero_rate_updates_ != offset_zero_rate_updates_ && published_k_ &&
      values_.exists(X(*published_k_))) {
    // A zero-rate update came in: the offset (a rotation about the vertical and a translation)
    // that puts the window's new estimate of the previously published state where it was
    // published. Between updates the offset stands, and the window's smoothing is published as
    // before.
    offset_zero_rate_updates_ = zero_rate_updates_;
    const gtsam::Pose3 previous_now = values_.at<gtsam::Pose3>(X(*published_k_));
    const gtsam::Matrix3 d = published_.rotation().matrix() * previous_now.rotation().matrix().transpose();
    const gtsam::Rot3 yaw = gtsam::Rot3::Rz(std::atan2(d(1, 0) - d(0, 1), d(0, 0) + d(1, 1)));
    offset_ = gtsam::Pose3(yaw, published_.translation() - yaw.rotate(previous_now.translation()));
  }
  s.world_T_body = offset_ * estimate;
  s.velocity_world = offset_.rotation().rotate(values_.at<gtsam::Vector3>(V(k)));
  if (options_.position_from_velocity && published_k_) {
    gtsam::Vector3 p =
        published_.translation() + 0.5 * (t_radar - published_t_) * (published_velocity_ + s.velocity_world);
    p.z() = s.world_T_body.translation().z();
    s.world_T_body = gtsam::Pose3(s.world_T_body.rotation(), p);
  }
  published_ = s.world_T_body;
  published_t_ = t_radar;
  published_velocity_ = s.velocity_world;
  published_k_ = k;
  s.bias = values_.at<gtsam::imuBias::ConstantBias>(B(k));
  s.angular_velocity_body = s.bias.correctGyroscope(gyro_at(t_radar + options_.radar_time_offset_s));
  s.radar_used = radar_used;
  try {
    s.pose_covariance = gtsam::Marginals(graph_, values_).marginalCovariance(X(k));
  } catch (const std::exception&) {
    s.pose_covariance = gtsam::Matrix6::Identity() * 1e3;  // indeterminate: say so, do not invent
  }
  return s;
}

std::optional<FrontendState> RioFrontend::add_radar(double t_radar, const EgoVelocity& ego) {
  const double t = t_radar + options_.radar_time_offset_s;
  if (window_.empty()) {
    if (!initialise(t, ego)) return std::nullopt;
    return state(window_.back().first, t_radar, options_.use_radar && ego.ok());
  }
  const auto [prev, t_prev] = window_.back();
  if (t <= t_prev || imu_.empty()) return std::nullopt;
  const auto bias_prev = values_.at<gtsam::imuBias::ConstantBias>(B(prev));
  const std::uint64_t k = next_++;
  const gtsam::PreintegratedCombinedMeasurements pim = add_imu_factor(prev, k, t_prev, t, bias_prev);
  const gtsam::NavState predicted =
      pim.predict(gtsam::NavState(values_.at<gtsam::Pose3>(X(prev)), values_.at<gtsam::Vector3>(V(prev))), bias_prev);
  values_.insert(X(k), predicted.pose());
  values_.insert(V(k), predicted.v());
  values_.insert(B(k), bias_prev);
  window_.emplace_back(k, t);
  if (options_.whole_run_smoother) whole_times_.emplace_back(k, t - options_.radar_time_offset_s);
  add_radar_factor(k, t, ego);
  add_zero_rate_factor(k, t_prev, t, ego);

  gtsam::LevenbergMarquardtParams lm;
  lm.setMaxIterations(options_.lm_max_iterations);
  lm.setVerbosityLM("SILENT");
  values_ = gtsam::LevenbergMarquardtOptimizer(graph_, values_, lm).optimize();
  std::optional<SettledState> settled;
  if (static_cast<int>(window_.size()) > options_.window_states) {
    const auto [j, t_j] = window_.front();
    settled = SettledState{t_j - options_.radar_time_offset_s, offset_ * values_.at<gtsam::Pose3>(X(j)),
                           values_.at<gtsam::imuBias::ConstantBias>(B(j))};
    marginalise_oldest();
  }
  FrontendState s = state(k, t_radar, options_.use_radar && ego.ok());
  s.settled = settled;
  return s;
}

gtsam::Pose3 retilted(const gtsam::Pose3& world_T_body, const gtsam::Vector3& accel_bias_then,
                      const gtsam::Vector3& accel_bias_now, double gravity) {
  // At rest f = R^T g_up + b: the state explained f with R_then and b_then, so the true up in the
  // body is R_then^T e_z + (b_then - b_now) / g; the rotation phi (body frame, perpendicular to up)
  // with R = R_then Exp(phi) moves up by -phi x up, hence phi = w x up for w the difference across up.
  const gtsam::Vector3 up = world_T_body.rotation().unrotate(gtsam::Vector3::UnitZ());
  const gtsam::Vector3 d = (accel_bias_then - accel_bias_now) / gravity;
  const gtsam::Vector3 w = d - d.dot(up) * up;
  return gtsam::Pose3(world_T_body.rotation() * gtsam::Rot3::Expmap(w.cross(up)), world_T_body.translation());
}

gtsam::Pose3 with_tilt_of(const gtsam::Pose3& world_T_body, const gtsam::Rot3& attitude) {
  // Q takes the pose's up (in the body frame) to attitude's; R' = R Q^T has R'^T e_z = Q R^T e_z.
  const gtsam::Vector3 from = world_T_body.rotation().unrotate(gtsam::Vector3::UnitZ());
  const gtsam::Vector3 to = attitude.unrotate(gtsam::Vector3::UnitZ());
  const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(from, to);
  return gtsam::Pose3(world_T_body.rotation() * gtsam::Rot3(q.toRotationMatrix().transpose()), world_T_body.translation());
}

}  // namespace rsrio::rio

#include "rsrio/splat/backend.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <limits>
#include <numbers>
#include <numeric>
#include <stdexcept>

namespace rsrio::splat {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

bool finite(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

Eigen::Isometry3d to_isometry(const gtsam::Pose3& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = p.rotation().matrix();
  T.translation() = p.translation();
  return T;
}

gtsam::Pose3 to_pose3(const Eigen::Isometry3d& T) {
  // Re-orthonormalise: products of many isometries drift by rounding.
  const Eigen::Quaterniond q(T.linear());
  return gtsam::Pose3(gtsam::Rot3(q.normalized()), gtsam::Point3(T.translation()));
}

// The keyframe's radar pose as its odometry has it, in the plane: what the odometry priors hold
// the map pose to (the yaw prior: its heading plus Keyframe::loop_yaw).
PlanarPose odometry_radar_pose(const Keyframe& kf, const Eigen::Isometry3d& body_T_radar) {
  return PlanarPose::from_world_T_radar(kf.odom_T_body * body_T_radar);
}

enum class PointClass { unusable, dynamic, static_point };

/// Whether a CFAR point may seed the map and take part in revisit alignment: finite, strong
/// enough, and static (a static point seen from a radar moving with v has range rate -u . v).
PointClass classify_point(const rsrio::DspPoint& p, const Eigen::Vector3d& velocity, const BackendOptions& o) {
  if (p.snr_db < o.min_point_snr_db) return PointClass::unusable;
  const Eigen::Vector3d x(p.x, p.y, p.z);
  const double r = x.norm();
  if (!x.allFinite() || !(r > 0)) return PointClass::unusable;
  const double expected = -x.dot(velocity) / r;
  return std::abs(p.doppler_mps - expected) > o.static_doppler_tolerance_mps ? PointClass::dynamic
                                                                            : PointClass::static_point;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

// ------------------------------------------------------------------------------------------------
// objective

template <typename Scalar>
KeyframeObjective<Scalar>::KeyframeObjective(const RadarImageGrid& grid, const RaRenderOptions& ra_options,
                                             const RdRenderOptions& rd_options, const ImageLossOptions& ra_loss,
                                             const ImageLossOptions& rd_loss, bool rd_image_gradient)
    : ra_renderer_(grid, ra_options),
      rd_renderer_(grid, rd_options),
      ra_loss_(ra_loss),
      rd_loss_(rd_loss),
      rd_image_gradient_(rd_image_gradient) {}

template <typename Scalar>
typename KeyframeObjective<Scalar>::Result KeyframeObjective<Scalar>::evaluate(
    const GaussianScene& scene, std::span<const std::uint32_t> gaussians, const Eigen::Isometry3d& radar_T_world,
    const Eigen::Vector3d* velocity, const Image<Scalar>& ra_target, const Image<Scalar>& rd_target, double ra_weight,
    double rd_weight, SceneGradients* scene_gradients, Vector6d* grad_pose, Eigen::Vector3d* grad_velocity,
    const PixelDirections<Scalar>* directions, std::span<const int> visible_rows) {
  Result r;
  const bool backward = scene_gradients != nullptr || grad_pose != nullptr;
  ra_renderer_.render(scene, radar_T_world, gaussians, ra_);
  // The RA loss on the pixels before the occluders only; the RD from the whole RA, as the
  // measured RD holds every return the radar received, whatever its azimuth.
  const Image<Scalar>* ra_compared = &ra_;
  if (!visible_rows.empty()) {
    ra_visible_ = ra_;
    zero_occluded(ra_visible_, visible_rows);
    ra_compared = &ra_visible_;
  }
  r.ra_loss = ra_loss_.evaluate(*ra_compared, ra_target, backward ? &grad_ra_ : nullptr);
  if (backward) {
    zero_occluded(grad_ra_, visible_rows);  // d(masked RA)/d(RA) is the mask
    grad_ra_ *= static_cast<Scalar>(ra_weight);
  }
  const bool use_rd = velocity != nullptr && rd_weight > 0;
  if (use_rd) {
    rd_renderer_.render(ra_, *velocity, rd_, directions);
    const bool rd_backward = backward || grad_velocity != nullptr;
    r.rd_loss = rd_loss_.evaluate(rd_, rd_target, rd_backward ? &grad_rd_ : nullptr);
    if (rd_backward) {
      grad_rd_ *= static_cast<Scalar>(rd_weight);
      if (!backward) grad_ra_.setZero(ra_.rows(), ra_.cols());
      rd_renderer_.backward(ra_, *velocity, grad_rd_, rd_image_gradient_ ? &grad_ra_ : nullptr, grad_velocity,
                            directions);
    }
  }
  if (backward) ra_renderer_.backward(scene, radar_T_world, gaussians, grad_ra_, scene_gradients, grad_pose);
  return r;
}

template class KeyframeObjective<float>;
template class KeyframeObjective<double>;

RadarVelocity keyframe_velocity(const Eigen::Isometry3d& radar_T_world_current,
                                const Eigen::Isometry3d& radar_T_world_previous, double dt,
                                const Eigen::Vector3d& correction) {
  RadarVelocity v = radar_velocity_from_poses(radar_T_world_current, radar_T_world_previous, dt);
  v.velocity += correction;
  return v;
}

// ------------------------------------------------------------------------------------------------
// backend

Backend::Backend(const RadarConfig& config, const rsrio::DspGrids& grids, const BackendOptions& options)
    : options_(options) {
  validate(options_);
  grid_ = RadarImageGrid::from_config(config, options_.psf_range_window, options_.psf_angle_window);
  grid_.validate();
  auto close = [](double a, double b) { return std::abs(a - b) <= 1e-9 * std::max(1.0, std::abs(b)); };
  if (grids.range_bins != grid_.range_bins || grids.azimuth_bins != grid_.azimuth_bins ||
      grids.doppler_bins != grid_.doppler_bins || !close(grids.range_bin_m, grid_.range_bin_m) ||
      !close(grids.velocity_bin_mps, grid_.velocity_bin_mps) ||
      !close(grids.azimuth_sin_bin, grid_.azimuth_sin_step()))
    throw std::invalid_argument("splat::Backend: the DSP grids are not those of the radar configuration");
  dsp_range_bins_ = grid_.range_bins;
  if (options_.max_image_range_m > 0)
    grid_.range_bins = std::clamp(static_cast<int>(std::ceil(options_.max_image_range_m / grid_.range_bin_m)), 1,
                                  grid_.range_bins);

  ra_options_.elevation_gain_sigma_sin = options_.elevation_gain_sigma_sin;
  ra_options_.range_falloff_exponent = options_.range_falloff_exponent;
  ra_options_.azimuth_gain_sigma_deg = options_.azimuth_gain_sigma_deg;
  ra_options_.view_dependent_return = options_.view_dependent_return;
  rd_options_.kernel_sigma_bins = options_.rd_kernel_sigma_bins > 0
                                      ? options_.rd_kernel_sigma_bins
                                      : window_power_fwhm_bins(options_.psf_doppler_window) / 2.355;
  rd_options_.window_bins = options_.rd_window_bins;
  rd_options_.elevation_sigma_sin = options_.rd_elevation_sigma_sin;
  for (ImageLossOptions* l : {&ra_loss_options_, &rd_loss_options_}) {
    l->l1_weight = options_.l1_weight;
    l->ssim_weight = options_.ssim_weight;
    l->ssim.window = options_.ssim_window;
    l->compression.floor = options_.compression_floor;
    l->skip_near_range_bins = options_.skip_near_range_bins;
  }
  SceneOptions so;
  so.max_gaussians = static_cast<std::size_t>(options_.max_gaussians);
  so.view_returns = options_.view_dependent_return;
  scene_ = GaussianScene(so);
  reference_ = GaussianScene(so);
  SplatAdamOptions ao;
  ao.lr_means = options_.lr_means;
  ao.lr_rotations = options_.lr_rotations;
  ao.lr_log_scales = options_.lr_log_scales;
  ao.lr_log_returns = options_.lr_log_returns;
  ao.lr_view_returns = options_.view_dependent_return ? options_.lr_view_returns : 0.0;
  scene_adam_ = SplatAdam(ao, 3);
}

Backend::~Backend() = default;

Eigen::Isometry3d OdomCorrection::apply(const Eigen::Isometry3d& odom_T_body) const {
  Eigen::Isometry3d map_T_body = map_T_odom * odom_T_body;
  if (hold_height)
    map_T_body.translation().z() -= (map_T_odom.linear() * (odom_T_body.translation() - keyframe_odom_position)).z();
  return map_T_body;
}

gtsam::Pose3 Backend::map_T_odom() const { return to_pose3(correction_.map_T_odom); }

std::size_t Backend::replace_odometry(const std::function<std::optional<gtsam::Pose3>(double t)>& odom_at) {
  std::size_t replaced = 0;
  const Eigen::Isometry3d radar_T_body = options_.body_T_radar.inverse();
  for (Keyframe& kf : keyframes_)
    if (const std::optional<gtsam::Pose3> pose = odom_at(kf.t); pose && pose->matrix().allFinite()) {
      // The yaw prior's reference (the odometry's heading plus loop_yaw) is a heading in the map
      // that the loops found against the old odometry: it stays where it was. loop_yaw kept as
      // it was would add the loops' correction of the old odometry's drift to a heading that no
      // longer has that drift.
      const double old_yaw = odometry_radar_pose(kf, options_.body_T_radar).yaw;
      kf.odom_T_body = to_isometry(*pose);
      kf.loop_yaw += std::remainder(old_yaw - odometry_radar_pose(kf, options_.body_T_radar).yaw, 2 * std::numbers::pi);
      // Roll and pitch are the frontend's (3-DoF; 6-DoF: where the end-of-run BA starts them and
      // what its prior holds them to): the new odometry's tilt on the keyframe's map pose, its
      // heading and the body's position kept. Else the corrections (correction_at) would carry the
      // old tilt of the keyframe onto every frame after it.
      const gtsam::Pose3 world_T_body = to_pose3(kf.world_T_radar * radar_T_body);
      kf.world_T_radar = to_isometry(rio::with_tilt_of(world_T_body, pose->rotation())) * options_.body_T_radar;
      ++replaced;
    }
  if (!keyframes_.empty()) update_correction();
  return replaced;
}

void Backend::finish() {
  if (options_.final_ba.max_iterations <= 0 || keyframes_.size() < 2) return;
  std::vector<std::size_t> views, poses;
  for (std::size_t k = 0; k < keyframes_.size(); ++k) {
    if (!keyframes_[k].has_images()) continue;
    views.push_back(k);
    if (k != 0) poses.push_back(k);  // the first keyframe is the gauge, as in every BA window
  }
  run_stage(views, poses, true, options_.final_ba_rd_loss, options_.final_ba, options_.final_ba.max_iterations,
            stats_.final_ba);
  cleanup_scene();
  update_correction();
  stats_.gaussians = scene_.size();
}

gtsam::Pose3 Backend::corrected(const gtsam::Pose3& odom_T_body) const {
  return to_pose3(correction_.apply(to_isometry(odom_T_body)));
}

const BackendStats& Backend::stats() const { return stats_; }

std::vector<std::pair<double, gtsam::Pose3>> Backend::keyframe_poses() const {
  std::vector<std::pair<double, gtsam::Pose3>> out;
  out.reserve(keyframes_.size());
  const Eigen::Isometry3d radar_T_body = options_.body_T_radar.inverse();
  for (const Keyframe& k : keyframes_) out.emplace_back(k.t, to_pose3(k.world_T_radar * radar_T_body));
  return out;
}

gtsam::Pose3 Backend::revised(double t, const gtsam::Pose3& odom_T_body) const {
  if (keyframes_.empty()) return odom_T_body;
  auto it = std::upper_bound(keyframes_.begin(), keyframes_.end(), t,
                             [](double time, const Keyframe& k) { return time < k.t; });
  const Keyframe& k = it == keyframes_.begin() ? *it : *std::prev(it);
  return to_pose3(correction_at(k).apply(to_isometry(odom_T_body)));
}

gtsam::Pose3 Backend::predicted(double t) const {
  if (keyframes_.empty()) return gtsam::Pose3();
  const Eigen::Isometry3d radar_T_body = options_.body_T_radar.inverse();
  const Keyframe& last = keyframes_.back();
  if (keyframes_.size() == 1) return to_pose3(last.world_T_radar * radar_T_body);
  const Keyframe& before = keyframes_[keyframes_.size() - 2];
  const PlanarPose p = extrapolate_planar(PlanarPose::from_world_T_radar(before.world_T_radar), before.t,
                                          PlanarPose::from_world_T_radar(last.world_T_radar), last.t, t);
  return to_pose3(p.world_T_radar() * radar_T_body);
}

bool Backend::accept(const BackendFrame& f) const {
  if (!std::isfinite(f.t) || (have_previous_ && !(f.t > previous_t_))) return false;
  if (f.dsp == nullptr) return false;
  const auto nr = static_cast<std::size_t>(dsp_range_bins_);
  if (f.dsp->ra.size() != nr * static_cast<std::size_t>(grid_.azimuth_bins)) return false;
  if (f.dsp->rd.size() != nr * static_cast<std::size_t>(grid_.doppler_bins)) return false;
  if (!f.odom_T_body.matrix().allFinite()) return false;
  auto all_finite = [](std::span<const float> s) {
    return std::all_of(s.begin(), s.end(), [](float v) { return std::isfinite(v); });
  };
  return all_finite(f.dsp->ra) && all_finite(f.dsp->rd);
}

bool keyframe_due(const BackendOptions& o, double dt, const Eigen::Isometry3d& last_T_frame) {
  const double angle = Eigen::AngleAxisd(last_T_frame.linear()).angle();
  return last_T_frame.translation().norm() >= o.keyframe_distance_m || angle >= o.keyframe_angle_deg * kDeg ||
         dt >= o.keyframe_time_s;
}

void take_frontend_options(BackendOptions& b, const rio::OdometryOptions& o) {
  b.psf_range_window = o.dsp.range_window;
  b.psf_doppler_window = o.dsp.doppler_window;
  b.psf_angle_window = o.dsp.angle_window;
  b.body_T_radar = Eigen::Isometry3d(o.frontend.body_T_radar.matrix());
}

bool Backend::is_keyframe(double t, const Eigen::Isometry3d& odom_T_body) const {
  if (keyframes_.empty()) return true;
  const Keyframe& last = keyframes_.back();
  return keyframe_due(options_, t - last.t, last.odom_T_body.inverse() * odom_T_body);
}

void Backend::add_predecessor(double t, const gtsam::Pose3& odom_T_body) {
  ++stats_.frames;
  const Eigen::Isometry3d pose = to_isometry(odom_T_body);
  if (!std::isfinite(t) || (have_previous_ && !(t > previous_t_)) || !pose.matrix().allFinite()) {
    ++stats_.rejected_frames;
    return;
  }
  have_previous_ = true;
  previous_t_ = t;
  previous_odom_T_body_ = pose;
}

bool Backend::add_frame(const BackendFrame& frame) {
  ++stats_.frames;
  if (!accept(frame)) {
    ++stats_.rejected_frames;
    return false;
  }
  const Eigen::Isometry3d odom_T_body = to_isometry(frame.odom_T_body);
  // The frontend's radar velocity at this frame (radar frame), from this frame and the previous.
  Eigen::Vector3d v_odom = Eigen::Vector3d::Zero();
  const Eigen::Isometry3d odom_T_radar = odom_T_body * options_.body_T_radar;
  if (have_previous_)
    v_odom = radar_velocity_from_poses(odom_T_radar.inverse(), (previous_odom_T_body_ * options_.body_T_radar).inverse(),
                                       frame.t - previous_t_)
                 .velocity;
  // A keyframe needs the frontend's velocity at its frame (RD rendering, the static-point test),
  // hence a predecessor: the very first frame only starts it.
  const bool keyframe = have_previous_ && is_keyframe(frame.t, odom_T_body);
  have_previous_ = true;
  previous_t_ = frame.t;
  previous_odom_T_body_ = odom_T_body;
  if (!keyframe) return false;

  Keyframe kf;
  kf.t = frame.t;
  kf.odom_T_body = odom_T_body;
  kf.world_T_radar = correction_.map_T_odom * odom_T_radar;
  if (keyframes_.empty()) floor_z_ = kf.world_T_radar.translation().z();
  if (options_.level_floor) kf.world_T_radar.translation().z() = floor_z_;
  kf.z_reference = kf.world_T_radar.translation().z();
  // Row-major [range][column]: the first range_bins rows are the cut grid's image.
  kf.ra = Eigen::Map<const Image<float>>(frame.dsp->ra.data(), grid_.range_bins, grid_.azimuth_bins);
  kf.rd = Eigen::Map<const Image<float>>(frame.dsp->rd.data(), grid_.range_bins, grid_.doppler_bins);
  for (const rsrio::DspPoint& p : frame.dsp->points)
    if (classify_point(p, v_odom, options_) == PointClass::static_point) kf.points.emplace_back(p.x, p.y, p.z);
  if (!keyframes_.empty()) {
    const Keyframe& prev = keyframes_.back();
    kf.loop_yaw = prev.loop_yaw;
    // heading_drift_window_s: the frontend's heading drifts on since the last revisit; turn the
    // new keyframe about the one before by what the rate says it drifted between them.
    const double dyaw = heading_drift_rate_ * (kf.t - prev.t);
    if (dyaw != 0) {
      const Eigen::Vector3d pivot = prev.world_T_radar.translation();
      const Eigen::Matrix3d R = Eigen::AngleAxisd(dyaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      kf.world_T_radar.translation() = pivot + R * (kf.world_T_radar.translation() - pivot);
      kf.world_T_radar.linear() = R * kf.world_T_radar.linear();
      kf.loop_yaw += dyaw;
    }
  }
  const bool first = keyframes_.empty();
  if (first) {
    kf.velocity_correction = v_odom;
    kf.chain_start = true;
    start_map(kf);
  } else {
    const Keyframe& prev = keyframes_.back();
    const Eigen::Vector3d v_pair =
        radar_velocity_from_poses(odom_T_radar.inverse(), (prev.odom_T_body * options_.body_T_radar).inverse(),
                                  kf.t - prev.t)
            .velocity;
    kf.velocity_correction = v_odom - v_pair;
  }
  objective_->ra_loss().prepare_measurement(kf.ra, kf.ra_target);
  objective_->rd_loss().prepare_measurement(kf.rd, kf.rd_target);
  if (options_.occlusion_threshold > 0) {
    kf.visible_rows = occlusion_rows(kf.ra, kf.ra_target, options_.occlusion_threshold, options_.occlusion_row_db,
                                     options_.skip_near_range_bins,
                                     static_cast<int>(std::ceil(options_.occlusion_margin_m / grid_.range_bin_m)));
    zero_occluded(kf.ra_target, kf.visible_rows);
    for (const int n : kf.visible_rows) {
      stats_.occluded_columns += n < grid_.range_bins ? 1 : 0;
      stats_.occluded_pixels += static_cast<std::uint64_t>(grid_.range_bins - n);
    }
  }
  keyframes_.push_back(std::move(kf));
  ++stats_.keyframes;
  const std::size_t k = keyframes_.size() - 1;

  if (first) {
    add_gaussians(k, frame.dsp->points, v_odom);
    // The first map: one view, a fixed number of iterations (no budget: everything after
    // builds on it, and one view is cheap).
    StageOptions first_mapping = options_.mapping;
    first_mapping.time_budget_s = 0;
    run_stage({k}, {}, true, false, first_mapping, options_.first_keyframe_mapping_iterations, stats_.mapping);
  } else {
    // 1. pose refinement of the newest keyframe (RA + RD), the map fixed; on what the map covers.
    // The masked targets serve this stage only: mapping and BA compare the whole images.
    if (options_.loop_closure) align_revisit(k);
    Keyframe& newest = keyframes_[k];
    const Image<float> ra_target = newest.ra_target, rd_target = newest.rd_target;
    if (options_.pose_coverage_mask) mask_uncovered_targets(k);
    run_stage({k}, {k}, false, true, options_.pose, options_.pose.max_iterations, stats_.pose);
    newest.ra_target = ra_target;
    newest.rd_target = rd_target;
    // New Gaussians from this keyframe's points, placed with the refined pose.
    add_gaussians(k, frame.dsp->points, v_odom);
    // 2. mapping over the last N_map keyframes (RA only), poses fixed.
    std::vector<std::size_t> mapping_views;
    const std::size_t n_map = static_cast<std::size_t>(options_.mapping_keyframes);
    for (std::size_t i = keyframes_.size() > n_map ? keyframes_.size() - n_map : 0; i < keyframes_.size(); ++i)
      mapping_views.push_back(i);
    run_stage(mapping_views, {}, true, false, options_.mapping, options_.mapping.max_iterations, stats_.mapping);
    // 3. BA over the window: poses (all but the window's oldest, the gauge) and Gaussians.
    const std::vector<std::size_t> window = ba_window();
    std::vector<std::size_t> ba_poses;
    for (std::size_t i = 1; i < window.size(); ++i)
      if (window[i] != 0) ba_poses.push_back(window[i]);
    run_stage(window, ba_poses, true, true, options_.ba, options_.ba.max_iterations, stats_.ba);
  }
  cleanup_scene();
  freeze_reference();
  evict_keyframe_data();
  drop_bare_keyframes();
  update_correction();
  stats_.gaussians = scene_.size();
  stats_.reference_gaussians = reference_.size();
  return true;
}

void Backend::start_map(Keyframe& first) {
  ra_loss_options_.compression.reference =
      percentile_reference({first.ra.data(), static_cast<std::size_t>(first.ra.size())}, options_.reference_percentile);
  rd_loss_options_.compression.reference =
      percentile_reference({first.rd.data(), static_cast<std::size_t>(first.rd.size())}, options_.reference_percentile);
  // RD / RA scale: the DSP's RD is the channel sum before beamforming and its RA the beamformed
  // power summed over Doppler; their ratio depends on the array and the windows. Calibrated on
  // the first keyframe: the RD that the renderer makes from the MEASURED RA at the frontend's
  // velocity against the measured RD.
  double gain = options_.rd_gain;
  if (!(gain > 0)) {
    RdRenderOptions unit = rd_options_;
    unit.gain = 1.0;
    RdRenderer<float> rd(grid_, unit);
    Image<float> rendered;
    rd.render(first.ra, first.velocity_correction, rendered);
    const double num = first.rd.template cast<double>().sum();
    const double den = rendered.template cast<double>().sum();
    gain = (num > 0 && den > 0 && std::isfinite(num / den)) ? num / den : 1.0;
  }
  rd_options_.gain = gain;
  stats_.rd_gain = gain;
  objective_ =
      std::make_unique<KeyframeObjective<float>>(grid_, ra_options_, rd_options_, ra_loss_options_, rd_loss_options_,
                                                  options_.rd_image_gradient);
}

void Backend::add_gaussians(std::size_t k, std::span<const rsrio::DspPoint> points, const Eigen::Vector3d& velocity) {
  const Keyframe& kf = keyframes_[k];
  const auto anchor = static_cast<std::int32_t>(k);
  const double spacing = options_.init_min_spacing_m;
  std::vector<Eigen::Vector3d> added;
  std::vector<std::uint32_t> near;
  scene_.update_index();
  const double log_scale = std::log(options_.init_scale_m);
  std::vector<std::pair<Eigen::Vector3d, double>> accepted;
  for (const rsrio::DspPoint& p : points) {
    const PointClass c = classify_point(p, velocity, options_);
    if (c == PointClass::dynamic) ++stats_.points_rejected_dynamic;
    if (c != PointClass::static_point) continue;
    const Eigen::Vector3d x(p.x, p.y, p.z);
    const Eigen::Vector3d w = kf.world_T_radar * x;
    if (spacing > 0) {
      scene_.query_radius(w, spacing, near);
      if (!near.empty()) continue;
      bool close = false;
      for (const auto& a : accepted) close = close || (a.first - w).norm() < spacing;
      if (close) continue;
    }
    // Initial return: the measured RA power at the point's cell (the renderer draws a point
    // scatterer with its peak equal to the return ratio).
    const int kr = std::clamp(static_cast<int>(std::lround(p.range_bin)), 0, grid_.range_bins - 1);
    const int ka = std::clamp(static_cast<int>(std::lround(p.azimuth_bin)), 0, grid_.azimuth_bins - 1);
    double rho = kf.ra(kr, ka);
    if (!(rho > 0)) rho = p.power;
    // ... divided by what the renderer multiplies a point's return with here: the elevation and
    // azimuth gains (each at most 10 x: far off the beam a point's direction is too uncertain,
    // and its return too close to the noise, to trust with more) and the range falloff
    // (RaRenderOptions).
    const PointGains gains = point_gains(ra_options_, x);
    rho /= std::max(0.1, gains.elevation) * std::max(0.1, gains.azimuth) * gains.falloff;
    if (!(rho > 0) || !std::isfinite(rho)) continue;
    accepted.emplace_back(w, rho);
  }
  for (const auto& [w, rho] : accepted) {
    if (scene_.add(w, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(log_scale), std::log(rho))) {
      ++stats_.gaussians_added;
      anchors_.push_back(anchor);
    }
  }
  if (scene_.size() > static_cast<std::size_t>(options_.max_gaussians))
    remap_scene(scene_.enforce_cap(kf.world_T_radar.translation()));
}

std::vector<std::size_t> radius_window(std::span<const Eigen::Vector3d> positions, double radius_m, std::size_t cap) {
  std::vector<std::size_t> w;
  if (positions.empty() || cap == 0) return w;
  const Eigen::Vector3d c = positions.back();
  auto distance2 = [&](std::size_t i) { return (positions[i] - c).squaredNorm(); };
  for (std::size_t i = 0; i < positions.size(); ++i)
    if (distance2(i) <= radius_m * radius_m) w.push_back(i);
  if (w.size() <= cap) return w;
  // More keyframes within the radius than the bound: the newest half, and the rest nearest to
  // the newest keyframe among the older ones. On a revisit those are the keyframes of the earlier
  // pass, whose images tie the new poses to the map they built (the loop closure); keeping only
  // the newest ones would let the map follow the frontend's drift.
  const std::size_t newest = (cap + 1) / 2;
  std::vector<std::size_t> older(w.begin(), w.end() - static_cast<std::ptrdiff_t>(newest));
  std::stable_sort(older.begin(), older.end(), [&](std::size_t a, std::size_t b) { return distance2(a) < distance2(b); });
  older.resize(cap - newest);
  std::vector<std::size_t> out(w.end() - static_cast<std::ptrdiff_t>(newest), w.end());
  out.insert(out.end(), older.begin(), older.end());
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::size_t> Backend::ba_window() const {
  const auto cap = static_cast<std::size_t>(options_.ba_max_keyframes);
  if (options_.ba_window == "sliding") {
    const std::size_t count = std::min(cap, static_cast<std::size_t>(options_.ba_sliding_keyframes));
    std::vector<std::size_t> w;
    for (std::size_t i = keyframes_.size() > count ? keyframes_.size() - count : 0; i < keyframes_.size(); ++i)
      w.push_back(i);
    return w;
  }
  // Keyframes without images (evicted) take no part.
  std::vector<std::size_t> index;
  std::vector<Eigen::Vector3d> positions;
  for (std::size_t i = 0; i < keyframes_.size(); ++i)
    if (keyframes_[i].has_images()) {
      index.push_back(i);
      positions.push_back(keyframes_[i].world_T_radar.translation());
    }
  std::vector<std::size_t> w = radius_window(positions, options_.ba_radius_m, cap);
  for (std::size_t& i : w) i = index[i];
  return w;
}

Eigen::Vector3d Backend::velocity_of(std::size_t k, RadarVelocity* jacobians) const {
  const Keyframe& kf = keyframes_[k];
  if (k == 0 || kf.chain_start) {
    if (jacobians != nullptr) *jacobians = RadarVelocity{kf.velocity_correction, Matrix36d::Zero(), Matrix36d::Zero()};
    return kf.velocity_correction;
  }
  const Keyframe& prev = keyframes_[k - 1];
  const RadarVelocity v = keyframe_velocity(kf.world_T_radar.inverse(), prev.world_T_radar.inverse(), kf.t - prev.t,
                                            kf.velocity_correction);
  if (jacobians != nullptr) *jacobians = v;
  return v.velocity;
}

void Backend::run_stage(const std::vector<std::size_t>& views, const std::vector<std::size_t>& poses, bool optimise_scene,
                        bool use_rd, const StageOptions& stage, int max_iterations, StageStats& st,
                        const std::vector<char>* drawable, bool priors, std::optional<double> lr_pose_translation) {
  const auto start = std::chrono::steady_clock::now();
  ++st.runs;
  use_rd = use_rd && options_.rd_loss && options_.rd_weight > 0;
  if (views.empty() || max_iterations <= 0 || (!optimise_scene && poses.empty()) || scene_.empty()) return;
  const std::size_t stride = static_cast<std::size_t>(options_.pose_dof);
  const bool planar = stride == 3;

  std::vector<int> pose_row(keyframes_.size(), -1);
  for (std::size_t r = 0; r < poses.size(); ++r) pose_row[poses[r]] = static_cast<int>(r);
  SplatAdamOptions pose_adam_options;
  pose_adam_options.lr_pose_translation = lr_pose_translation.value_or(options_.lr_pose_translation);
  pose_adam_options.lr_pose_rotation = options_.lr_pose_rotation;
  SplatAdam pose_adam(pose_adam_options, stride);
  std::vector<double> params(stride * poses.size(), 0.0), grads(params.size(), 0.0);
  std::vector<Vector6d> grad_left(poses.size());
  auto load_params = [&] {
    if (!planar) return;
    for (std::size_t r = 0; r < poses.size(); ++r) {
      const PlanarPose p = PlanarPose::from_world_T_radar(keyframes_[poses[r]].world_T_radar);
      params[3 * r] = p.x;
      params[3 * r + 1] = p.y;
      params[3 * r + 2] = p.yaw;
    }
  };
  load_params();

  // The Gaussians each view draws: those within the render range of its radar, listed once per
  // stage (the means move by centimetres within a stage).
  const double radius =
      options_.max_render_range_m > 0 ? options_.max_render_range_m : grid_.range_bins * grid_.range_bin_m;
  scene_.update_index();
  std::vector<std::vector<std::uint32_t>> lists(views.size());
  std::vector<std::uint32_t> rows;
  for (std::size_t i = 0; i < views.size(); ++i) {
    scene_.query_radius(keyframes_[views[i]].world_T_radar.translation(), radius, lists[i]);
    if (drawable != nullptr)
      std::erase_if(lists[i], [&](std::uint32_t g) { return g >= drawable->size() || !(*drawable)[g]; });
    rows.insert(rows.end(), lists[i].begin(), lists[i].end());
  }
  std::sort(rows.begin(), rows.end());
  rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
  if (rows.empty()) return;

  // The RD pixels' directions, per view, from the map at the stage's start.
  const bool directions = use_rd && options_.rd_gaussian_directions;
  if (directions) {
    if (directions_.size() < views.size()) directions_.resize(views.size());
    for (std::size_t i = 0; i < views.size(); ++i)
      objective_->ra_renderer().render_directions(scene_, keyframes_[views[i]].world_T_radar.inverse(), lists[i],
                                                  directions_[i]);
  }

  // Sized for the scene once a stage (its structure changes between stages); each iteration
  // zeroes the rows it uses.
  if (optimise_scene && gradients_.size() != scene_.size()) gradients_.reset(scene_.size(), scene_.has_view_returns());

  ScaleRegulariserOptions reg;
  reg.max_scale_m = options_.scale_regulariser_max_m;
  reg.weight = options_.scale_regulariser_weight;
  const SplatAdamOptions& sa = scene_adam_.options();

  double previous_loss = std::numeric_limits<double>::quiet_NaN();
  int calm = 0;
  bool first_loss = true;
  for (int it = 0; it < max_iterations; ++it) {
    if (cancel_ != nullptr && cancel_->load(std::memory_order_relaxed)) break;
    if (stage.time_budget_s > 0 && seconds_since(start) > stage.time_budget_s) {
      ++st.budget_stops;
      break;
    }
    ++st.iterations;
    const double decay = std::pow(stage.lr_final_factor, static_cast<double>(it) / std::max(1, max_iterations - 1));
    pose_adam.poses.set_learning_rate(decay);
    if (optimise_scene) {
      scene_adam_.means.set_learning_rate(sa.lr_means * decay);
      scene_adam_.rotations.set_learning_rate(sa.lr_rotations * decay);
      scene_adam_.log_scales.set_learning_rate(sa.lr_log_scales * decay);
      scene_adam_.log_returns.set_learning_rate(sa.lr_log_returns * decay);
      scene_adam_.view_returns.set_learning_rate(sa.lr_view_returns * decay);
      gradients_.zero_rows(rows);  // what the views draw and the regulariser sees: all that is read
    }
    for (Vector6d& g : grad_left) g.setZero();
    double loss = 0;
    for (std::size_t i = 0; i < views.size(); ++i) {
      const std::size_t k = views[i];
      Keyframe& kf = keyframes_[k];
      RadarVelocity vj;
      Eigen::Vector3d v = Eigen::Vector3d::Zero();
      if (use_rd) v = velocity_of(k, &vj);
      Vector6d g_pose = Vector6d::Zero();
      Eigen::Vector3d g_v = Eigen::Vector3d::Zero();
      const auto r = objective_->evaluate(scene_, lists[i], kf.world_T_radar.inverse(), use_rd ? &v : nullptr,
                                          kf.ra_target, kf.rd_target, options_.ra_weight,
                                          use_rd ? options_.rd_weight : 0.0, optimise_scene ? &gradients_ : nullptr,
                                          pose_row[k] >= 0 ? &g_pose : nullptr, use_rd ? &g_v : nullptr,
                                          directions ? &directions_[i] : nullptr, kf.visible_rows);
      loss += options_.ra_weight * r.ra_loss + (use_rd ? options_.rd_weight * r.rd_loss : 0.0);
      if (pose_row[k] >= 0) grad_left[static_cast<std::size_t>(pose_row[k])] += g_pose + vj.d_current.transpose() * g_v;
      if (use_rd && k > 0 && pose_row[k - 1] >= 0)
        grad_left[static_cast<std::size_t>(pose_row[k - 1])] += vj.d_previous.transpose() * g_v;
    }
    if (optimise_scene) {
      loss += scale_regulariser(scene_, rows, reg, &gradients_);
      if (options_.view_dependent_return)
        loss += view_return_regulariser(scene_, rows, options_.view_return_regulariser_weight, &gradients_);
    }
    if (options_.odometry_prior && priors) loss += odometry_prior(poses, pose_row, grad_left);
    if (!planar)
      for (std::size_t r = 0; r < poses.size(); ++r) {
        const Keyframe& kf = keyframes_[poses[r]];
        const Eigen::Vector3d up = (kf.odom_T_body * options_.body_T_radar).linear().row(2).transpose();
        loss += vertical_prior(kf.world_T_radar.inverse(), up, kf.z_reference, options_.tilt_prior_sigma_deg * kDeg,
                               options_.height_prior_sigma_m, &grad_left[r]);
      }
    for (std::size_t r = 0; r < poses.size(); ++r) {
      if (planar) {
        const Eigen::Vector3d g =
            planar_gradient(PlanarPose::from_world_T_radar(keyframes_[poses[r]].world_T_radar), grad_left[r]);
        for (int c = 0; c < 3; ++c) grads[3 * r + c] = g[c];
      } else {
        for (int c = 0; c < 6; ++c) grads[6 * r + c] = grad_left[r][c];
      }
    }
    const bool ok = std::isfinite(loss) &&
                    std::all_of(grads.begin(), grads.end(), [](double g) { return std::isfinite(g); }) &&
                    (!optimise_scene || gradients_.all_finite(rows));
    if (!ok) {
      ++stats_.nan_guard_hits;
      continue;
    }
    if (first_loss) {
      st.last_initial_loss = loss;
      first_loss = false;
    }
    st.last_final_loss = loss;
    if (!poses.empty()) {
      SplatAdam::Step s;
      s.poses = params;
      s.pose_gradients = grads;
      pose_adam.step(s);
      for (std::size_t r = 0; r < poses.size(); ++r) {
        Keyframe& kf = keyframes_[poses[r]];
        Eigen::Isometry3d updated;
        if (planar) {
          PlanarPose p = PlanarPose::from_world_T_radar(kf.world_T_radar);
          p.x = params[3 * r];
          p.y = params[3 * r + 1];
          p.yaw = params[3 * r + 2];
          updated = p.world_T_radar();
        } else {
          Eigen::Isometry3d radar_T_world = kf.world_T_radar.inverse();
          apply_left_increment(radar_T_world, Eigen::Map<const Vector6d>(params.data() + 6 * r));
          updated = radar_T_world.inverse();
          std::fill(params.begin() + static_cast<std::ptrdiff_t>(6 * r),
                    params.begin() + static_cast<std::ptrdiff_t>(6 * r + 6), 0.0);
        }
        if (finite(updated)) {
          kf.world_T_radar = updated;
        } else {
          ++stats_.nan_guard_hits;
          load_params();
        }
      }
    }
    if (optimise_scene) {
      SplatAdam::Step s;
      s.scene = &scene_;
      s.scene_gradients = &gradients_;
      s.gaussians = rows;
      if (!scene_adam_.step(s)) ++stats_.nan_guard_hits;
    }
    // Convergence: the loss moved by less than convergence_rel for `patience` iterations.
    if (std::isfinite(previous_loss) && std::abs(loss - previous_loss) <= stage.convergence_rel * std::abs(previous_loss)) {
      if (++calm >= stage.convergence_patience) {
        ++st.converged;
        break;
      }
    } else {
      calm = 0;
    }
    previous_loss = loss;
  }
  if (optimise_scene) {
    const std::uint64_t before = scene_.removed_non_finite();
    remap_scene(scene_.sanitize());
    stats_.nan_guard_hits += scene_.removed_non_finite() - before;
  }
  const double elapsed = seconds_since(start);
  st.last_s = elapsed;
  st.total_s += elapsed;
  st.max_s = std::max(st.max_s, elapsed);
}

double Backend::odometry_prior(const std::vector<std::size_t>& poses, const std::vector<int>& pose_row,
                               std::vector<Vector6d>& grad_left) const {
  const double sigma_r = options_.odometry_prior_sigma_deg * kDeg;
  auto planar = [](const Eigen::Isometry3d& world_T_radar) { return PlanarPose::from_world_T_radar(world_T_radar); };
  auto odom_radar = [&](const Keyframe& kf) { return odometry_radar_pose(kf, options_.body_T_radar); };
  double loss = 0;
  // Each pair (k-1, k) once: from k when k is optimised, from k-1 when only k-1 is.
  auto pair = [&](std::size_t a, std::size_t b) {
    const PlanarPose pa = planar(keyframes_[a].world_T_radar), pb = planar(keyframes_[b].world_T_radar);
    Eigen::Vector3d ga = Eigen::Vector3d::Zero(), gb = Eigen::Vector3d::Zero();
    // The turn is the frontend's alone, not with what the loops and the drift rate added between
    // the two (loop_yaw, which the yaw prior's reference takes): with it, Table II's end of run
    // was 0.012 deg better on the mean, the third draw of the noise 0.003 m / 0.010 deg worse and
    // the tuned file's level (splat/RESULTS.md, 2026-12-07, night): not a change that shows.
    loss += planar_relative_prior(pa, pb, odom_radar(keyframes_[a]), odom_radar(keyframes_[b]),
                                  options_.odometry_prior_sigma_m, sigma_r, &ga, &gb,
                                  options_.odometry_prior_across_sigma_m);
    // The stages sum left-increment gradients; left_increment_jacobian's columns are orthonormal,
    // so planar_gradient(J g) = g: the planar gradient passes through unchanged (3-DoF), and 6-DoF
    // poses see the same prior on their x, y, yaw.
    if (pose_row[a] >= 0) grad_left[static_cast<std::size_t>(pose_row[a])] += left_increment_jacobian(pa) * ga;
    if (pose_row[b] >= 0) grad_left[static_cast<std::size_t>(pose_row[b])] += left_increment_jacobian(pb) * gb;
  };
  for (const std::size_t k : poses) {
    if (k > 0 && !keyframes_[k].chain_start) pair(k - 1, k);
    if (k + 1 < keyframes_.size() && pose_row[k + 1] < 0 && !keyframes_[k + 1].chain_start) pair(k, k + 1);
    if (options_.odometry_yaw_sigma_deg > 0) {
      const PlanarPose p = planar(keyframes_[k].world_T_radar);
      Eigen::Vector3d g = Eigen::Vector3d::Zero();
      loss += planar_yaw_prior(p, odom_radar(keyframes_[k]).yaw + keyframes_[k].loop_yaw,
                               options_.odometry_yaw_sigma_deg * kDeg, &g);
      grad_left[static_cast<std::size_t>(pose_row[k])] += left_increment_jacobian(p) * g;
    }
  }
  return loss;
}

void Backend::cleanup_scene() {
  const std::uint64_t before = scene_.removed_non_finite();
  remap_scene(scene_.sanitize());
  stats_.nan_guard_hits += scene_.removed_non_finite() - before;
  remap_scene(scene_.prune());
}

void Backend::evict_keyframe_data() {
  // Farthest from the newest keyframe first; the newest that the windows use never (their
  // images: mapping and BA; their points: the revisit alignment's query). Images go first
  // (max_keyframe_images), the static points later (max_keyframe_points >= it): the revisit
  // alignment needs only the earlier keyframes' points and Gaussians, and the points are a few
  // hundred bytes where the images are ~160 kB.
  const int windows = std::max(options_.mapping_keyframes, options_.ba_max_keyframes);
  const Eigen::Vector3d c = keyframes_.back().world_T_radar.translation();
  auto evict = [&](int cap, int newest_kept, auto holds, auto drop) {
    const auto protected_newest = static_cast<std::size_t>(newest_kept);
    std::size_t holding = 0;
    for (const Keyframe& kf : keyframes_) holding += holds(kf) ? 1 : 0;
    while (holding > static_cast<std::size_t>(cap) && keyframes_.size() > protected_newest) {
      std::size_t farthest = keyframes_.size();
      double best = -1;
      for (std::size_t i = 0; i + protected_newest < keyframes_.size(); ++i) {
        if (!holds(keyframes_[i])) continue;
        const double d = (keyframes_[i].world_T_radar.translation() - c).squaredNorm();
        if (d > best) {
          best = d;
          farthest = i;
        }
      }
      if (farthest == keyframes_.size()) break;
      drop(keyframes_[farthest]);
      --holding;
    }
  };
  evict(
      options_.max_keyframe_images, windows, [](const Keyframe& kf) { return kf.has_images(); },
      [&](Keyframe& kf) {
        for (Image<float>* image : {&kf.ra, &kf.rd, &kf.ra_target, &kf.rd_target}) image->resize(0, 0);
        kf.visible_rows.clear();
        ++stats_.keyframe_images_evicted;
      });
  evict(
      options_.max_keyframe_points, std::max(windows, options_.loop_closure ? options_.loop_query_keyframes : 0),
      [](const Keyframe& kf) { return !kf.points.empty(); },
      [&](Keyframe& kf) {
        // Move-assigned, not `= {}` (assign from an empty list: the capacity stays, a few kB a
        // keyframe for ever).
        kf.points = std::vector<Eigen::Vector3f>();
        ++stats_.keyframe_points_evicted;
      });
}

void Backend::drop_bare_keyframes() {
  const auto cap = static_cast<std::size_t>(options_.max_keyframes);
  if (keyframes_.size() <= cap) return;
  // A tenth of the cap at a time, so that the anchors (one per Gaussian) are renumbered once per
  // batch, not once per keyframe. Bare: no images, no points; the newest are never bare (the
  // eviction keeps the windows' and the revisit query's), and validate() keeps max_keyframes
  // above max_keyframe_points, so there are always bare keyframes to drop.
  const std::size_t excess = keyframes_.size() - cap + cap / 10;
  std::vector<std::int64_t> new_index(keyframes_.size(), -1);
  std::size_t dropped = 0, kept = 0;
  bool previous_dropped = false;
  for (std::size_t i = 0; i < keyframes_.size(); ++i) {
    Keyframe& kf = keyframes_[i];
    if (dropped < excess && i + 1 < keyframes_.size() && !kf.has_images() && kf.points.empty()) {
      ++dropped;
      previous_dropped = true;
      continue;
    }
    if (previous_dropped && !kf.chain_start) {
      kf.velocity_correction = velocity_of(i, nullptr);  // before its predecessor goes
      kf.chain_start = true;
    }
    previous_dropped = false;
    new_index[i] = static_cast<std::int64_t>(kept++);
  }
  if (dropped == 0) return;
  std::size_t out = 0;
  for (std::size_t i = 0; i < keyframes_.size(); ++i)
    if (new_index[i] >= 0) {
      if (out != i) keyframes_[out] = std::move(keyframes_[i]);
      ++out;
    }
  keyframes_.resize(out);  // no reallocation: the capacity stays, bounded by the cap
  for (std::vector<std::int32_t>* anchors : {&anchors_, &reference_anchors_})
    for (std::int32_t& a : *anchors)
      if (a >= 0) a = static_cast<std::int32_t>(new_index[static_cast<std::size_t>(a)]);
  std::erase_if(loops_, [&](const LoopConstraint& l) { return new_index[l.from] < 0 || new_index[l.to] < 0; });
  for (LoopConstraint& l : loops_) {
    l.from = static_cast<std::size_t>(new_index[l.from]);
    l.to = static_cast<std::size_t>(new_index[l.to]);
  }
  last_loop_attempt_ =
      new_index[last_loop_attempt_] >= 0 ? static_cast<std::size_t>(new_index[last_loop_attempt_]) : 0;
  stats_.keyframes_dropped += dropped;
}

void mask_uncovered(const Image<float>& ra_rendered_c, const Image<float>& rd_rendered_c, double knee, int margin,
                    Image<float>& ra_target, Image<float>& rd_target) {
  if (ra_rendered_c.rows() != ra_target.rows() || ra_rendered_c.cols() != ra_target.cols() ||
      rd_rendered_c.rows() != rd_target.rows() || rd_rendered_c.cols() != rd_target.cols() ||
      ra_target.rows() != rd_target.rows())
    throw std::invalid_argument("mask_uncovered: image sizes differ");
  const Eigen::Index rows = ra_target.rows(), cols = ra_target.cols(), m = std::max(0, margin);
  // Covered: within m bins (range and azimuth) of a rendered pixel above the knee. Separable
  // dilation: along azimuth, then along range.
  using Mask = Eigen::Array<bool, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const Mask above = ra_rendered_c.array() > static_cast<float>(knee);
  Mask along(rows, cols), covered(rows, cols);
  // [i - m, i + m] cut to [0, n): its start and length.
  auto first = [&](Eigen::Index i) { return std::max<Eigen::Index>(0, i - m); };
  auto length = [&](Eigen::Index i, Eigen::Index n) { return std::min(n, i + m + 1) - first(i); };
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index a = 0; a < cols; ++a) along(r, a) = above.row(r).segment(first(a), length(a, cols)).any();
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index a = 0; a < cols; ++a) covered(r, a) = along.col(a).segment(first(r), length(r, rows)).any();
  for (Eigen::Index r = 0; r < rows; ++r) {
    for (Eigen::Index a = 0; a < cols; ++a)
      if (!covered(r, a)) ra_target(r, a) = ra_rendered_c(r, a);
    // RD sums over azimuth: a range row the map does not reach at all takes the rendered RD.
    if (!covered.row(r).any()) rd_target.row(r) = rd_rendered_c.row(r);
  }
}

std::vector<int> occlusion_rows(const Image<float>& ra_linear, const Image<float>& ra_compressed, double threshold,
                                double row_db, int first_row, int margin_rows) {
  if (ra_linear.rows() != ra_compressed.rows() || ra_linear.cols() != ra_compressed.cols())
    throw std::invalid_argument("occlusion_rows: image sizes differ");
  const auto rows = static_cast<int>(ra_linear.rows()), cols = static_cast<int>(ra_linear.cols());
  std::vector<int> visible(static_cast<std::size_t>(cols), rows);
  const float ratio = static_cast<float>(std::pow(10.0, -row_db / 10.0));
  std::vector<bool> found(static_cast<std::size_t>(cols), false);
  for (int r = std::max(0, first_row); r < rows; ++r) {
    const float strongest = ra_linear.row(r).maxCoeff();
    for (int a = 0; a < cols; ++a) {
      const auto c = static_cast<std::size_t>(a);
      if (found[c] || !(ra_compressed(r, a) >= threshold) || !(ra_linear(r, a) >= ratio * strongest)) continue;
      found[c] = true;
      visible[c] = std::min(rows, r + 1 + std::max(0, margin_rows));
    }
  }
  return visible;
}

template <typename Scalar>
void zero_occluded(Image<Scalar>& image, std::span<const int> visible_rows) {
  const auto cols = std::min<Eigen::Index>(image.cols(), static_cast<Eigen::Index>(visible_rows.size()));
  for (Eigen::Index a = 0; a < cols; ++a)
    for (Eigen::Index r = std::max(0, visible_rows[static_cast<std::size_t>(a)]); r < image.rows(); ++r)
      image(r, a) = 0;
}
template void zero_occluded(Image<float>&, std::span<const int>);
template void zero_occluded(Image<double>&, std::span<const int>);

void Backend::mask_uncovered_targets(std::size_t k, const std::vector<char>* drawable) {
  // With occlusion_threshold the rendered RA is 0 beyond the occluders, so a range row occluded in
  // every column counts as uncovered and its RD target becomes the rendered RD: pose refinement's
  // RD loss then leaves such a row out, as its RA loss does.
  const KeyframeRender render = render_keyframe(k, drawable);
  Image<float> ra_c, rd_c;
  objective_->ra_loss().prepare_measurement(render.ra_rendered, ra_c);
  objective_->rd_loss().prepare_measurement(render.rd_rendered, rd_c);
  // The knee of the compression: rendered power above floor x reference, compressed as the images.
  const CompressionOptions& c = ra_loss_options_.compression;
  Image<float> knee;
  compress(Image<float>::Constant(1, 1, static_cast<float>(c.floor * c.reference)).eval(), c, knee);
  Keyframe& kf = keyframes_[k];
  mask_uncovered(ra_c, rd_c, knee(0, 0), options_.coverage_margin_bins, kf.ra_target, kf.rd_target);
}

namespace {
// Per Gaussian, its keyframe, after a structural change of its scene.
void remap_anchors(const SceneRemap& remap, std::vector<std::int32_t>& anchors) {
  std::vector<std::int32_t> out(remap.size(), -1);
  for (std::size_t i = 0; i < remap.size(); ++i)
    if (remap[i] >= 0 && static_cast<std::size_t>(remap[i]) < anchors.size())
      out[i] = anchors[static_cast<std::size_t>(remap[i])];
  anchors = std::move(out);
}
}  // namespace

void Backend::remap_scene(const SceneRemap& remap) {
  scene_adam_.remap_scene(remap);
  remap_anchors(remap, anchors_);
}

void Backend::freeze_reference() {
  // (validate() refuses the copy without the image alignment that draws it.)
  if (!options_.loop_closure || !options_.loop_frozen_reference) return;
  const Keyframe& newest = keyframes_.back();
  const double d2 = options_.loop_freeze_distance_m * options_.loop_freeze_distance_m;
  std::vector<char> freeze(keyframes_.size(), 0);
  bool any = false;
  for (std::size_t i = 0; i < keyframes_.size(); ++i) {
    Keyframe& kf = keyframes_[i];
    if (kf.reference_frozen || newest.t - kf.t < options_.loop_min_age_s ||
        (kf.world_T_radar.translation() - newest.world_T_radar.translation()).head<2>().squaredNorm() < d2)
      continue;
    kf.reference_frozen = true;
    freeze[i] = 1;
    any = true;
  }
  if (!any) return;
  for (std::size_t g = 0; g < scene_.size() && g < anchors_.size(); ++g) {
    const std::int32_t a = anchors_[g];
    if (a < 0 || !freeze[static_cast<std::size_t>(a)]) continue;
    reference_.copy_from(scene_, g);
    reference_anchors_.push_back(a);
  }
  if (reference_.size() > static_cast<std::size_t>(options_.max_gaussians))
    remap_anchors(reference_.enforce_cap(newest.world_T_radar.translation()), reference_anchors_);
}

Eigen::Isometry3d Backend::align_to_earlier_pass(std::size_t k, const Eigen::Isometry3d& start, std::size_t nearest) {
  // Pose-refinement iterations of keyframe k's RA image against the earlier pass's Gaussians
  // alone, started at `start` (no RD: its velocity would see the jump from the previous keyframe;
  // no odometry priors: they hold the pose to the drifted chain); the keyframe is left as it was.
  Keyframe& newest = keyframes_[k];
  const Eigen::Isometry3d drifted = newest.world_T_radar;
  const bool frozen = options_.loop_frozen_reference && keyframes_[nearest].reference_frozen;
  std::vector<char> earlier;
  if (!frozen) {
    earlier.assign(scene_.size(), 0);
    for (std::size_t g = 0; g < scene_.size() && g < anchors_.size(); ++g)
      earlier[g] =
          anchors_[g] >= 0 && newest.t - keyframes_[static_cast<std::size_t>(anchors_[g])].t >= options_.loop_min_age_s;
  }
  const std::vector<char>* drawable = frozen ? nullptr : &earlier;
  stats_.loop_frozen_alignments += frozen ? 1 : 0;
  newest.world_T_radar = start;
  const Image<float> ra_target = newest.ra_target, rd_target = newest.rd_target;
  {
    // loop_frozen_reference: the stage renders the frozen copy in the live map's place (a
    // pose-only stage reads the scene and changes nothing in it); swapped back however it ends.
    struct Swap {
      GaussianScene &a, &b;
      bool on;
      Swap(GaussianScene& x, GaussianScene& y, bool swap) : a(x), b(y), on(swap) {
        if (on) std::swap(a, b);
      }
      ~Swap() {
        if (on) std::swap(a, b);
      }
      Swap(const Swap&) = delete;
      Swap& operator=(const Swap&) = delete;
    } use_reference(scene_, reference_, frozen);
    if (options_.pose_coverage_mask) mask_uncovered_targets(k, drawable);
    run_stage({k}, {k}, false, false, options_.pose, options_.pose.max_iterations, stats_.loop_alignment, drawable,
              false, options_.loop_lr_pose_translation);
  }
  const Eigen::Isometry3d aligned = newest.world_T_radar;
  newest.world_T_radar = drifted;
  newest.ra_target = ra_target;
  newest.rd_target = rd_target;
  return aligned;
}

void Backend::align_revisit(std::size_t k) {
  if (last_loop_attempt_ > 0 && k < last_loop_attempt_ + static_cast<std::size_t>(options_.loop_every_keyframes)) return;
  Keyframe& newest = keyframes_[k];
  auto xy = [](const Eigen::Isometry3d& T) { return Eigen::Vector2d(T.translation().x(), T.translation().y()); };
  // The earlier pass: keyframes older than loop_min_age_s within loop_radius_m, nearest first.
  std::vector<std::pair<double, std::size_t>> old;
  for (std::size_t i = 0; i < k; ++i) {
    const Keyframe& kf = keyframes_[i];
    if (newest.t - kf.t < options_.loop_min_age_s || kf.points.empty()) continue;
    const double d = (xy(kf.world_T_radar) - xy(newest.world_T_radar)).norm();
    if (d <= options_.loop_radius_m) old.emplace_back(d, i);
  }
  if (old.empty()) return;
  std::sort(old.begin(), old.end());
  if (old.size() > static_cast<std::size_t>(options_.loop_reference_keyframes))
    old.resize(static_cast<std::size_t>(options_.loop_reference_keyframes));
  last_loop_attempt_ = k;
  ++stats_.loop_attempts;
  auto world_points = [&](std::size_t i, std::vector<Eigen::Vector2d>& out) {
    for (const Eigen::Vector3f& p : keyframes_[i].points) {
      const Eigen::Vector3d w = keyframes_[i].world_T_radar * p.cast<double>();
      out.emplace_back(w.x(), w.y());
    }
  };
  std::vector<Eigen::Vector2d> reference, query;
  for (const auto& [d, i] : old) world_points(i, reference);
  const std::size_t q = static_cast<std::size_t>(options_.loop_query_keyframes);
  for (std::size_t i = k + 1 > q ? k + 1 - q : 0; i <= k; ++i)
    if (newest.t - keyframes_[i].t < options_.loop_min_age_s) world_points(i, query);
  PlanarMatch m = match_planar(reference, query, options_.loop);
  // The window's best on its edge, or nothing in it that explains the points: the revisit may
  // lie beyond it. (A best on the edge is not refined outwards, one a step inside it at most
  // half a step: the quarter step tells them apart.)
  const auto on_edge = [&](const PlanarMatch& c) {
    const PlanarMatchOptions& w = options_.loop;
    return std::abs(c.correction.dyaw) / kDeg > w.search_deg - 0.25 * w.step_deg ||
           std::abs(c.correction.dx) > w.search_m - 0.25 * w.cell_m ||
           std::abs(c.correction.dy) > w.search_m - 0.25 * w.cell_m;
  };
  if ((!m.valid || m.score < options_.loop_min_score || on_edge(m)) &&
      (options_.loop_retry_search_m > 0 || options_.loop_retry_search_deg > 0)) {
    PlanarMatchOptions wider = options_.loop;
    wider.search_m = std::max(wider.search_m, options_.loop_retry_search_m);
    wider.search_deg = std::max(wider.search_deg, options_.loop_retry_search_deg);
    ++stats_.loop_retries;
    m = match_planar(reference, query, wider);
  }
  if (!m.valid || m.score < options_.loop_min_score) {
    ++stats_.loop_rejected_score;
    return;
  }
  if (m.spread_m > options_.loop_max_spread_m || m.spread_deg > options_.loop_max_spread_deg) {
    ++stats_.loop_rejected_ambiguous;
    return;
  }
  // Already aligned: the correction is small or explains hardly more than none.
  const Eigen::Isometry3d C = m.correction.isometry();
  const Eigen::Vector3d shift = C * newest.world_T_radar.translation() - newest.world_T_radar.translation();
  if (m.score < (1 + options_.loop_min_gain) * m.score_at_zero ||
      (shift.head<2>().norm() < options_.loop_min_correction_m &&
       std::abs(m.correction.dyaw) < options_.loop_min_correction_deg * kDeg)) {
    ++stats_.loop_below_threshold;
    return;
  }
  // The constraint takes the match's pose (good to a few tenths of a degree: its field is 15 cm
  // wide and the two passes see the walls from different places), or with loop_image_alignment
  // the newest keyframe's pose from its RA image aligned against the earlier pass's Gaussians
  // (align_to_earlier_pass), which holds the heading no better (splat/RESULTS.md).
  const Eigen::Isometry3d start = C * newest.world_T_radar;
  const Eigen::Isometry3d aligned =
      options_.loop_image_alignment ? align_to_earlier_pass(k, start, old.front().second) : start;
  const Eigen::Isometry3d refinement = start.inverse() * aligned;
  if (refinement.translation().head<2>().norm() > options_.loop_max_refinement_m ||
      std::abs(Eigen::AngleAxisd(refinement.linear()).angle()) > options_.loop_max_refinement_deg * kDeg) {
    ++stats_.loop_rejected_refinement;
    return;
  }
  // The constraint: the newest keyframe, aligned, in the frame of the nearest earlier keyframe.
  auto planar3 = [](const Eigen::Isometry3d& T) {
    const PlanarPose p = PlanarPose::from_world_T_radar(T);
    return Eigen::Vector3d(p.x, p.y, p.yaw);
  };
  const std::size_t j = old.front().second;
  loops_.push_back({j, k, planar_between(planar3(keyframes_[j].world_T_radar), planar3(aligned))});
  std::vector<Eigen::Vector3d> before(keyframes_.size());
  for (std::size_t i = 0; i < keyframes_.size(); ++i) before[i] = planar3(keyframes_[i].world_T_radar);
  std::vector<Eigen::Vector3d> after;
  try {
    after = close_loops(before, loops_, options_.loop_graph);
  } catch (const std::exception&) {
    // GTSAM refused the graph (an indeterminate system): the loop is dropped, nothing moves.
    loops_.pop_back();
    ++stats_.loop_rejected_refinement;
    return;
  }
  // Each keyframe moves by D_i = after_i before_i^-1 (about the vertical: heights, roll and
  // pitch kept), and its Gaussians with it.
  std::vector<Eigen::Isometry3d> moves(keyframes_.size(), Eigen::Isometry3d::Identity());
  for (std::size_t i = 0; i < keyframes_.size(); ++i) {
    const double dyaw = after[i].z() - before[i].z();
    if (before[i] == after[i]) continue;
    Eigen::Isometry3d D = Eigen::Isometry3d::Identity();
    D.linear() = Eigen::AngleAxisd(dyaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector2d t = after[i].head<2>() - D.linear().topLeftCorner<2, 2>() * before[i].head<2>();
    D.translation() = Eigen::Vector3d(t.x(), t.y(), 0.0);
    moves[i] = D;
    keyframes_[i].world_T_radar = D * keyframes_[i].world_T_radar;
    keyframes_[i].loop_yaw += dyaw;
  }
  // The frozen copy too: it is the earlier pass's map in the corrected frame.
  const auto move_gaussians = [&](GaussianScene& scene, const std::vector<std::int32_t>& anchors) {
    std::span<double> means = scene.mutable_means();
    std::span<double> rotations = scene.mutable_rotations();
    for (std::size_t g = 0; g < scene.size() && g < anchors.size(); ++g) {
      if (anchors[g] < 0) continue;
      const Eigen::Isometry3d& D = moves[static_cast<std::size_t>(anchors[g])];
      Eigen::Map<Eigen::Vector3d> mu(&means[3 * g]);
      mu = D * Eigen::Vector3d(mu);
      const Eigen::Quaterniond r(D.linear());
      double* qs = &rotations[4 * g];
      const Eigen::Quaterniond moved = r * Eigen::Quaterniond(qs[0], qs[1], qs[2], qs[3]);
      qs[0] = moved.w();
      qs[1] = moved.x();
      qs[2] = moved.y();
      qs[3] = moved.z();
    }
  };
  move_gaussians(scene_, anchors_);
  move_gaussians(reference_, reference_anchors_);
  ++stats_.loop_closures;
  estimate_heading_drift();
}

void Backend::estimate_heading_drift() {
  if (options_.heading_drift_window_s <= 0 || keyframes_.empty()) return;
  // Least squares of loop_yaw = a + rate t over the window's keyframes: after a closure the pose
  // graph's ramp since the earlier pass plus the rate already carried forward, so the slope is
  // the whole drift rate, not what is left of it.
  const double t_end = keyframes_.back().t;
  double n = 0, st = 0, sy = 0, stt = 0, sty = 0;
  for (auto it = keyframes_.rbegin(); it != keyframes_.rend() && t_end - it->t <= options_.heading_drift_window_s;
       ++it) {
    const double t = it->t - t_end;  // centred near 0: no cancellation on long runs
    n += 1;
    st += t;
    sy += it->loop_yaw;
    stt += t * t;
    sty += t * it->loop_yaw;
  }
  const double det = n * stt - st * st;
  if (n < 3 || !(det > 0)) return;
  const double rate = (n * sty - st * sy) / det;
  if (!std::isfinite(rate)) {
    ++stats_.nan_guard_hits;
    return;
  }
  const double max_rate = options_.heading_drift_max_deg_s * kDeg;
  heading_drift_rate_ = std::clamp(rate, -max_rate, max_rate);
  stats_.heading_drift_deg_s = heading_drift_rate_ / kDeg;
  ++stats_.heading_drift_updates;
}

OdomCorrection Backend::correction_at(const Keyframe& k) const {
  OdomCorrection c;
  c.map_T_odom = k.world_T_radar * options_.body_T_radar.inverse() * k.odom_T_body.inverse();
  c.hold_height = options_.level_floor;
  c.keyframe_odom_position = k.odom_T_body.translation();
  return c;
}

void Backend::update_correction() { correction_ = correction_at(keyframes_.back()); }

KeyframeRender Backend::render_keyframe(std::size_t k) { return render_keyframe(k, nullptr); }

KeyframeRender Backend::render_keyframe(std::size_t k, const std::vector<char>* drawable) {
  if (k >= keyframes_.size() || !objective_) throw std::out_of_range("Backend::render_keyframe: no such keyframe");
  if (!keyframes_[k].has_images())
    throw std::out_of_range("Backend::render_keyframe: keyframe " + std::to_string(k) + "'s images were evicted");
  const Keyframe& kf = keyframes_[k];
  KeyframeRender out;
  out.ra_measured = kf.ra;
  out.rd_measured = kf.rd;
  const double radius =
      options_.max_render_range_m > 0 ? options_.max_render_range_m : grid_.range_bins * grid_.range_bin_m;
  std::vector<std::uint32_t> list;
  scene_.update_index();
  scene_.query_radius(kf.world_T_radar.translation(), radius, list);
  if (drawable != nullptr)
    std::erase_if(list, [&](std::uint32_t g) { return g >= drawable->size() || !(*drawable)[g]; });
  objective_->ra_renderer().render(scene_, kf.world_T_radar.inverse(), list, out.ra_rendered);
  out.velocity = velocity_of(k, nullptr);
  PixelDirections<float> directions;
  if (options_.rd_gaussian_directions)
    objective_->ra_renderer().render_directions(scene_, kf.world_T_radar.inverse(), list, directions);
  objective_->rd_renderer().render(out.ra_rendered, out.velocity, out.rd_rendered,
                                   options_.rd_gaussian_directions ? &directions : nullptr);
  // What the RA loss compares: neither image beyond an occluder (occlusion_rows).
  zero_occluded(out.ra_measured, kf.visible_rows);
  zero_occluded(out.ra_rendered, kf.visible_rows);
  return out;
}

}  // namespace rsrio::splat

#include "rsrio/rio/odometry.hpp"

#include <chrono>
#include <cmath>
#include <iomanip>
#include <numbers>
#include <ostream>
#include <sstream>

#include "rsrio/common/options.hpp"

namespace rsrio::rio {

namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

std::vector<double> rpy_deg_of(const gtsam::Rot3& R) {
  const gtsam::Vector3 rpy = R.rpy() * 180.0 / std::numbers::pi;
  return {rpy.x(), rpy.y(), rpy.z()};
}

void read_vec3(OptionsNode& node, std::string_view key, std::vector<double>& v) {
  node.read(key, v);
  if (v.size() != 3) node.fail(key, "a list of 3 numbers");
}

}  // namespace

gtsam::Pose3 pose_from_xyz_rpy(const std::vector<double>& xyz, const std::vector<double>& rpy_deg) {
  constexpr double d = std::numbers::pi / 180.0;
  return gtsam::Pose3(gtsam::Rot3::RzRyRx(rpy_deg.at(0) * d, rpy_deg.at(1) * d, rpy_deg.at(2) * d),
                      gtsam::Point3(xyz.at(0), xyz.at(1), xyz.at(2)));
}

OdometryOptions load_odometry_options(OptionsNode& root) {
  OdometryOptions o;
  OptionsNode dsp = root.child("dsp");
  o.dsp = load_dsp_options(dsp);

  OptionsNode e = root.child("ego_velocity");
  EgoVelocityOptions& ev = o.ego_velocity;
  e.read("dimensions", ev.dimensions, {2, 3});
  e.read("min_points", ev.min_points, {3, 100000});
  e.read("min_inliers", ev.min_inliers, {3, 100000});
  e.read("min_inlier_ratio", ev.min_inlier_ratio, {0.0, 1.0});
  e.read("inlier_threshold_mps", ev.inlier_threshold_mps, {1e-4, 10.0});
  e.read("ransac_success_probability", ev.ransac_success_probability, {0.5, 0.999999});
  e.read("max_iterations", ev.max_iterations, {1, 100000});
  e.read("max_condition_number", ev.max_condition_number, {1.0, 1e12});
  e.read("max_speed_mps", ev.max_speed_mps, {0.01, 100.0});
  e.read("doppler_sigma_floor_mps", ev.doppler_sigma_floor_mps, {0.0, 10.0});
  int seed = static_cast<int>(ev.seed);
  e.read("seed", seed, {0, 1 << 30});
  ev.seed = static_cast<std::uint64_t>(seed);
  e.read("min_range_m", o.points.min_range_m, {0.0, 1000.0});
  e.read("min_snr_db", o.points.min_snr_db, {-100.0, 200.0});
  e.read("drop_ambiguous_azimuth", o.points.drop_ambiguous_azimuth);
  e.finish();

  OptionsNode f = root.child("frontend");
  FrontendOptions& fo = o.frontend;
  const Range<double> positive{0.0, 1e6};
  f.read("gravity_mps2", fo.gravity, {9.0, 10.5});
  f.read("accel_noise_density", fo.accel_noise_density, positive);
  f.read("gyro_noise_density", fo.gyro_noise_density, positive);
  f.read("accel_bias_random_walk", fo.accel_bias_random_walk, positive);
  f.read("gyro_bias_random_walk", fo.gyro_bias_random_walk, positive);
  f.read("bias_acc_omega_int", fo.bias_acc_omega_int, {0.0, 1.0});
  f.read("first_estimate_jacobians", fo.first_estimate_jacobians);
  std::vector<double> xyz{fo.body_T_radar.x(), fo.body_T_radar.y(), fo.body_T_radar.z()};
  std::vector<double> rpy = rpy_deg_of(fo.body_T_radar.rotation());
  std::string imu_interpolation = to_string(fo.imu_interpolation);
  f.read_choice("imu_interpolation", imu_interpolation, {"linear", "hold"});
  if (!imu_interpolation_from_string(imu_interpolation, fo.imu_interpolation))  // read_choice's list and the enum disagree
    f.fail("imu_interpolation", "a name the frontend knows, got '" + imu_interpolation + "'");
  read_vec3(f, "radar_translation_m", xyz);
  read_vec3(f, "radar_rpy_deg", rpy);
  fo.body_T_radar = pose_from_xyz_rpy(xyz, rpy);
  f.read("radar_time_offset_s", fo.radar_time_offset_s, {-1.0, 1.0});
  f.read("radar_velocity_sigma_scale", fo.radar_velocity_sigma_scale, {1e-3, 1e3});
  f.read("huber_k", fo.huber_k, {0.01, 1e6});
  f.read("use_radar", fo.use_radar);
  f.read("zero_rate_update", fo.zero_rate_update);
  f.read("still_speed_mps", fo.still_speed_mps, {0.0, 10.0});
  f.read("still_gyro_rate", fo.still_gyro_rate, {0.0, 10.0});
  f.read("still_rate_sigma", fo.still_rate_sigma, {1e-9, 10.0});
  f.read("still_neighbours", fo.still_neighbours, {1, 100});
  f.read("continuous_odometry", fo.continuous_odometry);
  f.read("position_from_velocity", fo.position_from_velocity);
  f.read("whole_run_smoother", fo.whole_run_smoother);
  f.read("window_states", fo.window_states, {2, 1000});
  f.read("lm_max_iterations", fo.lm_max_iterations, {1, 1000});
  f.read("prior_rotation_sigma", fo.prior_rotation_sigma, {1e-9, 10.0});
  f.read("prior_position_sigma", fo.prior_position_sigma, {1e-9, 1e3});
  f.read("prior_velocity_sigma", fo.prior_velocity_sigma, {1e-9, 1e3});
  f.read("prior_accel_bias_sigma", fo.prior_accel_bias_sigma, {1e-9, 1e3});
  f.read("prior_gyro_bias_sigma", fo.prior_gyro_bias_sigma, {1e-9, 1e3});
  f.read("init_imu_window_s", fo.init_imu_window_s, {0.005, 10.0});
  f.finish();
  return o;
}

void print(std::ostream& out, const OdometryOptions& o) {
  print(out, o.dsp);
  const auto& e = o.ego_velocity;
  const auto& f = o.frontend;
  const auto b = [](bool v) { return v ? "true" : "false"; };
  const auto v3 = [](const std::vector<double>& v) {
    std::ostringstream s;
    s << std::setprecision(6) << "[" << v[0] << ", " << v[1] << ", " << v[2] << "]";
    return s.str();
  };
  out << std::setprecision(6);
  out << "ego_velocity:\n"
      << "  dimensions: " << e.dimensions << "\n"
      << "  min_points: " << e.min_points << "\n"
      << "  min_inliers: " << e.min_inliers << "\n"
      << "  min_inlier_ratio: " << e.min_inlier_ratio << "\n"
      << "  inlier_threshold_mps: " << e.inlier_threshold_mps << "\n"
      << "  ransac_success_probability: " << e.ransac_success_probability << "\n"
      << "  max_iterations: " << e.max_iterations << "\n"
      << "  max_condition_number: " << e.max_condition_number << "\n"
      << "  max_speed_mps: " << e.max_speed_mps << "\n"
      << "  doppler_sigma_floor_mps: " << e.doppler_sigma_floor_mps << "\n"
      << "  seed: " << e.seed << "\n"
      << "  min_range_m: " << o.points.min_range_m << "\n"
      << "  min_snr_db: " << o.points.min_snr_db << "\n"
      << "  drop_ambiguous_azimuth: " << b(o.points.drop_ambiguous_azimuth) << "\n"
      << "frontend:\n"
      << "  gravity_mps2: " << f.gravity << "\n"
      << "  accel_noise_density: " << f.accel_noise_density << "\n"
      << "  gyro_noise_density: " << f.gyro_noise_density << "\n"
      << "  accel_bias_random_walk: " << f.accel_bias_random_walk << "\n"
      << "  gyro_bias_random_walk: " << f.gyro_bias_random_walk << "\n"
      << "  bias_acc_omega_int: " << f.bias_acc_omega_int << "\n"
      << "  first_estimate_jacobians: " << b(f.first_estimate_jacobians) << "\n"
      << "  imu_interpolation: " << to_string(f.imu_interpolation) << "\n"
      << "  radar_translation_m: "
      << v3({f.body_T_radar.x(), f.body_T_radar.y(), f.body_T_radar.z()}) << "\n"
      << "  radar_rpy_deg: " << v3(rpy_deg_of(f.body_T_radar.rotation())) << "\n"
      << "  radar_time_offset_s: " << f.radar_time_offset_s << "\n"
      << "  radar_velocity_sigma_scale: " << f.radar_velocity_sigma_scale << "\n"
      << "  huber_k: " << f.huber_k << "\n"
      << "  use_radar: " << b(f.use_radar) << "\n"
      << "  zero_rate_update: " << b(f.zero_rate_update) << "\n"
      << "  still_speed_mps: " << f.still_speed_mps << "\n"
      << "  still_gyro_rate: " << f.still_gyro_rate << "\n"
      << "  still_rate_sigma: " << f.still_rate_sigma << "\n"
      << "  still_neighbours: " << f.still_neighbours << "\n"
      << "  continuous_odometry: " << b(f.continuous_odometry) << "\n"
      << "  position_from_velocity: " << b(f.position_from_velocity) << "\n"
      << "  whole_run_smoother: " << b(f.whole_run_smoother) << "\n"
      << "  window_states: " << f.window_states << "\n"
      << "  lm_max_iterations: " << f.lm_max_iterations << "\n"
      << "  prior_rotation_sigma: " << f.prior_rotation_sigma << "\n"
      << "  prior_position_sigma: " << f.prior_position_sigma << "\n"
      << "  prior_velocity_sigma: " << f.prior_velocity_sigma << "\n"
      << "  prior_accel_bias_sigma: " << f.prior_accel_bias_sigma << "\n"
      << "  prior_gyro_bias_sigma: " << f.prior_gyro_bias_sigma << "\n"
      << "  init_imu_window_s: " << f.init_imu_window_s << "\n";
}

bool accept_point(const PointFilterOptions& filter, const DspPoint& p, DopplerMeasurement& measurement) {
  if (p.range_m < filter.min_range_m || p.snr_db < filter.min_snr_db) return false;
  if (filter.drop_ambiguous_azimuth && p.azimuth_ambiguous) return false;
  const Eigen::Vector3d u(p.x, p.y, p.z);
  const double n = u.norm();
  if (!(n > 0)) return false;
  measurement = {u / n, static_cast<double>(p.doppler_mps)};
  return true;
}

Odometry::Odometry(const RadarConfig& radar, const OdometryOptions& options)
    : options_(options),
      dsp_(radar, options.dsp),
      ego_(options.ego_velocity,
           static_cast<std::size_t>(options.dsp.cfar.max_detections) * static_cast<std::size_t>(options.dsp.max_angle_peaks)),
      frontend_(options.frontend),
      half_frame_s_(0.5 * derive(radar).frame_active_time_s) {
  measurements_.reserve(static_cast<std::size_t>(options.dsp.cfar.max_detections) *
                        static_cast<std::size_t>(options.dsp.max_angle_peaks));
}

const FrameInfo& Odometry::add_radar_frame(double t_stamp, const AdcCube& cube) {
  FrameInfo& info = info_;
  const auto t0 = std::chrono::steady_clock::now();
  const DspResult& dsp = dsp_.process(cube);  // throws before anything changes on a wrong shape
  info.dsp_ms = ms_since(t0);
  info.index = frames_++;
  info.t_stamp = t_stamp;
  info.t = t_stamp - half_frame_s_;
  info.detections = static_cast<int>(dsp.detections.size());
  info.points = static_cast<int>(dsp.points.size());

  const auto t1 = std::chrono::steady_clock::now();
  measurements_.clear();
  DopplerMeasurement m;
  for (const DspPoint& p : dsp.points)
    if (accept_point(options_.points, p, m)) measurements_.push_back(m);
  info.measurements = static_cast<int>(measurements_.size());
  info.ego = ego_.estimate(measurements_, info.index);
  info.ego_ms = ms_since(t1);

  const auto t2 = std::chrono::steady_clock::now();
  info.state = frontend_.add_radar(info.t, info.ego);
  if (info.state) info.world_T_radar = info.state->world_T_body.compose(options_.frontend.body_T_radar);
  info.frontend_ms = ms_since(t2);
  return info;
}

}  // namespace rsrio::rio

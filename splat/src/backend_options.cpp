// The backend's options: the `backend:` section of the config file (strict: an unknown or malformed
// key is named), the check of options made in code, and the section as printed at start-up.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <ostream>
#include <string>
#include <vector>

#include "rsrio/splat/backend.hpp"

namespace rsrio::splat {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

void load_stage(OptionsNode node, StageOptions& s) {
  node.read("max_iterations", s.max_iterations, {0, 100000});
  node.read("time_budget_s", s.time_budget_s, {0.0, 3600.0});
  node.read("convergence_rel", s.convergence_rel, {0.0, 1.0});
  node.read("convergence_patience", s.convergence_patience, {1, 100000});
  node.read("lr_final_factor", s.lr_final_factor, {1e-6, 1.0});
  node.finish();
}

}  // namespace

BackendOptions load_backend_options(OptionsNode node) {
  BackendOptions o;
  {
    OptionsNode e = node.child("body_T_radar");
    std::vector<double> t{0, 0, 0}, rpy{0, 0, 0};
    e.read("translation_m", t);
    e.read("rpy_deg", rpy);
    if (t.size() != 3) e.fail("translation_m", "three numbers [x, y, z]");
    if (rpy.size() != 3) e.fail("rpy_deg", "three numbers [roll, pitch, yaw]");
    e.finish();
    o.body_T_radar = Eigen::Isometry3d::Identity();
    o.body_T_radar.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
    o.body_T_radar.linear() = (Eigen::AngleAxisd(rpy[2] * kDeg, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(rpy[1] * kDeg, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(rpy[0] * kDeg, Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
  }
  node.read("keyframe_distance_m", o.keyframe_distance_m, {0.0, 100.0});
  node.read("keyframe_angle_deg", o.keyframe_angle_deg, {0.0, 180.0});
  node.read("keyframe_time_s", o.keyframe_time_s, {0.0, 3600.0});
  node.read("mapping_keyframes", o.mapping_keyframes, {1, 1000});
  node.read_choice("ba_window", o.ba_window, {"radius", "sliding"});
  node.read("ba_radius_m", o.ba_radius_m, {0.0, 1000.0});
  node.read("ba_sliding_keyframes", o.ba_sliding_keyframes, {1, 1000});
  node.read("ba_max_keyframes", o.ba_max_keyframes, {1, 1000});
  load_stage(node.child("pose"), o.pose);
  load_stage(node.child("mapping"), o.mapping);
  load_stage(node.child("ba"), o.ba);
  load_stage(node.child("final_ba"), o.final_ba);
  node.read("final_ba_rd_loss", o.final_ba_rd_loss);
  node.read("first_keyframe_mapping_iterations", o.first_keyframe_mapping_iterations, {0, 100000});
  node.read("pose_coverage_mask", o.pose_coverage_mask);
  node.read("coverage_margin_bins", o.coverage_margin_bins, {0, 1000});
  node.read("occlusion_threshold", o.occlusion_threshold, {0.0, 100.0});
  node.read("occlusion_row_db", o.occlusion_row_db, {0.0, 200.0});
  node.read("occlusion_margin_m", o.occlusion_margin_m, {0.0, 1000.0});
  node.read("rd_loss", o.rd_loss);
  node.read("ra_weight", o.ra_weight, {0.0, 1e6});
  node.read("rd_weight", o.rd_weight, {0.0, 1e6});
  node.read("l1_weight", o.l1_weight, {0.0, 1e6});
  node.read("ssim_weight", o.ssim_weight, {0.0, 1e6});
  node.read("ssim_window", o.ssim_window, {3, 31});
  node.read("compression_floor", o.compression_floor, {1e-9, 1.0});
  node.read("reference_percentile", o.reference_percentile, {1.0, 100.0});
  node.read("skip_near_range_bins", o.skip_near_range_bins, {0, 100000});
  node.read("scale_regulariser_weight", o.scale_regulariser_weight, {0.0, 1e9});
  node.read("scale_regulariser_max_m", o.scale_regulariser_max_m, {1e-4, 100.0});
  node.read("max_image_range_m", o.max_image_range_m, {0.0, 10000.0});
  node.read("max_render_range_m", o.max_render_range_m, {0.0, 10000.0});
  node.read("elevation_gain_sigma_sin", o.elevation_gain_sigma_sin, {0.0, 10.0});
  node.read("range_falloff_exponent", o.range_falloff_exponent, {0.0, 8.0});
  node.read("azimuth_gain_sigma_deg", o.azimuth_gain_sigma_deg, {0.0, 180.0});
  node.read("view_dependent_return", o.view_dependent_return);
  node.read("lr_view_returns", o.lr_view_returns, {0.0, 10.0});
  node.read("view_return_regulariser_weight", o.view_return_regulariser_weight, {0.0, 1e9});
  node.read("rd_kernel_sigma_bins", o.rd_kernel_sigma_bins, {0.0, 100.0});
  node.read("rd_window_bins", o.rd_window_bins, {0, 1000});
  node.read("rd_gain", o.rd_gain, {0.0, 1e12});
  node.read("rd_gaussian_directions", o.rd_gaussian_directions);
  node.read("rd_elevation_sigma_sin", o.rd_elevation_sigma_sin, {0.0, 0.49});
  node.read("rd_image_gradient", o.rd_image_gradient);
  node.read_choice("psf_range_window", o.psf_range_window, {"none", "hann", "hamming", "blackman"});
  node.read_choice("psf_angle_window", o.psf_angle_window, {"none", "hann", "hamming", "blackman"});
  node.read_choice("psf_doppler_window", o.psf_doppler_window, {"none", "hann", "hamming", "blackman"});
  node.read("pose_dof", o.pose_dof, {3, 6});
  node.read("level_floor", o.level_floor);
  node.read("odometry_prior", o.odometry_prior);
  node.read("odometry_prior_sigma_m", o.odometry_prior_sigma_m, {1e-6, 100.0});
  node.read("odometry_prior_sigma_deg", o.odometry_prior_sigma_deg, {1e-6, 180.0});
  node.read("odometry_prior_across_sigma_m", o.odometry_prior_across_sigma_m, {0.0, 100.0});
  node.read("odometry_yaw_sigma_deg", o.odometry_yaw_sigma_deg, {0.0, 180.0});
  node.read("heading_drift_window_s", o.heading_drift_window_s, {0.0, 1e6});
  node.read("heading_drift_max_deg_s", o.heading_drift_max_deg_s, {0.0, 10.0});
  node.read("tilt_prior_sigma_deg", o.tilt_prior_sigma_deg, {1e-6, 180.0});
  node.read("height_prior_sigma_m", o.height_prior_sigma_m, {1e-6, 100.0});
  node.read("lr_pose_translation", o.lr_pose_translation, {0.0, 10.0});
  node.read("lr_pose_rotation", o.lr_pose_rotation, {0.0, 10.0});
  node.read("lr_means", o.lr_means, {0.0, 10.0});
  node.read("lr_rotations", o.lr_rotations, {0.0, 10.0});
  node.read("lr_log_scales", o.lr_log_scales, {0.0, 10.0});
  node.read("lr_log_returns", o.lr_log_returns, {0.0, 10.0});
  node.read("max_gaussians", o.max_gaussians, {1, 100'000'000});
  node.read("max_keyframe_images", o.max_keyframe_images, {1, 100'000'000});
  node.read("max_keyframe_points", o.max_keyframe_points, {1, 100'000'000});
  node.read("max_keyframes", o.max_keyframes, {1, 100'000'000});
  node.read("init_scale_m", o.init_scale_m, {1e-4, 10.0});
  node.read("init_min_spacing_m", o.init_min_spacing_m, {0.0, 10.0});
  node.read("static_doppler_tolerance_mps", o.static_doppler_tolerance_mps, {0.0, 100.0});
  node.read("min_point_snr_db", o.min_point_snr_db, {-100.0, 200.0});
  node.read("loop_closure", o.loop_closure);
  node.read("loop_min_age_s", o.loop_min_age_s, {0.0, 1e6});
  node.read("loop_radius_m", o.loop_radius_m, {0.0, 1000.0});
  node.read("loop_query_keyframes", o.loop_query_keyframes, {1, 1000});
  node.read("loop_reference_keyframes", o.loop_reference_keyframes, {1, 100000});
  node.read("loop_every_keyframes", o.loop_every_keyframes, {1, 100000});
  node.read("loop_min_score", o.loop_min_score, {0.0, 1.0});
  node.read("loop_min_gain", o.loop_min_gain, {0.0, 100.0});
  node.read("loop_max_spread_m", o.loop_max_spread_m, {0.0, 100.0});
  node.read("loop_max_spread_deg", o.loop_max_spread_deg, {0.0, 180.0});
  node.read("loop_min_correction_m", o.loop_min_correction_m, {0.0, 100.0});
  node.read("loop_min_correction_deg", o.loop_min_correction_deg, {0.0, 180.0});
  node.read("loop_max_refinement_m", o.loop_max_refinement_m, {0.0, 100.0});
  node.read("loop_max_refinement_deg", o.loop_max_refinement_deg, {0.0, 180.0});
  node.read("loop_lr_pose_translation", o.loop_lr_pose_translation, {0.0, 10.0});
  node.read("loop_image_alignment", o.loop_image_alignment);
  node.read("loop_frozen_reference", o.loop_frozen_reference);
  node.read("loop_freeze_distance_m", o.loop_freeze_distance_m, {0.0, 1e6});
  node.read("loop_retry_search_m", o.loop_retry_search_m, {0.0, 100.0});
  node.read("loop_retry_search_deg", o.loop_retry_search_deg, {0.0, 90.0});
  {
    OptionsNode m = node.child("loop_match");
    m.read("search_m", o.loop.search_m, {0.0, 100.0});
    m.read("search_deg", o.loop.search_deg, {0.0, 90.0});
    m.read("cell_m", o.loop.cell_m, {1e-3, 10.0});
    m.read("step_deg", o.loop.step_deg, {1e-3, 90.0});
    m.read("sigma_m", o.loop.sigma_m, {1e-3, 10.0});
    m.read("near_best_fraction", o.loop.near_best_fraction, {0.01, 0.999});
    m.read("refine_peak", o.loop.refine_peak);
    int max_query = static_cast<int>(o.loop.max_query_points);
    m.read("max_query_points", max_query, {1, 1'000'000});
    o.loop.max_query_points = static_cast<std::size_t>(max_query);
    m.finish();
  }
  {
    OptionsNode g = node.child("loop_graph");
    g.read("odometry_sigma_m", o.loop_graph.odometry_sigma_m, {1e-6, 100.0});
    g.read("odometry_sigma_deg", o.loop_graph.odometry_sigma_deg, {1e-6, 180.0});
    g.read("loop_sigma_m", o.loop_graph.loop_sigma_m, {1e-6, 100.0});
    g.read("loop_sigma_deg", o.loop_graph.loop_sigma_deg, {1e-6, 180.0});
    int max_keyframes = static_cast<int>(o.loop_graph.max_keyframes);
    g.read("max_keyframes", max_keyframes, {0, 1'000'000});
    o.loop_graph.max_keyframes = static_cast<std::size_t>(max_keyframes);
    g.finish();
  }
  node.finish();
  validate(o, node.file());
  return o;
}

void print(std::ostream& out, const BackendOptions& o) {
  const Eigen::Vector3d t = o.body_T_radar.translation();
  const Eigen::Vector3d ypr = o.body_T_radar.linear().eulerAngles(2, 1, 0) / kDeg;  // R = Rz Ry Rx
  auto stage = [&](const char* name, const StageOptions& s) {
    out << "  " << name << ": {max_iterations: " << s.max_iterations << ", time_budget_s: " << s.time_budget_s
        << ", convergence_rel: " << s.convergence_rel << ", convergence_patience: " << s.convergence_patience
        << ", lr_final_factor: " << s.lr_final_factor << "}\n";
  };
  out << "backend:\n"
      << "  body_T_radar: {translation_m: [" << t.x() << ", " << t.y() << ", " << t.z() << "], rpy_deg: [" << ypr[2]
      << ", " << ypr[1] << ", " << ypr[0] << "]}\n"
      << "  keyframe_distance_m: " << o.keyframe_distance_m << "\n"
      << "  keyframe_angle_deg: " << o.keyframe_angle_deg << "\n"
      << "  keyframe_time_s: " << o.keyframe_time_s << "\n"
      << "  mapping_keyframes: " << o.mapping_keyframes << "\n"
      << "  ba_window: " << o.ba_window << "\n"
      << "  ba_radius_m: " << o.ba_radius_m << "\n"
      << "  ba_sliding_keyframes: " << o.ba_sliding_keyframes << "\n"
      << "  ba_max_keyframes: " << o.ba_max_keyframes << "\n";
  stage("pose", o.pose);
  stage("mapping", o.mapping);
  stage("ba", o.ba);
  stage("final_ba", o.final_ba);
  out << "  final_ba_rd_loss: " << (o.final_ba_rd_loss ? "true" : "false") << "\n"
      << "  first_keyframe_mapping_iterations: " << o.first_keyframe_mapping_iterations << "\n"
      << "  pose_coverage_mask: " << (o.pose_coverage_mask ? "true" : "false") << "\n"
      << "  coverage_margin_bins: " << o.coverage_margin_bins << "\n"
      << "  occlusion_threshold: " << o.occlusion_threshold << "\n"
      << "  occlusion_row_db: " << o.occlusion_row_db << "\n"
      << "  occlusion_margin_m: " << o.occlusion_margin_m << "\n"
      << "  rd_loss: " << (o.rd_loss ? "true" : "false") << "\n"
      << "  ra_weight: " << o.ra_weight << "\n"
      << "  rd_weight: " << o.rd_weight << "\n"
      << "  l1_weight: " << o.l1_weight << "\n"
      << "  ssim_weight: " << o.ssim_weight << "\n"
      << "  ssim_window: " << o.ssim_window << "\n"
      << "  compression_floor: " << o.compression_floor << "\n"
      << "  reference_percentile: " << o.reference_percentile << "\n"
      << "  skip_near_range_bins: " << o.skip_near_range_bins << "\n"
      << "  scale_regulariser_weight: " << o.scale_regulariser_weight << "\n"
      << "  scale_regulariser_max_m: " << o.scale_regulariser_max_m << "\n"
      << "  max_image_range_m: " << o.max_image_range_m << "\n"
      << "  max_render_range_m: " << o.max_render_range_m << "\n"
      << "  elevation_gain_sigma_sin: " << o.elevation_gain_sigma_sin << "\n"
      << "  range_falloff_exponent: " << o.range_falloff_exponent << "\n"
      << "  azimuth_gain_sigma_deg: " << o.azimuth_gain_sigma_deg << "\n"
      << "  view_dependent_return: " << (o.view_dependent_return ? "true" : "false") << "\n"
      << "  lr_view_returns: " << o.lr_view_returns << "\n"
      << "  view_return_regulariser_weight: " << o.view_return_regulariser_weight << "\n"
      << "  rd_kernel_sigma_bins: " << o.rd_kernel_sigma_bins << "\n"
      << "  rd_window_bins: " << o.rd_window_bins << "\n"
      << "  rd_gain: " << o.rd_gain << "\n"
      << "  rd_gaussian_directions: " << (o.rd_gaussian_directions ? "true" : "false") << "\n"
      << "  rd_elevation_sigma_sin: " << o.rd_elevation_sigma_sin << "\n"
      << "  rd_image_gradient: " << (o.rd_image_gradient ? "true" : "false") << "\n"
      << "  psf_range_window: " << o.psf_range_window << "\n"
      << "  psf_angle_window: " << o.psf_angle_window << "\n"
      << "  psf_doppler_window: " << o.psf_doppler_window << "\n"
      << "  pose_dof: " << o.pose_dof << "\n"
      << "  level_floor: " << (o.level_floor ? "true" : "false") << "\n"
      << "  odometry_prior: " << (o.odometry_prior ? "true" : "false") << "\n"
      << "  odometry_prior_sigma_m: " << o.odometry_prior_sigma_m << "\n"
      << "  odometry_prior_sigma_deg: " << o.odometry_prior_sigma_deg << "\n"
      << "  odometry_prior_across_sigma_m: " << o.odometry_prior_across_sigma_m << "\n"
      << "  odometry_yaw_sigma_deg: " << o.odometry_yaw_sigma_deg << "\n"
      << "  heading_drift_window_s: " << o.heading_drift_window_s << "\n"
      << "  heading_drift_max_deg_s: " << o.heading_drift_max_deg_s << "\n"
      << "  tilt_prior_sigma_deg: " << o.tilt_prior_sigma_deg << "\n"
      << "  height_prior_sigma_m: " << o.height_prior_sigma_m << "\n"
      << "  lr_pose_translation: " << o.lr_pose_translation << "\n"
      << "  lr_pose_rotation: " << o.lr_pose_rotation << "\n"
      << "  lr_means: " << o.lr_means << "\n"
      << "  lr_rotations: " << o.lr_rotations << "\n"
      << "  lr_log_scales: " << o.lr_log_scales << "\n"
      << "  lr_log_returns: " << o.lr_log_returns << "\n"
      << "  max_gaussians: " << o.max_gaussians << "\n"
      << "  max_keyframe_images: " << o.max_keyframe_images << "\n"
      << "  max_keyframe_points: " << o.max_keyframe_points << "\n"
      << "  max_keyframes: " << o.max_keyframes << "\n"
      << "  init_scale_m: " << o.init_scale_m << "\n"
      << "  init_min_spacing_m: " << o.init_min_spacing_m << "\n"
      << "  static_doppler_tolerance_mps: " << o.static_doppler_tolerance_mps << "\n"
      << "  min_point_snr_db: " << o.min_point_snr_db << "\n"
      << "  loop_closure: " << (o.loop_closure ? "true" : "false") << "\n"
      << "  loop_min_age_s: " << o.loop_min_age_s << "\n"
      << "  loop_radius_m: " << o.loop_radius_m << "\n"
      << "  loop_query_keyframes: " << o.loop_query_keyframes << "\n"
      << "  loop_reference_keyframes: " << o.loop_reference_keyframes << "\n"
      << "  loop_every_keyframes: " << o.loop_every_keyframes << "\n"
      << "  loop_min_score: " << o.loop_min_score << "\n"
      << "  loop_min_gain: " << o.loop_min_gain << "\n"
      << "  loop_max_spread_m: " << o.loop_max_spread_m << "\n"
      << "  loop_max_spread_deg: " << o.loop_max_spread_deg << "\n"
      << "  loop_min_correction_m: " << o.loop_min_correction_m << "\n"
      << "  loop_min_correction_deg: " << o.loop_min_correction_deg << "\n"
      << "  loop_max_refinement_m: " << o.loop_max_refinement_m << "\n"
      << "  loop_max_refinement_deg: " << o.loop_max_refinement_deg << "\n"
      << "  loop_lr_pose_translation: " << o.loop_lr_pose_translation << "\n"
      << "  loop_image_alignment: " << (o.loop_image_alignment ? "true" : "false") << "\n"
      << "  loop_frozen_reference: " << (o.loop_frozen_reference ? "true" : "false") << "\n"
      << "  loop_freeze_distance_m: " << o.loop_freeze_distance_m << "\n"
      << "  loop_retry_search_m: " << o.loop_retry_search_m << "\n"
      << "  loop_retry_search_deg: " << o.loop_retry_search_deg << "\n"
      << "  loop_match: {search_m: " << o.loop.search_m << ", search_deg: " << o.loop.search_deg
      << ", cell_m: " << o.loop.cell_m << ", step_deg: " << o.loop.step_deg << ", sigma_m: " << o.loop.sigma_m
      << ", near_best_fraction: " << o.loop.near_best_fraction << ", max_query_points: " << o.loop.max_query_points
      << ", refine_peak: " << (o.loop.refine_peak ? "true" : "false") << "}\n"
      << "  loop_graph: {odometry_sigma_m: " << o.loop_graph.odometry_sigma_m
      << ", odometry_sigma_deg: " << o.loop_graph.odometry_sigma_deg
      << ", loop_sigma_m: " << o.loop_graph.loop_sigma_m << ", loop_sigma_deg: " << o.loop_graph.loop_sigma_deg
      << ", max_keyframes: " << o.loop_graph.max_keyframes << "}\n";
}

void validate(const BackendOptions& o, const std::string& file) {
  auto fail = [&](const std::string& key, const std::string& what) { throw ConfigError(file, "backend." + key, what); };
  if (!o.body_T_radar.matrix().allFinite()) fail("body_T_radar", "a finite transform");
  if (o.pose_dof != 3 && o.pose_dof != 6) fail("pose_dof", "3 or 6");
  if (!(o.tilt_prior_sigma_deg > 0)) fail("tilt_prior_sigma_deg", "a number > 0");
  if (!(o.height_prior_sigma_m > 0)) fail("height_prior_sigma_m", "a number > 0");
  if (o.ba_window != "radius" && o.ba_window != "sliding") fail("ba_window", "one of 'radius' 'sliding'");
  if (o.mapping_keyframes < 1) fail("mapping_keyframes", "an integer >= 1");
  if (o.ba_sliding_keyframes < 1) fail("ba_sliding_keyframes", "an integer >= 1");
  if (o.ba_max_keyframes < 1) fail("ba_max_keyframes", "an integer >= 1");
  if (!(o.ba_radius_m >= 0)) fail("ba_radius_m", "a number >= 0");
  if (o.ssim_window < 3 || o.ssim_window % 2 == 0) fail("ssim_window", "an odd integer >= 3");
  if (!(o.compression_floor > 0)) fail("compression_floor", "a number > 0");
  if (!(o.reference_percentile > 0 && o.reference_percentile <= 100)) fail("reference_percentile", "a number in (0, 100]");
  if (!(o.init_scale_m > 0)) fail("init_scale_m", "a number > 0");
  if (o.max_gaussians < 1) fail("max_gaussians", "an integer >= 1");
  if (o.max_keyframe_images < std::max(o.mapping_keyframes, o.ba_max_keyframes))
    fail("max_keyframe_images", "an integer >= mapping_keyframes and ba_max_keyframes (those keep their images)");
  if (o.max_keyframe_points < o.max_keyframe_images || (o.loop_closure && o.max_keyframe_points < o.loop_query_keyframes))
    fail("max_keyframe_points", "an integer >= max_keyframe_images and loop_query_keyframes (points outlive images)");
  if (o.max_keyframes <= o.max_keyframe_points)
    fail("max_keyframes", "an integer > max_keyframe_points (only keyframes without images and points are dropped)");
  if (o.odometry_prior && !(o.odometry_prior_sigma_m > 0)) fail("odometry_prior_sigma_m", "a number > 0");
  if (o.odometry_prior && !(o.odometry_prior_sigma_deg > 0)) fail("odometry_prior_sigma_deg", "a number > 0");
  if (!(o.odometry_prior_across_sigma_m >= 0)) fail("odometry_prior_across_sigma_m", "a number >= 0 (0: isotropic)");
  if (!(o.loop.cell_m > 0)) fail("loop_match.cell_m", "a number > 0");
  if (!(o.loop.step_deg > 0)) fail("loop_match.step_deg", "a number > 0");
  if (!(o.loop.sigma_m > 0)) fail("loop_match.sigma_m", "a number > 0");
  if (!(o.loop.near_best_fraction > 0 && o.loop.near_best_fraction < 1))
    fail("loop_match.near_best_fraction", "a number in (0, 1)");
  if (!(o.loop.search_m >= 0 && o.loop.search_m / o.loop.cell_m <= 200))
    fail("loop_match.search_m", "a number >= 0, at most 200 cell_m steps");
  if (!(o.loop.search_deg >= 0 && o.loop.search_deg / o.loop.step_deg <= 200))
    fail("loop_match.search_deg", "a number >= 0, at most 200 step_deg steps");
  if (o.loop.max_query_points < 1) fail("loop_match.max_query_points", "an integer >= 1");
  if (!(o.loop_graph.odometry_sigma_m > 0)) fail("loop_graph.odometry_sigma_m", "a number > 0");
  if (!(o.loop_graph.odometry_sigma_deg > 0)) fail("loop_graph.odometry_sigma_deg", "a number > 0");
  if (!(o.loop_graph.loop_sigma_m > 0)) fail("loop_graph.loop_sigma_m", "a number > 0");
  if (!(o.loop_graph.loop_sigma_deg > 0)) fail("loop_graph.loop_sigma_deg", "a number > 0");
  if (!(o.loop_retry_search_m >= 0 && o.loop_retry_search_m / o.loop.cell_m <= 200))
    fail("loop_retry_search_m", "a number >= 0, at most 200 loop_match.cell_m steps");
  if (!(o.loop_retry_search_deg >= 0 && o.loop_retry_search_deg / o.loop.step_deg <= 200))
    fail("loop_retry_search_deg", "a number >= 0, at most 200 loop_match.step_deg steps");
  if (o.loop_frozen_reference && !o.loop_image_alignment)
    fail("loop_frozen_reference", "false unless loop_image_alignment is true (only the image alignment draws the copy)");
  if (o.loop_query_keyframes < 1) fail("loop_query_keyframes", "an integer >= 1");
  if (o.loop_reference_keyframes < 1) fail("loop_reference_keyframes", "an integer >= 1");
  if (o.loop_every_keyframes < 1) fail("loop_every_keyframes", "an integer >= 1");
  if (!(o.rd_kernel_sigma_bins >= 0)) fail("rd_kernel_sigma_bins", "a number >= 0 (0: the DSP's Doppler lobe)");
  if (!(o.rd_elevation_sigma_sin >= 0 && o.rd_elevation_sigma_sin < 0.5))
    fail("rd_elevation_sigma_sin", "a number in [0, 0.5) (0: elevation 0)");
  if (o.rd_elevation_sigma_sin > 0 && o.rd_gaussian_directions)
    fail("rd_elevation_sigma_sin", "0 with rd_gaussian_directions (the Gaussians' directions carry the elevation)");
  const auto check_stage = [&](const StageOptions& s, const std::string& name) {
    if (s.max_iterations < 0) fail(name + ".max_iterations", "an integer >= 0");
    if (!(s.time_budget_s >= 0)) fail(name + ".time_budget_s", "a number >= 0");
    if (!(s.lr_final_factor > 0 && s.lr_final_factor <= 1)) fail(name + ".lr_final_factor", "a number in (0, 1]");
    if (s.convergence_patience < 1) fail(name + ".convergence_patience", "an integer >= 1");
  };
  check_stage(o.pose, "pose");
  check_stage(o.mapping, "mapping");
  check_stage(o.ba, "ba");
  check_stage(o.final_ba, "final_ba");
}

}  // namespace rsrio::splat

// The RadarSplat++ backend (paper Sec. III-E, SPEC Sec. 9): keyframes from the frontend's poses,
// a Gaussian map initialised from the keyframes' CFAR points, and per new keyframe
//   0. (not in the paper, loop_closure) on a revisit, alignment against the earlier pass and a
//      loop constraint in a pose graph that moves the keyframes and their Gaussians
//      (align_revisit, loop_closure.hpp),
//   1. pose refinement of the newest keyframe (RA + RD loss, poses only),
//   2. mapping over the last N_map keyframes (RA loss + scale regulariser, Gaussians only),
//   3. bundle adjustment over the keyframes within r_BA of the newest (or the last N, the
//      sliding-window option): RA + RD loss + scale regulariser, poses and Gaussians,
// each a bounded number of Adam iterations inside a time budget, stopping early when the loss
// has stopped moving.
//
// FRAMES. The frontend estimates odom_T_body (its FrontendState::world_T_body: body = IMU). The
// backend works with radar poses world_T_radar = map_T_odom odom_T_body body_T_radar
// (options.body_T_radar is the extrinsic) in the MAP frame, which is the odom frame at the first
// keyframe (that keyframe's pose is the gauge and is never changed). After each keyframe
//     map_T_odom = map_T_body(newest keyframe, refined) * odom_T_body(newest keyframe)^-1,
// so that corrected(odom_T_body) = map_T_odom odom_T_body is the refined keyframe pose composed
// with the frontend's motion since that keyframe (REP-105's map -> odom). At the newest keyframe
// corrected() is exactly its refined pose; between keyframes it moves exactly as the frontend
// (on a level floor only horizontally: OdomCorrection).
//
// POSES. 3-DoF (default, the paper's x, y, yaw): a keyframe's x, y, yaw are optimised and its
// roll and pitch stay what the (corrected) frontend gave (elevation is marginalised by the
// renderer, so the images hardly see them); its z is the first keyframe's (level_floor, default)
// or the frontend's. 6-DoF: se(3) left increments (pose.hpp), with roll, pitch and z held softly
// near the frontend's tilt and the keyframe's starting height (vertical_prior).
//
// PRIORS. Besides the paper's image losses, pose refinement and BA weigh the frontend's planar
// motion between consecutive keyframes (planar_relative_prior) and its heading (planar_yaw_prior)
// (odometry_prior). Without them the poses slide where the images are ambiguous and the yaw of a
// window and its map wanders (measured on the simulated sequences: README).
//
// VELOCITY for the RD rendering of keyframe k (paper: "v obtained from T_k and T_{k-1} and the
// time difference"): the backward difference of the radar positions of keyframe k and its
// previous keyframe k-1, v_pair(T_k, T_{k-1}) (radar_velocity_from_poses), plus a constant that
// turns this average over the keyframe interval into the velocity AT frame k:
//     v_k = v_pair(T_k, T_{k-1}) + (v_odom,k - v_pair(odomT_k, odomT_{k-1})),
// v_odom,k = the frontend's velocity from frame k and its predecessor frame (the instantaneous
// velocity that the measured Doppler shows). The constant does not depend on the optimised poses,
// so the RD loss constrains the RELATIVE motion between consecutive keyframes (the scale and
// heading drift of the frontend), with gradients to both poses. The first keyframe has no
// previous keyframe: v = v_odom (constant).
//
// NaN guard: a non-finite loss or gradient skips the step (counted in stats().nan_guard_hits);
// poses are checked after each step and restored if not finite; the scene is sanitised after
// each stage (GaussianScene::sanitize, non-finite Gaussians removed and counted).
//
// Not thread-safe: one thread calls add_frame() (the backend thread of the daemon); the
// accessors may be called from that thread between add_frame() calls.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <gtsam/geometry/Pose3.h>

#include "rsrio/common/options.hpp"
#include "rsrio/common/radar_config.hpp"
#include "rsrio/dsp/processor.hpp"
#include "rsrio/rio/odometry.hpp"
#include "rsrio/splat/adam.hpp"
#include "rsrio/splat/gaussian_scene.hpp"
#include "rsrio/splat/grid.hpp"
#include "rsrio/splat/loop_closure.hpp"
#include "rsrio/splat/losses.hpp"
#include "rsrio/splat/pose.hpp"
#include "rsrio/splat/ra_renderer.hpp"
#include "rsrio/splat/rd_renderer.hpp"

namespace rsrio::splat {

/// One optimisation stage: at most max_iterations Adam steps and time_budget_s seconds (0: no
/// budget), early stop when the loss changed by less than convergence_rel (relative) for
/// convergence_patience consecutive iterations. Learning rates decay exponentially to
/// lr_final_factor of their value over max_iterations.
struct StageOptions {
  int max_iterations = 50;
  double time_budget_s = 0.5;
  double convergence_rel = 1e-4;
  int convergence_patience = 5;
  double lr_final_factor = 0.1;
};

struct BackendOptions {
  // ---- extrinsic: the radar in the body (IMU) frame, as the frontend's body_T_radar.
  Eigen::Isometry3d body_T_radar = Eigen::Isometry3d::Identity();
  // ---- keyframe selection (from the frontend's motion since the last keyframe; any one).
  double keyframe_distance_m = 0.4;
  double keyframe_angle_deg = 10.0;
  double keyframe_time_s = 1.0;
  // ---- windows
  int mapping_keyframes = 10;         // N_map
  std::string ba_window = "radius";   // radius (r_BA around the newest keyframe) | sliding (last N)
  double ba_radius_m = 10.0;          // r_BA
  int ba_sliding_keyframes = 10;      // N of the sliding window
  int ba_max_keyframes = 10;          // bound on either window (sliding: the newest; radius: the
                                      // newest half and the older ones nearest the newest keyframe)
  // ---- stages
  // Defaults: about 0.5 s per keyframe at most, i.e. one core keeps up with a keyframe every
  // 0.4 m at walking speed (rsrio-splat-bench measures it).
  StageOptions pose{40, 0.1, 1e-4, 5, 0.1};
  StageOptions mapping{20, 0.15, 1e-4, 5, 0.1};
  StageOptions ba{20, 0.25, 1e-4, 5, 0.1};
  int first_keyframe_mapping_iterations = 100;  // the map of the first keyframe alone (no budget)
  // The end-of-run BA (Backend::finish): every keyframe that still has its images, all poses but
  // the first keyframe's (the gauge) and the whole map, RA + RD. The windows above see ten
  // keyframes at a time, so a map bent by the frontend's drift over a longer stretch could stay
  // bent; all the views at once are what could straighten it (on the simulated sequences it takes
  // a few millimetres off, with rd_image_gradient false only: README). Not causal: it moves the
  // end-of-run trajectory (rsrio-replay's estimate_final.tum), never a published pose.
  // max_iterations 0: off.
  StageOptions final_ba{0, 0.0, 1e-5, 5, 0.1};
  // false: the end-of-run BA on the RA loss alone (the windows keep the RD as rd_loss says). The
  // elevation-0 RD fits the DSP's RD at 0.978 x the true speed, and over every keyframe at once its
  // pull towards slow draws the walk smaller: on the simulated sequences the RA-only end-of-run BA
  // ends 3-6 mm nearer the truth on three of five and within 0.4 mm on the others, and gives back
  // part of the heading the RD's holds in the room (splat/RESULTS.md, 2026-12-08). Ignored when
  // rd_loss is false.
  bool final_ba_rd_loss = true;
  // Pose refinement compares only the part of the newest keyframe's images that the map explains:
  // pixels farther than coverage_margin_bins (range and azimuth) from any the map renders above
  // the compression knee take the rendered value as target. Returns from what is not mapped yet
  // (ahead, round a corner) would otherwise pull the pose towards them.
  bool pose_coverage_mask = true;
  int coverage_margin_bins = 3;
  // What a keyframe's RA cannot show. A wall hides what lies behind it, but the renderer draws
  // every Gaussian in range (RadarSplat's, no occlusion): from a corridor it draws the corridors
  // beyond its walls that the map holds from other views, and the losses pull poses and
  // Gaussians to explain returns that no radar there could measure. occlusion_threshold > 0: in
  // each azimuth column of a keyframe's measured RA the nearest pixel whose compressed power is
  // at least this (1: the reference, reference_percentile) and within occlusion_row_db of its
  // range row's strongest (so not an azimuth sidelobe of a return elsewhere at that range) is
  // taken for an occluder, and the pixels more than occlusion_margin_m beyond it take no part in
  // that keyframe's RA loss: measured and rendered RA set to 0 there (occlusion_rows). The RD
  // is rendered from the whole RA: the measured RD holds every return received, and rendered
  // from the masked RA the default configuration's end of run was worse on sequences 1-3
  // (splat/RESULTS.md, 2026-12-06). 0: off.
  double occlusion_threshold = 0;
  double occlusion_row_db = 10;
  double occlusion_margin_m = 0.5;
  // ---- loss
  bool rd_loss = true;                // RD term in pose refinement and BA (the ablation: false)
  double ra_weight = 1.0;
  double rd_weight = 1.0;
  double l1_weight = 0.8;
  double ssim_weight = 0.2;
  int ssim_window = 11;
  double compression_floor = 1e-3;         // knee of the log compression, relative to the reference
  double reference_percentile = 99.0;      // of the first keyframe's images: the fixed references
  int skip_near_range_bins = 4;            // TX-RX leakage and DC
  double scale_regulariser_weight = 100.0;
  double scale_regulariser_max_m = 0.5;
  // ---- rendering
  double max_image_range_m = 0;        // only range bins below this take part (0: the whole grid);
                                       // indoors the far bins hold noise and ghosts, and cost time
  double max_render_range_m = 0;       // Gaussians farther than this from the radar are not drawn (0: grid)
  double elevation_gain_sigma_sin = 0; // RaRenderOptions
  double range_falloff_exponent = 0;   // RaRenderOptions (reference 1 m); 4: the radar equation
  double azimuth_gain_sigma_deg = 0;   // RaRenderOptions; the shipped scenarios' beam: 36
  // Each Gaussian's return depends on the horizontal direction it is seen from (RaRenderOptions::
  // view_dependent_return; RadarSplat's reflectance is view-dependent through spherical
  // harmonics), trained at lr_view_returns and held towards isotropic by
  // view_return_regulariser_weight (mean over the stage's Gaussians of their terms' squares).
  bool view_dependent_return = false;
  double lr_view_returns = 0.03;
  double view_return_regulariser_weight = 1.0;
  // Doppler soft-binning sigma in bins. <= 0: the DSP's Doppler main lobe (psf_doppler_window's
  // power FWHM / 2.355, 0.61 bins for hann). The paper's 3 bins suit its fine Doppler bins; on
  // an xwr1843 frame (0.29 m/s bins) 3 bins blur the RD image so much that it hardly depends
  // on the velocity (backend_sim_test measures the correlation against the DSP's RD).
  double rd_kernel_sigma_bins = 0;
  int rd_window_bins = 10;             // paper
  double rd_gain = 0;                  // RD / RA scale; <= 0: calibrated on the first keyframe
  // Each RD pixel's Doppler from where the map's Gaussians in it lie (their 3D directions, the
  // paper's per-Gaussian -r^T v; RdRenderer, PixelDirections) instead of from its azimuth at
  // elevation 0, which makes returns above and below the radar close in too fast and so pulls
  // the velocity low (rsrio-splat-bench: best fit at 0.978 x the true speed at elevation 0,
  // 0.992 x with the simulator's scatterers' directions). Off by default: with the map's own
  // Gaussians it made sequences 3-5 0.3-0.6 % too long and worse, and sequence 1 worse (README).
  // The directions are made once per view and stage.
  bool rd_gaussian_directions = false;
  // The RD pixels' Doppler marginalised over the radar's elevation beam instead of taken at
  // elevation 0 (RdRenderOptions::elevation_sigma_sin: sigma of sin(elevation) of the two-way
  // beam; 0: elevation 0, the paper's model). rsrio-splat-bench: 0.993 x the true speed fits best
  // with the simulator's beam (0.157), as with the scatterers' own directions (0.992), against
  // 0.978 at elevation 0. Off by default: in the pipeline it made every walk 0.1-0.4 % longer
  // and sequences 3-5 worse at the end of the run (README). Not with rd_gaussian_directions,
  // whose directions carry the elevation (a configuration error).
  double rd_elevation_sigma_sin = 0;
  // The RD loss's gradient reaches the poses and Gaussians through the RA image it is rendered
  // from (the paper's chain rule) as well as through the velocity. false: through the velocity
  // only, so that the RD term constrains motion and leaves the map's geometry to the RA loss.
  bool rd_image_gradient = true;
  std::string psf_range_window = "hann";  // the DSP's windows (dsp.range_window / angle_window)
  std::string psf_angle_window = "none";
  std::string psf_doppler_window = "hann";
  // ---- poses
  int pose_dof = 3;                    // 3: x, y, yaw; 6: se(3)
  // The platform moves on a level floor: every keyframe's radar height (map z) is the first
  // keyframe's instead of the frontend's, whose z drifts (the radar hardly sees height, and
  // double-integrated vertical acceleration wanders: decimetres over a few minutes). 3-DoF poses
  // keep it there; 6-DoF poses start from it. A corrected pose keeps its keyframe's height too
  // (OdomCorrection): between keyframes the frontend's z wanders by up to 3 cm in a second on the
  // simulated walks, and published that way it snapped back at every keyframe.
  bool level_floor = true;
  // The frontend's planar motion between consecutive keyframes as a prior in pose refinement and
  // BA (planar_relative_prior; not in the paper, whose image losses alone let the poses slide
  // where the map is ambiguous: the ablation `without the odometry prior` measures it). 6-DoF:
  // the same planar prior on the poses' x, y, yaw. Loose on purpose: the frontend is good to
  // millimetres between keyframes, but a tight prior leaves the images no say (1 cm / 0.2 deg:
  // the poses moved by 0.1 mm per keyframe on sequence 1); 0.2 m lets the map correct the drift.
  bool odometry_prior = true;
  double odometry_prior_sigma_m = 0.2;
  double odometry_prior_sigma_deg = 1.0;
  // ... across the frontend's motion between the two keyframes (planar_relative_prior's
  // sigma_across_m; 0: odometry_prior_sigma_m, isotropic): the direction a keyframe moves in its
  // own frame is the radar's sideslip, which the frontend measures well, where how far it moves
  // is what the map corrects.
  double odometry_prior_across_sigma_m = 0;
  // ... and the frontend's heading itself (planar_yaw_prior; 0: off): the map frame is the odom
  // frame at the first keyframe, so a keyframe's yaw should stay near the frontend's. Without it
  // the yaw of sequences 3 and 4 random-walked by 3-6 deg over a few minutes, either way.
  double odometry_yaw_sigma_deg = 2.0;
  // The frontend's heading drift as a rate (a gyro z bias its window does not settle drifts the
  // heading at a steady 0.01-0.04 deg/s on the simulated walks), so that what the revisits took
  // out goes on being taken out until the next one: between revisits the images do not see such a
  // drift (they track the map the last keyframes made), and the yaw prior holds the keyframes at
  // the frontend's heading. After each loop closure the rate is the least-squares slope over time
  // of the heading the loop closures and this rate added to the frontend's (Keyframe::loop_yaw)
  // over the keyframes of the last heading_drift_window_s; each new keyframe then starts turned by
  // rate * (its time since the one before) about the one before, and its yaw prior with it.
  // 0: off. The estimate is clamped to +-heading_drift_max_deg_s. On a draw of the noise where the
  // frontend's heading drifts 6-8 deg over a run, sequence 4's end of run 0.253 -> 0.041 m; on
  // Table II's draw level (splat/RESULTS.md, 2026-12-07, late).
  double heading_drift_window_s = 120;
  double heading_drift_max_deg_s = 0.1;
  // 6-DoF only: the frontend's tilt (roll, pitch) and the keyframe's starting height as a soft
  // prior on every optimised pose (vertical_prior), in every stage, the revisit alignment too.
  // The images hardly see them: without it sequence 1's rotation error came out 12.4 deg
  // (2026-12-04); 3-DoF poses hold all three fixed.
  double tilt_prior_sigma_deg = 0.5;
  double height_prior_sigma_m = 0.05;
  // ---- learning rates (Adam)
  double lr_pose_translation = 0.003;  // m
  double lr_pose_rotation = 0.004;     // rad
  // The map moves slower than the pose (RadarSplat's 1.6e-4 x scene scale, 2e-3 for a ~12 m room):
  // with Adam's normalised steps a faster map absorbs a keyframe's pose error into the Gaussians
  // instead of letting the images correct the pose. 0.005 before 2026-12-05 (splat/RESULTS.md,
  // "How fast the map moves": 0.002 lowers the mean APE published and at the end of the run, and
  // against a frontend that drifts keeps less of its drift).
  double lr_means = 0.002;             // m
  double lr_rotations = 1e-3;
  double lr_log_scales = 5e-3;
  double lr_log_returns = 0.03;
  // ---- revisit alignment (loop_closure.hpp; not in the paper). Before pose refinement, every
  // loop_every_keyframes keyframes that have earlier-pass keyframes (older than loop_min_age_s)
  // within loop_radius_m: the static CFAR points of the newest loop_query_keyframes keyframes
  // are matched against those of the loop_reference_keyframes nearest earlier-pass keyframes
  // (match_planar over +-loop.search_m, +-loop.search_deg). A match whose mean field value is at
  // least loop_min_score, at least loop_min_gain above that without correction, and whose
  // near-best candidates spread less than loop_max_spread_m / loop_max_spread_deg (a corridor's
  // along-track ambiguity does not pass) and that corrects by more than loop_min_correction_m or
  // loop_min_correction_deg becomes a loop constraint; close_loops spreads it over the keyframes
  // since the earlier pass, and each keyframe's Gaussians move with it.
  bool loop_closure = true;
  double loop_min_age_s = 30.0;
  double loop_radius_m = 5.0;
  int loop_query_keyframes = 10;
  int loop_reference_keyframes = 20;
  int loop_every_keyframes = 5;
  double loop_min_score = 0.25;
  double loop_min_gain = 0.05;
  double loop_max_spread_m = 0.15;
  double loop_max_spread_deg = 1.5;
  double loop_min_correction_m = 0.03;
  double loop_min_correction_deg = 0.2;
  // With loop_image_alignment the accepted match starts an alignment of the newest keyframe's RA
  // image against the earlier pass's Gaussians (pose-refinement iterations, no priors); it may
  // move the match's pose by at most this much, else the match is refused.
  double loop_max_refinement_m = 0.3;
  double loop_max_refinement_deg = 2.0;
  // The alignment's translation learning rate (m): the pose stage's iterations must be able to
  // cover loop_max_refinement_m (40 x 1 cm), where the stages' own lr_pose_translation is set
  // for steps of millimetres around a pose the frontend already gives to centimetres.
  double loop_lr_pose_translation = 0.01;
  // false: the constraint takes the point match's pose as it is (loop.refine_peak places it
  // between the grid's steps). true: the match starts the image alignment above
  // (align_to_earlier_pass), whose pose the constraint takes. The alignment does not hold a
  // revisit's heading better than the match: it stays near its start against the live map and
  // wanders by up to 0.9 deg against a frozen copy; without it Table II ends at a mean of
  // 0.037 m / 0.17 deg against 0.046 / 0.23 with it, and the other noise seeds level
  // (splat/RESULTS.md, "The loop constraint from the point match alone" and the entry after).
  bool loop_image_alignment = false;
  // What that alignment renders. false: the live map's Gaussians anchored to earlier-pass
  // keyframes. true: where the nearest earlier keyframe has been frozen, a frozen copy of them:
  // each keyframe's Gaussians copied when it is first loop_freeze_distance_m from the newest
  // keyframe and loop_min_age_s old (the pass that made it has left), and moved with it by later
  // loop closures. On the way back the current pass's mapping and BA (r_BA = 10 m reaches the
  // earlier pass before loop_radius_m does) fit the earlier pass's Gaussians to the drifted
  // poses, and the alignment then finds the drift agrees with the map (splat/RESULTS.md,
  // "Sequence 4's first 40 s"); the copy is the earlier pass's map as that pass left it. Costs a
  // second scene of at most max_gaussians.
  bool loop_frozen_reference = false;
  double loop_freeze_distance_m = 10.0;
  PlanarMatchOptions loop;
  // The pose graph that spreads an accepted match along the chain (loop_closure.hpp's
  // PoseGraphOptions: the odometry edges' and the loops' sigmas, the graph's keyframe bound).
  PoseGraphOptions loop_graph;
  // A revisit beyond loop_match's window: a frontend whose heading drifts by a few hundredths of
  // a degree a second comes back several degrees off after a loop of a few minutes, where the
  // window's best candidate lies on the window's edge or explains little of the points. When it
  // does (on the edge, or below loop_min_score) the match is tried once more over
  // +-loop_retry_search_m and +-loop_retry_search_deg (each at least the window's; both 0: off),
  // and what it finds goes through the same checks. Against a frontend drifting 0.03 deg/s
  // (rsrio-replay --odometry-drift) it closed the corridor rings' loops (sequence 3 0.61 ->
  // 0.19 m at the end of the run, sequence 4 0.65 -> 0.17 m); on the five sequences as they are
  // it retried 2-5 times each, accepted none, and left every trajectory the same to the last
  // digit. A wider window from the start instead found matches the narrow one refuses as
  // ambiguous and made sequence 2 worse (splat/RESULTS.md). About 0.3 s a retry (the window's
  // 14 times: rsrio-splat-bench), on the BA thread.
  double loop_retry_search_m = 2.0;
  double loop_retry_search_deg = 12.0;
  // ---- scene
  int max_gaussians = 100'000;
  // Keyframes whose images are kept (about 160 kB each on the cascade): beyond it the images of
  // the keyframe farthest from the newest are dropped (its pose stays, for the odometry prior
  // and the trajectory; it takes no part in the windows any more). The newest mapping_keyframes /
  // ba_max_keyframes are never dropped. 500 keyframes cover ~200 m of path at 0.4 m spacing.
  int max_keyframe_images = 500;
  // Keyframes whose static CFAR points are kept (the revisit alignment's earlier pass; a few
  // hundred bytes each): beyond it those of the farthest are dropped, as the images are. 5000
  // keyframes are 2 km of path, about what max_gaussians covers: an older pass has no Gaussians
  // left to align against.
  int max_keyframe_points = 5000;
  // Keyframes kept at all: beyond it the oldest that hold neither images nor points (a pose, 448
  // bytes, that no stage and no revisit uses any more) are dropped, a tenth of the cap at a time.
  // Their Gaussians stay in the map (loop closures no longer move them), their loops leave the
  // pose graph, and the end-of-run trajectory (revised()) takes a dropped stretch's frames from the
  // keyframe before it. 6000 keyframes are 2.4 km of path at 0.4 m; the keyframe after a dropped
  // one starts a new chain (Keyframe::chain_start).
  int max_keyframes = 6000;
  double init_scale_m = 0.1;
  double init_min_spacing_m = 0.1;     // a CFAR point this near an existing Gaussian adds none
  double static_doppler_tolerance_mps = 0.3;  // points moving relative to the world add none
  double min_point_snr_db = 0;
};

/// Reads the `backend:` section (every key optional, defaults above); strict: unknown keys,
/// wrong types and out-of-range values throw ConfigError naming the key.
///   body_T_radar: {translation_m: [x, y, z], rpy_deg: [roll, pitch, yaw]}
///   pose / mapping / ba: {max_iterations, time_budget_s, convergence_rel, convergence_patience,
///                         lr_final_factor}
BackendOptions load_backend_options(OptionsNode node);
void validate(const BackendOptions& options, const std::string& file = "<built-in>");
/// The options as a `backend:` YAML section (what programs print at start-up; loadable again).
void print(std::ostream& out, const BackendOptions& options);

/// What the backend takes from the frontend's options: the extrinsic, and the DSP's windows as
/// the point spread it renders with. Every program that runs the backend behind the odometry
/// calls this (rsrio-replay, rsriod).
void take_frontend_options(BackendOptions& backend, const rio::OdometryOptions& odometry);

/// Keyframe selection: a frame `dt` seconds and `last_T_frame` (body motion) after the last
/// keyframe becomes one when any of the options' thresholds is reached. The backend decides with
/// it; the daemon's RIO thread uses it to hand over only the frames the backend will take.
bool keyframe_due(const BackendOptions& options, double dt, const Eigen::Isometry3d& last_T_frame);

struct BackendFrame {
  double t = 0;                         // s, radar clock
  gtsam::Pose3 odom_T_body;             // the frontend's world_T_body (IMU frame) at t
  const rsrio::DspResult* dsp = nullptr;  // ra, rd, points of the frame; read during add_frame only
};

struct StageStats {
  std::uint64_t runs = 0;
  std::uint64_t iterations = 0;
  std::uint64_t converged = 0;       // runs stopped by the convergence test
  std::uint64_t budget_stops = 0;    // runs stopped by the time budget
  double total_s = 0, last_s = 0, max_s = 0;
  double last_initial_loss = 0, last_final_loss = 0;
};

struct BackendStats {
  std::uint64_t frames = 0;
  std::uint64_t rejected_frames = 0;  // bad input (null DSP, wrong image size, non-finite pose, time)
  std::uint64_t keyframes = 0;
  std::uint64_t nan_guard_hits = 0;   // skipped steps + restored poses + non-finite Gaussians removed
  std::uint64_t gaussians_added = 0;
  std::uint64_t points_rejected_dynamic = 0;
  std::uint64_t keyframe_images_evicted = 0;  // keyframes whose images were dropped (max_keyframe_images)
  std::uint64_t keyframe_points_evicted = 0;  // keyframes whose static points were dropped (max_keyframe_points)
  std::uint64_t keyframes_dropped = 0;        // keyframes dropped altogether (max_keyframes)
  // occlusion_threshold: keyframe RA columns with an occluder, and the pixels beyond it left out.
  std::uint64_t occluded_columns = 0, occluded_pixels = 0;
  // Revisit alignment: matches tried, loops closed, and matches refused (each reason counted).
  std::uint64_t loop_attempts = 0, loop_closures = 0;
  std::uint64_t loop_rejected_score = 0, loop_rejected_ambiguous = 0, loop_below_threshold = 0;
  std::uint64_t loop_rejected_refinement = 0;  // the image alignment moved the match too far, or the graph failed
  std::uint64_t loop_retries = 0;  // matches tried again over the wider window (loop_retry_search_*)
  std::size_t gaussians = 0;
  std::size_t reference_gaussians = 0;  // loop_frozen_reference's copy
  std::uint64_t loop_frozen_alignments = 0;  // revisit alignments that drew the copy
  // heading_drift_window_s: the frontend's heading drift rate as last estimated, and how often.
  double heading_drift_deg_s = 0;
  std::uint64_t heading_drift_updates = 0;
  double rd_gain = 0;
  StageStats pose, mapping, ba;
  StageStats final_ba;        // Backend::finish
  StageStats loop_alignment;  // the revisit's image alignment against the earlier pass's map
};

/// One keyframe as the backend holds it.
struct Keyframe {
  double t = 0;
  Eigen::Isometry3d odom_T_body = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d world_T_radar = Eigen::Isometry3d::Identity();  // map frame, optimised
  Eigen::Vector3d velocity_correction = Eigen::Vector3d::Zero();    // the constant of the header
  Image<float> ra, rd;                          // measured, linear
  Image<float> ra_target, rd_target;            // compressed (ImageLoss::prepare_measurement)
  std::vector<Eigen::Vector3f> points;          // static CFAR points, radar frame (revisit alignment)
  // Per azimuth column, the range rows [0, n) that take part in the losses (occlusion_rows);
  // empty: all. Goes with the images.
  std::vector<int> visible_rows;
  // The heading that loop closures (and the drift rate carried forward since: heading_drift_window_s)
  // added to the frontend's at this keyframe: the yaw prior's reference is the frontend's heading
  // plus it (a loop correction is not undone by the prior).
  double loop_yaw = 0;
  double z_reference = 0;  // the height it started at (the 6-DoF vertical prior's)
  // The keyframe before it was dropped (max_keyframes), or it is the first: its RD velocity is
  // velocity_correction alone (frozen at what it was), and no odometry pair prior ties it to the
  // keyframe now before it.
  bool chain_start = false;
  bool reference_frozen = false;  // its Gaussians are in the revisit alignment's frozen copy
  bool has_images() const { return ra.size() > 0; }  // false once evicted (max_keyframe_images)
};

/// The images of one keyframe rendered from the current map (for pictures and checks).
struct KeyframeRender {
  // Linear. The RA pair as the RA loss compares them: 0 beyond the keyframe's occluders
  // (BackendOptions::occlusion_threshold); the RD rendered from the whole RA.
  Image<float> ra_measured, ra_rendered, rd_measured, rd_rendered;
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
};

/// The loss of one keyframe's images for a pose, with gradients: what every stage sums. Scalar:
/// float in the backend, double for the finite-difference tests.
template <typename Scalar>
class KeyframeObjective {
 public:
  /// rd_image_gradient false: the RD loss moves the velocity only, not the RA image it is
  /// rendered from (BackendOptions::rd_image_gradient).
  KeyframeObjective(const RadarImageGrid& grid, const RaRenderOptions& ra_options, const RdRenderOptions& rd_options,
                    const ImageLossOptions& ra_loss, const ImageLossOptions& rd_loss, bool rd_image_gradient = true);

  struct Result {
    double ra_loss = 0, rd_loss = 0;
  };
  /// RA loss (+ rd_weight x RD loss when rd_weight > 0 and velocity is not null) of the listed
  /// Gaussians seen from radar_T_world against the compressed targets. ADDS gradients into
  /// scene_gradients (may be null), grad_pose (left increment of radar_T_world, may be null) and
  /// grad_velocity (may be null). `directions`: the pixels' directions for the RD rendering
  /// (RaRenderer::render_directions, held constant; null: elevation 0). `visible_rows` (per
  /// azimuth column, occlusion_rows; empty: all): the RA loss compares the rendered RA set to 0
  /// from that row on (ra_target must be 0 there too: zero_occluded), so what lies beyond moves
  /// nothing through it; the RD is rendered from the whole RA.
  Result evaluate(const GaussianScene& scene, std::span<const std::uint32_t> gaussians,
                  const Eigen::Isometry3d& radar_T_world, const Eigen::Vector3d* velocity,
                  const Image<Scalar>& ra_target, const Image<Scalar>& rd_target, double ra_weight, double rd_weight,
                  SceneGradients* scene_gradients, Vector6d* grad_pose, Eigen::Vector3d* grad_velocity,
                  const PixelDirections<Scalar>* directions = nullptr, std::span<const int> visible_rows = {});

  const RaRenderer<Scalar>& ra_renderer() const { return ra_renderer_; }
  RdRenderer<Scalar>& rd_renderer() { return rd_renderer_; }
  ImageLoss<Scalar>& ra_loss() { return ra_loss_; }
  ImageLoss<Scalar>& rd_loss() { return rd_loss_; }

 private:
  RaRenderer<Scalar> ra_renderer_;
  RdRenderer<Scalar> rd_renderer_;
  ImageLoss<Scalar> ra_loss_, rd_loss_;
  bool rd_image_gradient_;
  Image<Scalar> ra_, ra_visible_, rd_, grad_ra_, grad_rd_;
};

extern template class KeyframeObjective<float>;
extern template class KeyframeObjective<double>;

/// The RD velocity of the header: v_pair(current, previous, dt) + correction, with the Jacobians
/// of v_pair (the correction is constant).
RadarVelocity keyframe_velocity(const Eigen::Isometry3d& radar_T_world_current,
                                const Eigen::Isometry3d& radar_T_world_previous, double dt,
                                const Eigen::Vector3d& correction);

/// Pose refinement's targets on what the map explains (pose_coverage_mask): a pixel of ra_target
/// farther than `margin` bins (range and azimuth) from every pixel of the compressed rendered RA
/// above `knee` takes the rendered value; a range row of rd_target with no covered RA pixel takes
/// the rendered RD row. Throws std::invalid_argument for images of different sizes.
void mask_uncovered(const Image<float>& ra_rendered_compressed, const Image<float>& rd_rendered_compressed, double knee,
                    int margin, Image<float>& ra_target, Image<float>& rd_target);

/// The occlusion mask of a measured RA (BackendOptions::occlusion_threshold): for each azimuth
/// column, the number of range rows that take part, from row 0. The first row from `first_row` on
/// whose compressed power is >= threshold and whose linear power is within row_db of the
/// strongest of its range row (from first_row on) is the occluder; the rows up to margin_rows
/// beyond it stay. A column without one keeps every row. Throws std::invalid_argument for
/// images of different sizes.
std::vector<int> occlusion_rows(const Image<float>& ra_linear, const Image<float>& ra_compressed, double threshold,
                                double row_db, int first_row, int margin_rows);

/// Sets the pixels of each column from row visible_rows[column] on to 0 (all rows if
/// visible_rows is empty: nothing changes).
template <typename Scalar>
void zero_occluded(Image<Scalar>& image, std::span<const int> visible_rows);

/// The BA window of the paper's radius option for the newest (last) of `positions`, the keyframes'
/// radar positions in time order: the indices of those within radius_m of it, at most `cap` of
/// them (then the newest half and the older ones nearest to it, which on a revisit are the
/// earlier pass's keyframes). Sorted ascending; the newest is always in it.
std::vector<std::size_t> radius_window(std::span<const Eigen::Vector3d> positions, double radius_m, std::size_t cap);

/// What turns a frontend pose (odom_T_body) into a corrected one, as of one keyframe: map_T_odom
/// (REP-105's map -> odom) and, on a level floor (BackendOptions::level_floor), the keyframe's
/// height. A value the BA thread hands to the publisher: no allocation.
struct OdomCorrection {
  Eigen::Isometry3d map_T_odom = Eigen::Isometry3d::Identity();
  bool hold_height = false;                                   // level_floor
  Eigen::Vector3d keyframe_odom_position = Eigen::Vector3d::Zero();  // the keyframe's body origin in odom

  /// map_T_odom * odom_T_body; with hold_height, minus the vertical (map z) part of the frontend's
  /// motion since the keyframe, so that the body stays at the keyframe's height.
  Eigen::Isometry3d apply(const Eigen::Isometry3d& odom_T_body) const;
};

class Backend {
 public:
  /// Throws std::invalid_argument when the grids are not those of `config` (sizes and steps) or
  /// ConfigError (via validate) for unusable options.
  Backend(const RadarConfig& config, const rsrio::DspGrids& grids, const BackendOptions& options);
  ~Backend();
  Backend(const Backend&) = delete;
  Backend& operator=(const Backend&) = delete;

  /// Feeds one frame (in time order). Returns true when it became a keyframe and was optimised.
  /// The first frame is never a keyframe (a keyframe needs the frontend's velocity, from its
  /// predecessor frame). A bad frame is counted (stats().rejected_frames) and ignored.
  bool add_frame(const BackendFrame& frame);
  /// The frame just before the next add_frame() one, pose only: a caller that passes only
  /// keyframe candidates (the daemon) gives their predecessors this way, for the frontend's
  /// velocity at the candidate. Non-finite input is counted as rejected and ignored.
  void add_predecessor(double t, const gtsam::Pose3& odom_T_body);
  /// A flag another thread may set to end the running stages early (shutdown); null: none. The
  /// keyframe being optimised keeps the iterations it has made.
  void set_cancel_flag(const std::atomic<bool>* cancel) { cancel_ = cancel; }

  /// Every keyframe's frontend pose replaced by odom_at(its t) where that gives one (the frontend's
  /// whole run solved as one batch: rio::RioFrontend::smooth_whole_run), so that the end-of-run BA's
  /// odometry priors (relative motion; 6-DoF: the tilt) and revised() follow it. The keyframes'
  /// map poses keep their heading and position and take the new odometry's roll and pitch, and the
  /// yaw prior's reference (the odometry's heading plus Keyframe::loop_yaw) keeps its heading.
  /// Before finish(); not causal. Returns the keyframes whose pose was replaced.
  std::size_t replace_odometry(const std::function<std::optional<gtsam::Pose3>(double t)>& odom_at);
  /// The end-of-run BA (options().final_ba; nothing when its max_iterations is 0). Call once the
  /// last frame is in; later frames are still accepted, but the windows then start from its map.
  void finish();

  gtsam::Pose3 map_T_odom() const;
  /// As of the newest keyframe (identity before the first).
  const OdomCorrection& correction() const { return correction_; }
  /// correction().apply(odom_T_body): map_T_odom * odom_T_body, at the newest keyframe's height on
  /// a level floor.
  gtsam::Pose3 corrected(const gtsam::Pose3& odom_T_body) const;
  const BackendStats& stats() const;
  /// (t, map_T_body) of every keyframe, refined.
  std::vector<std::pair<double, gtsam::Pose3>> keyframe_poses() const;
  /// The pose of the frame at time t (frontend pose odom_T_body) as the map has it NOW, not as it
  /// was published: the refined pose of the last keyframe at or before t (the first keyframe for
  /// earlier frames; the keyframe before a stretch that max_keyframes dropped for the frames in it)
  /// composed with the frontend's motion since that keyframe (on a level floor
  /// without its vertical part, as corrected()). Later BA and loop
  /// closures move it; for frames after the newest keyframe it is corrected(). Without keyframes:
  /// odom_T_body. The end-of-run trajectory (rsrio-replay's estimate_final.tum), not causal.
  gtsam::Pose3 revised(double t, const gtsam::Pose3& odom_T_body) const;
  /// The body pose at time t (map frame) if the rig keeps the motion of the two newest keyframes
  /// (extrapolate_planar of their refined radar poses); one keyframe: its pose; none: the origin.
  /// The pipeline's poses come from the frontend; this is the motion model of the paper's `no
  /// frontend` ablation (rsrio-replay --backend-poses constant-velocity feeds
  /// map_T_odom()^-1 predicted(t) as each frame's odom_T_body, so a keyframe starts at the
  /// prediction and corrected() publishes it).
  gtsam::Pose3 predicted(double t) const;

  // ---- inspection (tests, pictures, benchmarks)
  const BackendOptions& options() const { return options_; }
  /// The grid the backend renders on: the DSP's, cut at options().max_image_range_m.
  const RadarImageGrid& grid() const { return grid_; }
  const GaussianScene& scene() const { return scene_; }
  const std::vector<Keyframe>& keyframes() const { return keyframes_; }
  /// Measured and rendered RA / RD of keyframe k (index into keyframes()); std::out_of_range for
  /// a keyframe without images (evicted).
  KeyframeRender render_keyframe(std::size_t k);

 private:
  bool accept(const BackendFrame& frame) const;
  bool is_keyframe(double t, const Eigen::Isometry3d& odom_T_body) const;
  void start_map(Keyframe& first);
  /// New Gaussians from keyframe k's static points (anchored to k).
  void add_gaussians(std::size_t k, std::span<const rsrio::DspPoint> points, const Eigen::Vector3d& velocity);
  /// The stages: `poses` = keyframes whose pose is optimised, `views` = keyframes rendered.
  /// `drawable` (per Gaussian, may be null: all) limits what the views draw; `priors` false
  /// leaves the odometry priors out (the revisit's alignment against the earlier pass's map);
  /// `lr_pose_translation` replaces the options' rate (the alignment's).
  void run_stage(const std::vector<std::size_t>& views, const std::vector<std::size_t>& poses, bool optimise_scene,
                 bool use_rd, const StageOptions& stage, int max_iterations, StageStats& stats,
                 const std::vector<char>* drawable = nullptr, bool priors = true,
                 std::optional<double> lr_pose_translation = std::nullopt);
  std::vector<std::size_t> ba_window() const;
  /// The odometry prior of every consecutive keyframe pair with an optimised pose: its loss, and
  /// its gradients added to grad_left (rows of pose_row).
  double odometry_prior(const std::vector<std::size_t>& poses, const std::vector<int>& pose_row,
                        std::vector<Vector6d>& grad_left) const;
  Eigen::Vector3d velocity_of(std::size_t k, RadarVelocity* jacobians) const;
  void cleanup_scene();
  void evict_keyframe_data();
  /// max_keyframes: drops the oldest bare keyframes and renumbers the anchors and loops.
  void drop_bare_keyframes();
  /// The newest keyframe's targets for pose refinement (pose_coverage_mask): where the map renders
  /// nothing near, the rendered image itself.
  void mask_uncovered_targets(std::size_t k, const std::vector<char>* drawable = nullptr);
  KeyframeRender render_keyframe(std::size_t k, const std::vector<char>* drawable);
  void update_correction();
  // The correction as of keyframe k: its refined pose composed with the frontend's motion since.
  OdomCorrection correction_at(const Keyframe& k) const;
  /// Revisit alignment of the newest keyframe k (options' loop_*): match, and when accepted, a
  /// loop constraint, the pose graph, and the keyframes and their Gaussians moved.
  void align_revisit(std::size_t k);
  /// heading_drift_window_s: the frontend's heading drift rate from the keyframes' loop_yaw after
  /// a loop closure (stats().heading_drift_deg_s).
  void estimate_heading_drift();
  /// The revisit's image alignment (loop_image_alignment): keyframe k's pose from its RA image
  /// against the earlier pass's Gaussians (the frozen copy where `nearest` is frozen), started at
  /// `start`; the keyframe itself is left as it was.
  Eigen::Isometry3d align_to_earlier_pass(std::size_t k, const Eigen::Isometry3d& start, std::size_t nearest);
  /// The scene's structure changed: the optimiser's state and the anchors follow.
  void remap_scene(const SceneRemap& remap);
  /// loop_frozen_reference: copies the Gaussians of the keyframes that have just been left
  /// (loop_freeze_distance_m, loop_min_age_s) into reference_ (capped as the scene, around the
  /// newest keyframe).
  void freeze_reference();

  BackendOptions options_;
  RadarImageGrid grid_;                // the DSP's grid, cut at max_image_range_m
  int dsp_range_bins_ = 0;             // the DSP's images have this many rows
  RaRenderOptions ra_options_;
  RdRenderOptions rd_options_;
  ImageLossOptions ra_loss_options_, rd_loss_options_;
  std::unique_ptr<KeyframeObjective<float>> objective_;
  GaussianScene scene_;
  SplatAdam scene_adam_;
  std::vector<Keyframe> keyframes_;
  std::vector<std::int32_t> anchors_;  // per Gaussian: the keyframe that created it (loop corrections move it with it)
  std::vector<LoopConstraint> loops_;
  GaussianScene reference_;                       // loop_frozen_reference: the frozen copy
  std::vector<std::int32_t> reference_anchors_;  // per Gaussian of reference_: its keyframe
  std::size_t last_loop_attempt_ = 0;
  double floor_z_ = 0;  // the first keyframe's radar height (level_floor)
  double heading_drift_rate_ = 0;  // rad/s, heading_drift_window_s's estimate
  OdomCorrection correction_;
  BackendStats stats_;
  // The previous frame (for the frontend's instantaneous velocity).
  bool have_previous_ = false;
  double previous_t_ = 0;
  Eigen::Isometry3d previous_odom_T_body_ = Eigen::Isometry3d::Identity();
  const std::atomic<bool>* cancel_ = nullptr;
  // Scratch.
  SceneGradients gradients_;
  std::vector<PixelDirections<float>> directions_;  // per view of the running stage
};

}  // namespace rsrio::splat

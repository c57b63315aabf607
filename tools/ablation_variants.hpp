// The backend configurations of rsrio-eval --ablation (paper Tables III and IV), apart from the
// program so that tools/tests/ablation_variants_test.cpp loads each through the backend's own
// options loader: a variant whose options the replay refuses is found by the tests, not an hour
// into an ablation.
#pragma once

#include <array>

namespace rsrio::ablation {

// A backend configuration of the ablations (paper Tables III and IV): YAML lines appended under
// `backend:` to the pipeline options, or no backend at all.
struct Variant {
  const char* key;      // output directory suffix
  const char* label;
  const char* backend;  // none | ba
  const char* overrides;
  const char* paper;    // the paper's APE t / r (Tables III, IV), or why there is none
  const char* replay_option = nullptr;  // one more rsrio-replay option, or none
};
inline constexpr Variant kFull{"replay", "full (r_BA = 10 m, RA + RD, priors, level floor, loops)", "ba", "",
                               "[0.93 / 3.03]  (no prior, z from its frontend)"};
inline constexpr std::array<Variant, 16> kAblations{{
    {"ablation_noba", "no BA (pose refinement + mapping only)", "ba", "  ba: {max_iterations: 0}\n", "[2.83 / 8.23]"},
    {"ablation_r1", "r_BA = 1 m", "ba", "  ba_radius_m: 1.0\n", "[3.12 / 7.98]"},
    {"ablation_r5", "r_BA = 5 m", "ba", "  ba_radius_m: 5.0\n", "[1.07 / 3.24]"},
    {"ablation_n2", "sliding N = 2", "ba", "  ba_window: sliding\n  ba_sliding_keyframes: 2\n", "[2.83 / 8.23]"},
    {"ablation_n5", "sliding N = 5", "ba", "  ba_window: sliding\n  ba_sliding_keyframes: 5\n", "[1.42 / 3.95]"},
    {"ablation_n10", "sliding N = 10", "ba", "  ba_window: sliding\n  ba_sliding_keyframes: 10\n", "[1.17 / 3.61]"},
    {"ablation_ninf", "sliding N = inf (every keyframe)", "ba",
     "  ba_window: sliding\n  ba_sliding_keyframes: 1000\n  ba_max_keyframes: 1000\n  max_keyframe_images: 100000\n"
     "  max_keyframe_points: 100000\n  max_keyframes: 200000\n",
     "[1.36 / 4.03]"},
    {"ablation_nord", "without the RD loss", "ba", "  rd_loss: false\n", "[3.41 / 3.57]"},
    {"ablation_rdvelocity", "RD loss through the velocity only (rd_image_gradient: false)", "ba",
     "  rd_image_gradient: false\n", "[-]  not in the paper"},
    {"ablation_noprior", "without the odometry prior (the paper's losses only)", "ba", "  odometry_prior: false\n",
     "[-]  not in the paper"},
    {"ablation_frontendz", "z from the frontend (level_floor: false)", "ba", "  level_floor: false\n",
     "[-]  not in the paper"},
    {"ablation_rddirections", "RD Doppler from the Gaussians' directions (rd_gaussian_directions: true)", "ba",
     "  rd_gaussian_directions: true\n", "[-]  the paper's per-Gaussian -r^T v"},
    // The shipped scenarios' two-way elevation beam (30 deg), rounded:
    // rsrio::sim::RadarModelOptions::elevation_power_sigma_sin() (0.1566).
    {"ablation_rdbeam", "RD Doppler over the elevation beam (rd_elevation_sigma_sin: 0.157)", "ba",
     "  rd_elevation_sigma_sin: 0.157\n", "[-]  not in the paper"},
    {"ablation_noloop", "without revisit alignment (loop_closure: false)", "ba", "  loop_closure: false\n",
     "[-]  the paper has none"},
    {"ablation_nobackend", "backend off (frontend only)", "none", "", "[10.99 / 18.42]"},
    // The backend alone: every frame a keyframe (keyframe_time_s below the frame period), each
    // starting from the backend's own constant-velocity prediction, and no frontend motion to be
    // a prior. At the frontend's keyframe spacing (0.4 m) the prediction starts the walk 0.4 m
    // off, beyond the image loss's basin, and sequence 1 ended 11 m off.
    {"ablation_nofrontend", "no frontend (the backend tracks every frame alone)", "ba",
     "  odometry_prior: false\n  keyframe_time_s: 0.05\n", "[18.27 / 25.91]", "--backend-poses=constant-velocity"},
}};

}  // namespace rsrio::ablation

// Adam (Kingma & Ba) with bias correction, per parameter block, and the NaN guard.
//
// AdamBlock: the state of one block of parameters laid out in rows of `stride` values (all
// Gaussian means: stride 3; the poses of a window: stride 3 planar or 6 se(3)). Each row has its
// own step count, so rows that appear later (densification, new keyframes) start with fresh,
// correctly bias-corrected moments, and a step may update only some rows (the Gaussians near the
// keyframes being optimised) without decaying the others' moments.
//
// SplatAdam: the five groups of the paper's optimisation (means, rotations, log-scales,
// log-returns, poses), each with its learning rate (poses: separate rates for translation and
// rotation), the view returns' when they are trained (lr_view_returns > 0), and the NaN guard: a step whose gradient has any non-finite value changes nothing
// and is counted (skipped()).
//
// Pose parameters: for planar poses the parameters are (x, y, yaw) themselves. For 6-DoF poses
// they are the left increments delta = (rho, omega) (pose.hpp) held at zero: after step() apply
// apply_left_increment(T, delta) and zero delta again (MonoGS); the moments persist.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "rsrio/splat/gaussian_scene.hpp"

namespace rsrio::splat {

struct AdamOptions {
  double beta1 = 0.9;
  double beta2 = 0.999;
  double epsilon = 1e-15;  // gsplat / RadarSplat
};

class AdamBlock {
 public:
  AdamBlock(std::size_t stride, double learning_rate);

  std::size_t stride() const { return stride_; }
  std::size_t rows() const { return steps_.size(); }
  double learning_rate() const { return learning_rate_; }
  void set_learning_rate(double lr) { learning_rate_ = lr; }
  /// Per-component multipliers of the learning rate (size stride; default all 1).
  void set_component_scale(std::vector<double> scale);

  /// New rows (if growing) start fresh; dropped rows are forgotten.
  void resize(std::size_t rows);
  /// Follows a scene structure change: row i takes the state of row origin[i] (fresh if -1).
  void remap(const SceneRemap& origin);
  void reset();

  /// One step on the listed rows (all rows when `rows` is empty). params and grads hold
  /// rows() * stride() values; the state grows to cover the rows if needed.
  void step(std::span<double> params, std::span<const double> grads, std::span<const std::uint32_t> rows,
            const AdamOptions& options);

 private:
  void step_row(std::size_t row, double* params, const double* grads, const AdamOptions& options);

  std::size_t stride_;
  double learning_rate_;
  std::vector<double> component_scale_;
  std::vector<double> m_, v_;
  std::vector<std::uint32_t> steps_;
};

struct SplatAdamOptions {
  AdamOptions adam;
  double lr_means = 2e-3;            // m (RadarSplat: 1.6e-4 x scene scale; 2e-3 for ~12 m rooms)
  double lr_rotations = 1e-3;
  double lr_log_scales = 5e-3;
  double lr_log_returns = 5e-2;
  double lr_view_returns = 0;        // 0: the view returns are not stepped (isotropic returns)
  double lr_pose_translation = 5e-3; // m
  double lr_pose_rotation = 2e-3;    // rad
};

class SplatAdam {
 public:
  /// pose_stride: 3 for planar (x, y, yaw), 6 for se(3) left increments (rho, omega).
  explicit SplatAdam(const SplatAdamOptions& options = {}, std::size_t pose_stride = 3);

  struct Step {
    GaussianScene* scene = nullptr;                   // null: the scene is held fixed
    const SceneGradients* scene_gradients = nullptr;
    std::span<const std::uint32_t> gaussians;         // rows to update; empty: all
    std::span<double> poses;                          // pose_stride values per pose; empty: none
    std::span<const double> pose_gradients;
    std::span<const std::uint32_t> pose_rows;         // poses to update; empty: all
  };

  /// The NaN guard, then one Adam step. Returns false (and counts) when a gradient that would
  /// be used is not finite; nothing is changed then. Updated log-scales, log-returns and view
  /// returns are clamped into the scene's bounds.
  bool step(const Step& step);

  /// After a structure change of the scene.
  void remap_scene(const SceneRemap& origin);

  std::uint64_t steps() const { return steps_; }
  std::uint64_t skipped() const { return skipped_; }
  const SplatAdamOptions& options() const { return options_; }

  AdamBlock means{3, 0};
  AdamBlock rotations{4, 0};
  AdamBlock log_scales{3, 0};
  AdamBlock log_returns{1, 0};
  AdamBlock view_returns{kViewTerms, 0};
  AdamBlock poses{3, 0};

 private:
  SplatAdamOptions options_;
  std::uint64_t steps_ = 0;
  std::uint64_t skipped_ = 0;
};

}  // namespace rsrio::splat

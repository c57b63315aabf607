#include "rsrio/splat/adam.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rsrio::splat {

AdamBlock::AdamBlock(std::size_t stride, double learning_rate)
    : stride_(stride), learning_rate_(learning_rate), component_scale_(stride, 1.0) {
  if (stride == 0) throw std::invalid_argument("AdamBlock: stride must be positive");
}

void AdamBlock::set_component_scale(std::vector<double> scale) {
  if (scale.size() != stride_) throw std::invalid_argument("AdamBlock: component scale must have stride values");
  component_scale_ = std::move(scale);
}

void AdamBlock::resize(std::size_t rows) {
  m_.resize(rows * stride_, 0.0);
  v_.resize(rows * stride_, 0.0);
  steps_.resize(rows, 0);
}

void AdamBlock::remap(const SceneRemap& origin) {
  std::vector<double> m(origin.size() * stride_, 0.0), v(origin.size() * stride_, 0.0);
  std::vector<std::uint32_t> t(origin.size(), 0);
  for (std::size_t i = 0; i < origin.size(); ++i) {
    const std::int32_t o = origin[i];
    if (o < 0 || static_cast<std::size_t>(o) >= steps_.size()) continue;
    std::copy_n(&m_[static_cast<std::size_t>(o) * stride_], stride_, &m[i * stride_]);
    std::copy_n(&v_[static_cast<std::size_t>(o) * stride_], stride_, &v[i * stride_]);
    t[i] = steps_[static_cast<std::size_t>(o)];
  }
  m_ = std::move(m);
  v_ = std::move(v);
  steps_ = std::move(t);
}

void AdamBlock::reset() {
  std::fill(m_.begin(), m_.end(), 0.0);
  std::fill(v_.begin(), v_.end(), 0.0);
  std::fill(steps_.begin(), steps_.end(), 0u);
}

void AdamBlock::step_row(std::size_t row, double* params, const double* grads, const AdamOptions& o) {
  const std::uint32_t t = ++steps_[row];
  const double bc1 = 1.0 - std::pow(o.beta1, t);
  const double bc2 = 1.0 - std::pow(o.beta2, t);
  const double step_size = learning_rate_ / bc1;
  const double inv_sqrt_bc2 = 1.0 / std::sqrt(bc2);
  double* m = &m_[row * stride_];
  double* v = &v_[row * stride_];
  for (std::size_t c = 0; c < stride_; ++c) {
    const double g = grads[c];
    m[c] = o.beta1 * m[c] + (1 - o.beta1) * g;
    v[c] = o.beta2 * v[c] + (1 - o.beta2) * g * g;
    params[c] -= component_scale_[c] * step_size * m[c] / (std::sqrt(v[c]) * inv_sqrt_bc2 + o.epsilon);
  }
}

void AdamBlock::step(std::span<double> params, std::span<const double> grads, std::span<const std::uint32_t> rows,
                     const AdamOptions& options) {
  if (params.size() != grads.size() || params.size() % stride_ != 0)
    throw std::invalid_argument("AdamBlock::step: params and grads must hold rows * stride values");
  const std::size_t n = params.size() / stride_;
  if (steps_.size() < n) resize(n);
  if (rows.empty()) {
    for (std::size_t r = 0; r < n; ++r) step_row(r, &params[r * stride_], &grads[r * stride_], options);
    return;
  }
  for (const std::uint32_t r : rows)
    if (r < n) step_row(r, &params[r * stride_], &grads[r * stride_], options);
}

// ---------------------------------------------------------------------------------------------
SplatAdam::SplatAdam(const SplatAdamOptions& options, std::size_t pose_stride)
    : means(3, options.lr_means),
      rotations(4, options.lr_rotations),
      log_scales(3, options.lr_log_scales),
      log_returns(1, options.lr_log_returns),
      view_returns(kViewTerms, options.lr_view_returns),
      poses(pose_stride, 1.0),
      options_(options) {
  if (pose_stride == 3) {
    poses.set_component_scale({options.lr_pose_translation, options.lr_pose_translation, options.lr_pose_rotation});
  } else if (pose_stride == 6) {
    const double t = options.lr_pose_translation, r = options.lr_pose_rotation;
    poses.set_component_scale({t, t, t, r, r, r});
  } else {
    throw std::invalid_argument("SplatAdam: pose_stride must be 3 (planar) or 6 (se(3))");
  }
}

namespace {

bool finite_rows(std::span<const double> values, std::size_t stride, std::span<const std::uint32_t> rows) {
  if (rows.empty())
    return std::all_of(values.begin(), values.end(), [](double v) { return std::isfinite(v); });
  const std::size_t n = values.size() / stride;
  for (const std::uint32_t r : rows) {
    if (r >= n) continue;
    for (std::size_t c = 0; c < stride; ++c)
      if (!std::isfinite(values[r * stride + c])) return false;
  }
  return true;
}

}  // namespace

bool SplatAdam::step(const Step& s) {
  const bool scene_on = s.scene != nullptr && s.scene_gradients != nullptr;
  if (scene_on && s.scene_gradients->size() != s.scene->size())
    throw std::invalid_argument("SplatAdam::step: gradients are not sized to the scene");
  if (s.poses.size() != s.pose_gradients.size())
    throw std::invalid_argument("SplatAdam::step: pose parameters and gradients differ in size");
  const bool view = view_returns.learning_rate() > 0;
  if (scene_on && view &&
      (!s.scene->has_view_returns() || s.scene_gradients->view_returns.size() != kViewTerms * s.scene->size()))
    throw std::invalid_argument("SplatAdam::step: lr_view_returns > 0 for a scene or gradients without view returns");
  // ---- NaN guard: every gradient this step would use.
  bool finite = finite_rows(s.pose_gradients, poses.stride(), s.pose_rows);
  if (scene_on && finite) {
    const SceneGradients& g = *s.scene_gradients;
    finite = finite_rows(g.means, 3, s.gaussians) && finite_rows(g.rotations, 4, s.gaussians) &&
             finite_rows(g.log_scales, 3, s.gaussians) && finite_rows(g.log_returns, 1, s.gaussians) &&
             (!view || finite_rows(g.view_returns, kViewTerms, s.gaussians));
  }
  if (!finite) {
    ++skipped_;
    return false;
  }
  ++steps_;
  const AdamOptions& o = options_.adam;
  if (!s.poses.empty()) poses.step(s.poses, s.pose_gradients, s.pose_rows, o);
  if (!scene_on) return true;
  GaussianScene& scene = *s.scene;
  const SceneGradients& g = *s.scene_gradients;
  means.step(scene.mutable_means(), g.means, s.gaussians, o);
  rotations.step(scene.mutable_rotations(), g.rotations, s.gaussians, o);
  log_scales.step(scene.mutable_log_scales(), g.log_scales, s.gaussians, o);
  log_returns.step(scene.mutable_log_returns(), g.log_returns, s.gaussians, o);
  if (view) view_returns.step(scene.mutable_view_returns(), g.view_returns, s.gaussians, o);
  // Keep exp() of the updated values finite (the full check is GaussianScene::sanitize()).
  const SceneOptions& so = scene.options();
  auto ls = scene.mutable_log_scales();
  auto lr = scene.mutable_log_returns();
  auto vr = scene.mutable_view_returns();
  auto clamp_row = [&](std::size_t i) {
    for (int c = 0; c < 3; ++c) ls[3 * i + c] = std::clamp(ls[3 * i + c], so.min_log_scale, so.max_log_scale);
    lr[i] = std::clamp(lr[i], so.min_log_return, so.max_log_return);
    if (view)
      for (std::size_t c = 0; c < kViewTerms; ++c)
        vr[kViewTerms * i + c] = std::clamp(vr[kViewTerms * i + c], -so.max_view_return, so.max_view_return);
  };
  if (s.gaussians.empty()) {
    for (std::size_t i = 0; i < scene.size(); ++i) clamp_row(i);
  } else {
    for (const std::uint32_t i : s.gaussians)
      if (i < scene.size()) clamp_row(i);
  }
  return true;
}

void SplatAdam::remap_scene(const SceneRemap& origin) {
  means.remap(origin);
  rotations.remap(origin);
  log_scales.remap(origin);
  log_returns.remap(origin);
  // Untrained view returns have no state to carry (step() sizes it when they have a rate).
  if (view_returns.rows() > 0) view_returns.remap(origin);
}

}  // namespace rsrio::splat

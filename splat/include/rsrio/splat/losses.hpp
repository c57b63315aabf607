// Losses of RadarSplat++ (paper Sec. III-E; reference/renderer.md Sec. 1.5), with hand-written
// gradients:
//   image loss      L = 0.8 L1 + 0.2 (1 - SSIM), on COMPRESSED images (below), as RadarSplat;
//   scale regulariser  L_s = weight * mean over axes of relu(exp(log s) - s_max).
//
// Compression. The DSP's RA / RD are linear power with a dynamic range of 60 dB and more (1/R^4,
// RCS from walls to screws). On linear power L1 and SSIM see only the few strongest returns, and
// SSIM's constants (C1 = 0.01^2, C2 = 0.03^2) assume data in [0, 1]. Both the rendered and the
// measured images therefore go through the same fixed map
//     y = log(1 + x / (floor * reference)) / log(1 + 1 / floor)
// which is linear below floor * reference (the noise floor stays flat instead of exploding as
// log(x) would, and the gradient is bounded: dy/dx <= 1 / (floor reference log(1 + 1/floor))),
// logarithmic above, and maps x = reference to 1. `reference` must be FIXED for a sensor set-up
// (e.g. a high percentile of the first keyframe's image, percentile_reference()), never
// recomputed per image: a per-image normalisation would make the return ratios of Gaussians
// depend on what else is in view. `logarithmic = false` gives y = x / reference.
//
// SSIM: Gaussian window (default 11 x 11, sigma 1.5, as 3DGS / fused-ssim), "valid" padding:
// the mean is over the positions where the window lies entirely inside the image (RadarSplat's
// fused_ssim padding="valid"); a 7 x 7 window is an option for small images.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "rsrio/splat/gaussian_scene.hpp"
#include "rsrio/splat/grid.hpp"

namespace rsrio::splat {

struct CompressionOptions {
  bool logarithmic = true;
  double reference = 1.0;  // linear power mapped to 1
  double floor = 1e-3;     // knee of the log map, relative to reference (-30 dB)
};

/// out = compression of `linear` (negative inputs are treated as 0).
template <typename Scalar>
void compress(const Image<Scalar>& linear, const CompressionOptions& options, Image<Scalar>& out);
/// grad_linear = grad_compressed * dy/dx (0 where the input was clamped).
template <typename Scalar>
void compress_backward(const Image<Scalar>& linear, const Image<Scalar>& grad_compressed,
                       const CompressionOptions& options, Image<Scalar>& grad_linear);
/// The `percentile` (0..100) of the positive values of an image: a reference power for
/// CompressionOptions (e.g. 99.9 on a keyframe's RA image). 1 when there is none.
double percentile_reference(std::span<const float> image, double percentile);

/// mean |x - y|; grad_x (if not null, resized) = d/dx.
template <typename Scalar>
double l1_loss(const Image<Scalar>& x, const Image<Scalar>& y, Image<Scalar>* grad_x);

struct SsimOptions {
  int window = 11;      // odd
  double sigma = 1.5;
  double c1 = 1e-4;     // (0.01 * data range 1)^2
  double c2 = 9e-4;     // (0.03 * data range 1)^2
};

/// Mean SSIM with its gradient with respect to the first image. Holds the workspaces: no
/// allocation after the first call for a size. One per thread.
template <typename Scalar>
class Ssim {
 public:
  explicit Ssim(const SsimOptions& options = {});
  const SsimOptions& options() const { return options_; }
  /// Mean SSIM over the valid positions; grad_x (if not null, resized) = d(mean SSIM)/dx.
  /// Images smaller than the window give 1 (and a zero gradient).
  double evaluate(const Image<Scalar>& x, const Image<Scalar>& y, Image<Scalar>* grad_x);

 private:
  void filter_valid(const Image<Scalar>& in, Image<Scalar>& out);    // window-sized valid filter
  void filter_adjoint(const Image<Scalar>& in, Image<Scalar>& out);  // its adjoint (full size)

  SsimOptions options_;
  std::vector<Scalar> kernel_;
  Image<Scalar> xx_, yy_, xy_, tmp_;
  Image<Scalar> mu_x_, mu_y_, e_xx_, e_yy_, e_xy_;
  Image<Scalar> c_mx_, c_xx_, c_xy_, a_mx_, a_xx_, a_xy_;
};

struct ImageLossOptions {
  double l1_weight = 0.8;
  double ssim_weight = 0.2;
  SsimOptions ssim;
  CompressionOptions compression;
  /// Range bins [0, skip) take no part (TX-RX leakage, DC; RadarSplat drops the first 2.5 m).
  int skip_near_range_bins = 0;
};

/// L = l1_weight L1(c(R), M) + ssim_weight (1 - SSIM(c(R), M)) for a rendered linear image R and
/// a measured image M already compressed (prepare_measurement, once per keyframe).
template <typename Scalar>
class ImageLoss {
 public:
  explicit ImageLoss(const ImageLossOptions& options = {});
  const ImageLossOptions& options() const { return options_; }

  void prepare_measurement(const Image<Scalar>& measured_linear, Image<Scalar>& measured_compressed) const;
  /// grad_rendered (if not null; resized, overwritten) = dL/dR on the linear rendered image.
  double evaluate(const Image<Scalar>& rendered_linear, const Image<Scalar>& measured_compressed,
                  Image<Scalar>* grad_rendered);

 private:
  ImageLossOptions options_;
  Ssim<Scalar> ssim_;
  Image<Scalar> compressed_, rendered_part_, measured_part_, grad_l1_, grad_ssim_, grad_compressed_;
};

struct ScaleRegulariserOptions {
  double max_scale_m = 1.0;  // RadarSplat: 2 x init scale
  double weight = 100.0;     // RadarSplat's maxsize_lambda
};

/// weight * mean over the listed Gaussians' 3 axes of relu(exp(log s) - max_scale); ADDS its
/// gradient into gradients->log_scales (if not null). An empty list means all Gaussians.
double scale_regulariser(const GaussianScene& scene, std::span<const std::uint32_t> gaussians,
                         const ScaleRegulariserOptions& options, SceneGradients* gradients);

/// weight * mean over the listed Gaussians' view-return terms of c^2: holds the returns towards
/// isotropic where the views do not say otherwise. ADDS its gradient into
/// gradients->view_returns (if not null). An empty list means all Gaussians.
double view_return_regulariser(const GaussianScene& scene, std::span<const std::uint32_t> gaussians,
                               double weight, SceneGradients* gradients);

extern template class Ssim<float>;
extern template class Ssim<double>;
extern template class ImageLoss<float>;
extern template class ImageLoss<double>;

}  // namespace rsrio::splat

#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers_floating_point.hpp>

#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

#include "rsrio/splat/losses.hpp"
#include "splat_test_support.hpp"

using namespace rsrio::splat;
using namespace rsrio::splat::test;

namespace {

// Finite differences of f at a sample of pixels of x against grad. relative: the step h * x and
// both sides compared as x df/dx, for pixels whose values span decades (every pixel then counts
// on the same scale).
double check_image_gradient(std::mt19937_64& rng, Image<double>& x, const Image<double>& grad,
                            const std::function<double(const Image<double>&)>& f, double h, int samples,
                            bool relative = false) {
  std::uniform_int_distribution<Eigen::Index> pick(0, x.size() - 1);
  std::vector<double> a, n;
  for (int s = 0; s < samples; ++s) {
    const Eigen::Index k = pick(rng);
    const double x0 = x.data()[k];
    const double scale = relative ? x0 : 1.0;
    n.push_back(scale * central_difference(
                            [&](double v) {
                              x.data()[k] = v;
                              return f(x);
                            },
                            x0, h * scale));
    x.data()[k] = x0;
    a.push_back(scale * grad.data()[k]);
  }
  return relative_error(a, n);
}

}  // namespace

TEST_CASE("L1 and SSIM gradients match central differences", "[splat][loss]") {
  std::mt19937_64 rng(5);
  Image<double> x = random_image(rng, 40, 36, 0.0, 1.0);
  // y correlated with x so that SSIM is in its working range.
  const Image<double> y = (0.7 * x + 0.3 * random_image(rng, 40, 36, 0.0, 1.0)).eval();
  Image<double> grad;
  l1_loss(x, y, &grad);
  const double err_l1 = check_image_gradient(
      rng, x, grad, [&](const Image<double>& v) { return l1_loss<double>(v, y, nullptr); }, 1e-7, 200);
  double err_ssim[2];
  int idx = 0;
  for (int window : {11, 7}) {
    SsimOptions o;
    o.window = window;
    Ssim<double> ssim(o);
    ssim.evaluate(x, y, &grad);
    err_ssim[idx++] = check_image_gradient(
        rng, x, grad, [&](const Image<double>& v) { return ssim.evaluate(v, y, nullptr); }, 1e-6, 300);
    CHECK_THAT(ssim.evaluate(x, x, nullptr), Catch::Matchers::WithinAbs(1.0, 1e-12));
  }
  std::printf("loss gradcheck: L1 %.2e SSIM(11x11) %.2e SSIM(7x7) %.2e\n", err_l1, err_ssim[0], err_ssim[1]);
  CHECK(err_l1 < 1e-3);
  CHECK(err_ssim[0] < 1e-3);
  CHECK(err_ssim[1] < 1e-3);
}

TEST_CASE("The combined loss on compressed images: gradient w.r.t. the linear rendered image", "[splat][loss]") {
  std::mt19937_64 rng(8);
  // Linear power over five decades.
  Image<double> rendered = random_image(rng, 48, 40, -5.0, 0.0).unaryExpr([](double e) { return std::pow(10.0, e); });
  const Image<double> measured_linear =
      random_image(rng, 48, 40, -5.0, 0.0).unaryExpr([](double e) { return std::pow(10.0, e); });
  for (bool logarithmic : {true, false}) {
    ImageLossOptions o;
    o.compression.logarithmic = logarithmic;
    o.compression.reference = 0.5;
    o.compression.floor = 1e-3;
    o.skip_near_range_bins = 4;
    ImageLoss<double> loss(o);
    Image<double> measured, grad;
    loss.prepare_measurement(measured_linear, measured);
    loss.evaluate(rendered, measured, &grad);
    CHECK(grad.topRows(4).isZero());
    // Relative steps: pixel values span five decades.
    const double err = check_image_gradient(
        rng, rendered, grad, [&](const Image<double>& v) { return loss.evaluate(v, measured, nullptr); }, 1e-6, 300,
        true);
    std::printf("image loss gradcheck (%s): %.2e\n", logarithmic ? "log" : "linear", err);
    CHECK(err < 1e-3);
  }
  // The map: reference -> 1, floor * reference -> log 2 / log(1 + 1/floor), 0 -> 0.
  CompressionOptions c;
  c.reference = 2.0;
  c.floor = 1e-2;
  Image<double> in(1, 3), out;
  in << 2.0, 0.02, 0.0;
  compress(in, c, out);
  CHECK_THAT(out(0, 0), Catch::Matchers::WithinRel(1.0, 1e-12));
  CHECK_THAT(out(0, 1), Catch::Matchers::WithinRel(std::log(2.0) / std::log(101.0), 1e-12));
  CHECK(out(0, 2) == 0.0);
  const std::vector<float> values = {0.f, 1.f, 2.f, 3.f, 4.f, 5.f};
  CHECK(percentile_reference(values, 100.0) == 5.0);
  CHECK(percentile_reference(values, 0.0) == 1.0);
}

TEST_CASE("View-return regulariser: value and gradient", "[splat][loss]") {
  std::mt19937_64 rng(3);
  SceneOptions scene_options;
  scene_options.view_returns = true;
  GaussianScene scene = random_scene(rng, Eigen::Isometry3d::Identity(), 6, 2.0, 8.0, 50, 15, 0.05, 0.4, scene_options);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (double& c : scene.mutable_view_returns()) c = u(rng);
  SceneGradients g;
  g.reset(scene.size(), scene.has_view_returns());
  const double weight = 3.0;
  const double value = view_return_regulariser(scene, {}, weight, &g);
  double sum = 0;
  for (const double c : scene.view_returns()) sum += c * c;
  CHECK_THAT(value, Catch::Matchers::WithinRel(weight * sum / static_cast<double>(scene.view_returns().size()), 1e-12));
  std::vector<double> numeric(g.view_returns.size());
  for (std::size_t k = 0; k < numeric.size(); ++k) {
    const double x0 = scene.view_returns()[k];
    numeric[k] = central_difference(
        [&](double v) {
          scene.mutable_view_returns()[k] = v;
          return view_return_regulariser(scene, {}, weight, nullptr);
        },
        x0, 1e-6);
    scene.mutable_view_returns()[k] = x0;
  }
  const double err = relative_error(g.view_returns, numeric);
  std::printf("view-return regulariser gradcheck: %.2e\n", err);
  CHECK(err < 1e-6);
  // A list restricts the mean and the gradient to the listed Gaussians.
  SceneGradients h;
  h.reset(scene.size(), scene.has_view_returns());
  const std::vector<std::uint32_t> one = {2};
  double own = 0;
  for (std::size_t c = 0; c < kViewTerms; ++c) own += std::pow(scene.view_returns()[kViewTerms * 2 + c], 2);
  CHECK_THAT(view_return_regulariser(scene, one, weight, &h), Catch::Matchers::WithinRel(weight * own / kViewTerms, 1e-12));
  CHECK(h.view_returns[0] == 0.0);
  CHECK(h.view_returns[kViewTerms * 2] == 2 * weight / kViewTerms * scene.view_returns()[kViewTerms * 2]);
  // Gradients without the block the scene has are refused; a scene without view returns has none to hold.
  SceneGradients without;
  without.reset(scene.size(), false);
  CHECK_THROWS_AS(view_return_regulariser(scene, {}, weight, &without), std::invalid_argument);
  CHECK(view_return_regulariser(random_scene(rng, Eigen::Isometry3d::Identity(), 6), {}, weight, &without) == 0.0);
}

TEST_CASE("Scale regulariser: value and gradient", "[splat][loss]") {
  std::mt19937_64 rng(2);
  GaussianScene scene = random_scene(rng, Eigen::Isometry3d::Identity(), 20, 2, 8, 50, 15, 0.2, 2.0);
  ScaleRegulariserOptions o;
  o.max_scale_m = 1.0;
  o.weight = 10.0;
  SceneGradients g;
  g.reset(scene.size(), scene.has_view_returns());
  const double value = scale_regulariser(scene, {}, o, &g);
  CHECK(value > 0);
  std::vector<double> numeric(g.log_scales.size());
  for (std::size_t k = 0; k < numeric.size(); ++k) {
    const double x0 = scene.log_scales()[k];
    numeric[k] = central_difference(
        [&](double v) {
          scene.mutable_log_scales()[k] = v;
          return scale_regulariser(scene, {}, o, nullptr);
        },
        x0, 1e-7);
    scene.mutable_log_scales()[k] = x0;
  }
  const double err = relative_error(g.log_scales, numeric);
  std::printf("scale regulariser gradcheck: %.2e\n", err);
  CHECK(err < 1e-3);
  // A list restricts the mean to the listed Gaussians.
  const std::vector<std::uint32_t> one = {0};
  SceneGradients g1;
  g1.reset(scene.size(), scene.has_view_returns());
  scale_regulariser(scene, one, o, &g1);
  for (std::size_t i = 1; i < scene.size(); ++i) CHECK(g1.log_scales[3 * i] == 0.0);
}

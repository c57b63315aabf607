#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers_floating_point.hpp>

#include <cstdio>
#include <random>

#include "rsrio/splat/rd_renderer.hpp"
#include "splat_test_support.hpp"

using namespace rsrio::splat;
using namespace rsrio::splat::test;

namespace {

Image<double> random_image(std::mt19937_64& rng, int rows, int cols, double lo, double hi) {
  std::uniform_real_distribution<double> u(lo, hi);
  Image<double> m(rows, cols);
  for (Eigen::Index k = 0; k < m.size(); ++k) m.data()[k] = u(rng);
  return m;
}

void check_rd_gradients(const RdRenderOptions& options, const Eigen::Vector3d& velocity, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const RadarImageGrid grid = small_grid();
  RdRenderer<double> renderer(grid, options);
  Image<double> ra = random_image(rng, grid.range_bins, grid.azimuth_bins, 0.0, 1.0);
  const Image<double> weights = random_image(rng, grid.range_bins, grid.doppler_bins, -1.0, 1.0);
  auto loss = [&](const Image<double>& image, const Eigen::Vector3d& v) {
    Image<double> rd;
    renderer.render(image, v, rd);
    return (rd.array() * weights.array()).sum();
  };
  Image<double> grad_ra;
  Eigen::Vector3d grad_v = Eigen::Vector3d::Zero();
  renderer.backward(ra, velocity, weights, &grad_ra, &grad_v);

  std::uniform_int_distribution<int> pick_r(0, grid.range_bins - 1), pick_a(0, grid.azimuth_bins - 1);
  std::vector<double> analytic, numeric;
  for (int trial = 0; trial < 150; ++trial) {
    const int r = pick_r(rng), a = pick_a(rng);
    const double x0 = ra(r, a);
    numeric.push_back(central_difference(
        [&](double x) {
          ra(r, a) = x;
          return loss(ra, velocity);
        },
        x0, 1e-4));
    ra(r, a) = x0;
    analytic.push_back(grad_ra(r, a));
  }
  const double err_ra = relative_error(analytic, numeric);
  std::vector<double> nv(3);
  for (int c = 0; c < 3; ++c)
    nv[c] = central_difference(
        [&](double x) {
          Eigen::Vector3d v = velocity;
          v[c] = x;
          return loss(ra, v);
        },
        velocity[c], 1e-6);
  const double err_v = relative_error(to_vector(grad_v), nv);
  std::printf("RD gradcheck (window %d, v = %.2f %.2f): d/dRA %.2e d/dv %.2e\n", options.window_bins, velocity.x(),
              velocity.y(), err_ra, err_v);
  CHECK(err_ra < 1e-3);
  CHECK(err_v < 1e-3);
  CHECK(grad_v.z() == 0.0);
}

}  // namespace

TEST_CASE("RD gradients match central differences", "[splat][rd]") {
  RdRenderOptions wide;
  wide.window_bins = 30;  // kernel tail below 1e-20: the window edge never enters the differences
  check_rd_gradients(wide, Eigen::Vector3d(0.4, -0.25, 0.1), 1);
  RdRenderOptions dart;
  dart.window_bins = 30;
  dart.antenna.kind = AntennaProfile::Kind::kDartAwr1843;
  check_rd_gradients(dart, Eigen::Vector3d(-0.3, 0.5, 0.0), 2);
  // The paper's window (+-10 bins): fine as long as no pixel's v_D crosses a bin half-way point
  // within the difference step, which holds for generic velocities.
  RdRenderOptions paper;
  paper.antenna.kind = AntennaProfile::Kind::kCosinePower;
  check_rd_gradients(paper, Eigen::Vector3d(0.3131, 0.1717, 0.0), 3);
}

TEST_CASE("RD sign: forward motion makes boresight returns approach (negative Doppler)", "[splat][rd]") {
  const RadarImageGrid grid = small_grid();
  RdRenderer<double> renderer(grid);
  Image<double> ra = Image<double>::Zero(grid.range_bins, grid.azimuth_bins);
  const int boresight = grid.azimuth_bins / 2;
  ra(20, boresight) = 1.0;
  Image<double> rd;
  auto peak_velocity = [&](const Eigen::Vector3d& v) {
    renderer.render(ra, v, rd);
    Eigen::Index r, j;
    rd.maxCoeff(&r, &j);
    CHECK(r == 20);
    return grid.doppler_mps(static_cast<int>(j));
  };
  CHECK_THAT(peak_velocity(Eigen::Vector3d(0.5, 0, 0)), Catch::Matchers::WithinAbs(-0.5, 1e-9));
  CHECK_THAT(peak_velocity(Eigen::Vector3d(-0.5, 0, 0)), Catch::Matchers::WithinAbs(0.5, 1e-9));
  CHECK(static_doppler(Eigen::Vector3d(1, 0, 0), 0.0) < 0);
  // Moving left (+y): returns on the left approach.
  ra.setZero();
  const int left = grid.azimuth_bins / 2 + 16;  // sin = 0.5
  ra(20, left) = 1.0;
  CHECK_THAT(peak_velocity(Eigen::Vector3d(0, 0.6, 0)), Catch::Matchers::WithinAbs(-0.3, 1e-9));
  // Energy: a pixel spreads over the kernel, peak = Phi * RA at the centre bin.
  renderer.render(ra, Eigen::Vector3d(0, 0.6, 0), rd);
  CHECK_THAT(rd.maxCoeff(), Catch::Matchers::WithinRel(1.0, 1e-12));
}

TEST_CASE("RD wraps around the Doppler axis like the FFT", "[splat][rd]") {
  const RadarImageGrid grid = small_grid();  // +-0.8 m/s
  RdRenderer<double> renderer(grid);
  Image<double> ra = Image<double>::Zero(grid.range_bins, grid.azimuth_bins);
  ra(10, grid.azimuth_bins / 2) = 1.0;
  Image<double> rd;
  renderer.render(ra, Eigen::Vector3d(1.0, 0, 0), rd);  // v_D = -1.0 -> aliases to +0.6
  Eigen::Index r, j;
  rd.maxCoeff(&r, &j);
  CHECK_THAT(grid.doppler_mps(static_cast<int>(j)), Catch::Matchers::WithinAbs(0.6, 1e-9));
}

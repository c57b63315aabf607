#include <catch2/catch_test_macros.hpp>
#include <catch2/matchers/catch_matchers_floating_point.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vector>
#include <random>
#include <utility>

#include "rsrio/splat/ra_renderer.hpp"
#include "rsrio/splat/rd_renderer.hpp"
#include "splat_test_support.hpp"

using namespace rsrio::splat;
using namespace rsrio::splat::test;

namespace {

// Pixel directions of returns up to +-40 deg above and below each pixel's azimuth (unit vectors
// with the pixel's sin-theta), as RaRenderer::render_directions makes them.
PixelDirections<double> random_directions(std::mt19937_64& rng, const RadarImageGrid& grid) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  PixelDirections<double> d;
  for (Image<double>* m : {&d.x, &d.y, &d.z, &d.weight}) m->setOnes(grid.range_bins, grid.azimuth_bins);
  for (int r = 0; r < grid.range_bins; ++r)
    for (int a = 0; a < grid.azimuth_bins; ++a) {
      const double s = std::clamp(grid.azimuth_sin(a), -1.0, 1.0);
      const double w = std::sqrt(1 - s * s) * std::sin(0.7 * u(rng));
      d.y(r, a) = s;
      d.z(r, a) = w;
      d.x(r, a) = std::sqrt(std::max(0.0, 1 - s * s - w * w));
    }
  return d;
}

// The RD image's Doppler centroid (m/s) over all its range bins.
double doppler_centroid(const RadarImageGrid& grid, const Image<double>& rd) {
  double sum = 0, moment = 0;
  for (int r = 0; r < grid.range_bins; ++r)
    for (int j = 0; j < grid.doppler_bins; ++j) {
      sum += rd(r, j);
      moment += rd(r, j) * grid.doppler_mps(j);
    }
  return moment / sum;
}

void check_rd_gradients(const RdRenderOptions& options, const Eigen::Vector3d& velocity, std::uint64_t seed,
                        bool with_directions = false) {
  std::mt19937_64 rng(seed);
  const RadarImageGrid grid = small_grid();
  RdRenderer<double> renderer(grid, options);
  Image<double> ra = random_image(rng, grid.range_bins, grid.azimuth_bins, 0.0, 1.0);
  const Image<double> weights = random_image(rng, grid.range_bins, grid.doppler_bins, -1.0, 1.0);
  const PixelDirections<double> directions_storage = random_directions(rng, grid);
  const PixelDirections<double>* directions = with_directions ? &directions_storage : nullptr;
  auto loss = [&](const Image<double>& image, const Eigen::Vector3d& v) {
    Image<double> rd;
    renderer.render(image, v, rd, directions);
    return (rd.array() * weights.array()).sum();
  };
  Image<double> grad_ra;
  Eigen::Vector3d grad_v = Eigen::Vector3d::Zero();
  renderer.backward(ra, velocity, weights, &grad_ra, &grad_v, directions);

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
  std::printf("RD gradcheck (window %d, v = %.2f %.2f %.2f, %s): d/dRA %.2e d/dv %.2e\n", options.window_bins,
              velocity.x(), velocity.y(), velocity.z(), with_directions ? "pixel directions" : options.elevation_sigma_sin > 0 ? "elevation beam" : "elevation 0", err_ra,
              err_v);
  CHECK(err_ra < 1e-3);
  CHECK(err_v < 1e-3);
  // At elevation 0 v_z cannot matter; with returns above and below the radar it does.
  if (with_directions || options.elevation_sigma_sin > 0)
    CHECK(std::abs(grad_v.z()) > 1e-3 * grad_v.norm());
  else
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
  // Each pixel's Doppler from its direction (elevation included), v_z in play; the backend's
  // DSP-lobe kernel (0.61 bins, window cut at 8 sigma) too.
  check_rd_gradients(wide, Eigen::Vector3d(0.4, -0.25, 0.1), 4, true);
  RdRenderOptions lobe;
  lobe.kernel_sigma_bins = 0.61;
  check_rd_gradients(lobe, Eigen::Vector3d(0.3131, 0.1717, -0.05), 5, true);
  // Marginalised over the elevation beam (three elevation nodes an azimuth bin).
  RdRenderOptions beam = wide;
  beam.elevation_sigma_sin = 0.156;
  check_rd_gradients(beam, Eigen::Vector3d(0.4, -0.25, 0.1), 6);
  RdRenderOptions beam_lobe = lobe;
  beam_lobe.elevation_sigma_sin = 0.3;  // the outer nodes leave the widest azimuths no direction
  check_rd_gradients(beam_lobe, Eigen::Vector3d(0.3131, 0.1717, -0.05), 7);
}

TEST_CASE("RD over the elevation beam is the weighted sum of renderings at three elevations", "[splat][rd]") {
  // Independent of the marginalised path: each Gauss-Hermite node as explicit pixel directions
  // (sqrt(cos^2 el - u^2), u, sin el), rendered by the per-pixel path and summed with weights
  // 1/6, 2/3, 1/6; directions that do not exist (|u| > cos el) left out as the renderer does.
  std::mt19937_64 rng(8);
  const RadarImageGrid grid = small_grid();
  RdRenderOptions o;
  o.kernel_sigma_bins = 0.61;
  o.elevation_sigma_sin = 0.3;
  RdRenderer<double> beam(grid, o);
  RdRenderOptions flat_options = o;
  flat_options.elevation_sigma_sin = 0;
  RdRenderer<double> per_pixel(grid, flat_options);
  const Image<double> ra = random_image(rng, grid.range_bins, grid.azimuth_bins, 0.1, 1.0);
  const Eigen::Vector3d v(0.45, -0.2, 0.08);
  const double e = std::sqrt(3.0) * o.elevation_sigma_sin;
  Image<double> expected = Image<double>::Zero(grid.range_bins, grid.doppler_bins), part, rd;
  int missing = 0;
  for (const auto& [sin_el, weight] : {std::pair{-e, 1.0 / 6}, std::pair{0.0, 2.0 / 3}, std::pair{e, 1.0 / 6}}) {
    PixelDirections<double> d;
    for (Image<double>* m : {&d.x, &d.y, &d.z, &d.weight}) m->setZero(grid.range_bins, grid.azimuth_bins);
    Image<double> node_ra = ra;
    for (int r = 0; r < grid.range_bins; ++r)
      for (int a = 0; a < grid.azimuth_bins; ++a) {
        const double u = std::clamp(grid.azimuth_sin(a), -1.0, 1.0), forward2 = 1 - sin_el * sin_el - u * u;
        if (forward2 < 0) {
          node_ra(r, a) = 0;  // no such direction
          missing += r == 0;
          continue;
        }
        d.x(r, a) = std::sqrt(forward2);
        d.y(r, a) = u;
        d.z(r, a) = sin_el;
      }
    per_pixel.render(node_ra, v, part, &d);
    expected += weight * part;
  }
  beam.render(ra, v, rd);
  CHECK(missing > 0);  // the widest azimuths have no direction at the outer elevations
  CHECK((rd - expected).cwiseAbs().maxCoeff() <= 1e-12 * expected.cwiseAbs().maxCoeff());
  // The beam's returns close in more slowly than elevation 0's: the Doppler centroid of forward
  // motion is -v * E[sqrt(cos^2 el - u^2)], not -v * sqrt(1 - u^2).
  Image<double> rd0;
  per_pixel.render(ra, Eigen::Vector3d(0.6, 0, 0), rd0);
  beam.render(ra, Eigen::Vector3d(0.6, 0, 0), rd);
  const double flat_centroid = doppler_centroid(grid, rd0), beam_centroid = doppler_centroid(grid, rd);
  INFO("Doppler centroid at elevation 0: " << flat_centroid << " m/s, over the beam: " << beam_centroid);
  CHECK(beam_centroid > flat_centroid + 0.005);
  RdRenderOptions bad = o;
  bad.elevation_sigma_sin = -0.1;
  CHECK_THROWS_AS(RdRenderer<double>(grid, bad), std::invalid_argument);
}

TEST_CASE("RD with the pixels' own directions at elevation 0 is the per-azimuth rendering", "[splat][rd]") {
  std::mt19937_64 rng(6);
  const RadarImageGrid grid = small_grid();
  for (const double sigma : {3.0, 0.61}) {
    RdRenderOptions o;
    o.kernel_sigma_bins = sigma;
    RdRenderer<double> renderer(grid, o);
    const Image<double> ra = random_image(rng, grid.range_bins, grid.azimuth_bins, 0.0, 1.0);
    PixelDirections<double> flat;
    for (Image<double>* m : {&flat.x, &flat.y, &flat.z, &flat.weight}) m->setZero(grid.range_bins, grid.azimuth_bins);
    for (int r = 0; r < grid.range_bins; ++r)
      for (int a = 0; a < grid.azimuth_bins; ++a) {
        const double s = std::clamp(grid.azimuth_sin(a), -1.0, 1.0);
        flat.x(r, a) = std::sqrt(1 - s * s);
        flat.y(r, a) = s;
      }
    const Eigen::Vector3d v(0.37, -0.21, 0.3);  // v_z has nothing to act on at elevation 0
    Image<double> a, b;
    renderer.render(ra, v, a);
    renderer.render(ra, v, b, &flat);
    CHECK((a - b).cwiseAbs().maxCoeff() <= 1e-12 * a.cwiseAbs().maxCoeff());
    const Image<double> g = random_image(rng, grid.range_bins, grid.doppler_bins, -1.0, 1.0);
    Image<double> ga, gb;
    Eigen::Vector3d va = Eigen::Vector3d::Zero(), vb = Eigen::Vector3d::Zero();
    renderer.backward(ra, v, g, &ga, &va);
    renderer.backward(ra, v, g, &gb, &vb, &flat);
    CHECK((ga - gb).cwiseAbs().maxCoeff() <= 1e-12 * ga.cwiseAbs().maxCoeff());
    CHECK((va - vb).norm() <= 1e-12 * va.norm());
  }
  CHECK(effective_window(RdRenderOptions{}) == 10);  // sigma 3: the paper's +-10 bins
  RdRenderOptions lobe;
  lobe.kernel_sigma_bins = 0.61;
  CHECK(effective_window(lobe) == 5);
  Image<double> wrong = Image<double>::Zero(3, 3);
  PixelDirections<double> bad{wrong, wrong, wrong, wrong};
  RdRenderer<double> renderer(grid);
  Image<double> rd;
  CHECK_THROWS_AS(renderer.render(Image<double>::Zero(grid.range_bins, grid.azimuth_bins), Eigen::Vector3d::UnitX(), rd,
                                  &bad),
                  std::invalid_argument);
}

TEST_CASE("RD from the Gaussians' directions: a return above the radar closes in at cos(elevation)", "[splat][rd]") {
  const RadarImageGrid grid = small_grid();  // 0.05 m/s Doppler bins, +-0.8 m/s
  // One small Gaussian 3 m ahead and 1.5 m above the radar (elevation 26.6 deg): sin-theta 0,
  // so at elevation 0 its pixel would close in at the full 0.6 m/s.
  GaussianScene scene;
  const Eigen::Vector3d p(3.0, 0.0, 1.5);
  scene.add(p, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Constant(std::log(0.02)), 0.0);
  const Eigen::Isometry3d radar_T_world = Eigen::Isometry3d::Identity();
  RaRenderer<double> ra_renderer(grid);
  Image<double> ra;
  ra_renderer.render(scene, radar_T_world, ra);
  std::vector<std::uint32_t> all{0};
  PixelDirections<double> directions;
  ra_renderer.render_directions(scene, radar_T_world, all, directions);
  CHECK((directions.weight - ra).cwiseAbs().maxCoeff() <= 1e-12 * ra.maxCoeff());
  // Where the Gaussian is drawn, the direction is its own; elsewhere the pixel's at elevation 0.
  Eigen::Index kr, ka;
  ra.maxCoeff(&kr, &ka);
  const Eigen::Vector3d n = p.normalized();
  CHECK(std::abs(directions.x(kr, ka) - n.x()) < 1e-12);
  CHECK(std::abs(directions.z(kr, ka) - n.z()) < 1e-12);
  CHECK(directions.z(5, 10) == 0.0);
  CHECK(std::abs(directions.y(5, 10) - grid.azimuth_sin(10)) < 1e-12);

  RdRenderOptions o;
  o.kernel_sigma_bins = 0.61;
  RdRenderer<double> rd_renderer(grid, o);
  const Eigen::Vector3d v(0.6, 0, 0);
  // The RD's Doppler centroid over the Gaussian's range bins.
  auto centroid = [&](const PixelDirections<double>* d) {
    Image<double> rd;
    rd_renderer.render(ra, v, rd, d);
    return doppler_centroid(grid, rd);
  };
  const double expected = -n.dot(v);  // -0.537 m/s
  INFO("elevation 0: " << centroid(nullptr) << " m/s, with directions: " << centroid(&directions) << " m/s, true "
                       << expected);
  CHECK(std::abs(centroid(&directions) - expected) < 0.005);
  CHECK(std::abs(centroid(nullptr) - (-0.6)) < 0.01);
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

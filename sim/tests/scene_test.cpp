// The scene: sampling, back faces, occlusion, multipath ghosts and walking people.
#include <cmath>

#include <catch2/catch_test_macros.hpp>

#include "rsrio/sim/scene.hpp"

using namespace rsrio::sim;

namespace {

bool visible(const Scene& scene, const Eigen::Vector3d& from, const Scatterer& s) {
  std::vector<int> occ, cyl;
  scene.nearby(from, 100.0, occ, cyl);
  if (s.normal.squaredNorm() > 0 && -s.normal.dot((s.position - from).normalized()) <= 0) return false;  // back face
  return scene.line_of_sight(from, s, occ, cyl);
}

}  // namespace

TEST_CASE("sim: walls are sampled on both faces with the configured density", "[scene]") {
  SceneOptions o;
  WallOptions w;
  w.points = {{0, 0}, {10, 0}};
  w.height_m = 2.5;
  w.spacing_m = 0.25;
  w.row_spacing_m = 0.5;
  o.walls.push_back(w);
  const Scene scene(o);
  // 40 columns x 5 rows x 2 faces.
  REQUIRE(scene.static_scatterers().size() == 400);
  int up = 0;
  double mean_rcs = 0;
  for (const auto& s : scene.static_scatterers()) {
    CHECK(std::abs(std::abs(s.normal.y()) - 1) < 1e-12);
    CHECK(std::abs(s.position.y()) < 0.03);
    up += s.normal.y() > 0;
    mean_rcs += s.rcs_m2 / 400;
  }
  CHECK(up == 200);
  CHECK(std::abs(mean_rcs / w.rcs_m2 - 1) < 0.2);  // exponential draws with the configured mean
}

TEST_CASE("sim: walls hide what is behind them and show only their front face", "[scene]") {
  SceneOptions o;
  WallOptions w;
  w.points = {{0, 2}, {10, 2}};
  w.height_m = 2.0;
  o.walls.push_back(w);
  ClutterOptions behind;
  behind.region = Eigen::Vector4d(5, 4, 5, 4);
  behind.z_min_m = behind.z_max_m = 1.0;
  behind.count = 1;
  o.clutter.push_back(behind);
  const Scene scene(o);
  const Eigen::Vector3d radar(5, 0, 1);
  const Scatterer* point = nullptr;
  int front = 0, back = 0;
  for (const auto& s : scene.static_scatterers()) {
    if (s.kind == ScattererKind::kClutter) point = &s;
    if (s.kind != ScattererKind::kWall || !visible(scene, radar, s)) continue;
    (s.normal.y() < 0 ? front : back)++;
  }
  REQUIRE(point != nullptr);
  CHECK(front > 0);
  CHECK(back == 0);
  CHECK_FALSE(visible(scene, radar, *point));
  // Looking over the wall: from 3 m up the line passes above the 2 m wall.
  CHECK(visible(scene, Eigen::Vector3d(5, 0, 3.5), *point));
}

TEST_CASE("sim: a mirror wall makes ghosts seen only through it", "[scene]") {
  SceneOptions o;
  WallOptions w;
  w.points = {{0, 0}, {10, 0}};
  w.mirror_loss_db = 10.0;
  o.walls.push_back(w);
  PillarOptions p;
  p.center = Eigen::Vector2d(5, 2);
  o.pillars.push_back(p);
  const Scene scene(o);
  int ghosts = 0, seen = 0;
  for (const auto& s : scene.static_scatterers()) {
    if (s.kind != ScattererKind::kGhost) continue;
    ++ghosts;
    CHECK(s.position.y() < 0);  // behind the mirror
    CHECK(s.mirror >= 0);
    // From the side: straight behind the pillar, the pillar itself blocks the view of its image.
    seen += visible(scene, Eigen::Vector3d(1.5, 3, 1), s);
  }
  CHECK(ghosts > 0);
  CHECK(seen > 0);
  // From behind the mirror, the ghosts are not there.
  for (const auto& s : scene.static_scatterers())
    if (s.kind == ScattererKind::kGhost) CHECK_FALSE(visible(scene, Eigen::Vector3d(5, -3, 1), s));
}

TEST_CASE("sim: people walk their paths with consistent velocities", "[scene]") {
  SceneOptions o;
  PersonOptions p;
  p.path = {{0, 0}, {8, 0}};
  p.speed_mps = 1.2;
  p.start_s = 1.0;
  o.people.push_back(p);
  const Scene scene(o);
  REQUIRE(scene.max_dynamic_scatterers() == Scene::kScatterersPerPerson);
  std::vector<Scatterer> a, b, c;
  const double t = 4.0, h = 1e-4;
  scene.dynamic_scatterers(t, a);
  scene.dynamic_scatterers(t + h, b);
  scene.dynamic_scatterers(t - h, c);
  REQUIRE(a.size() == Scene::kScatterersPerPerson);
  for (std::size_t i = 0; i < a.size(); ++i) {
    CHECK((a[i].velocity - (b[i].position - c[i].position) / (2 * h)).norm() < 1e-5);
    CHECK((a[i].acceleration - (b[i].velocity - c[i].velocity) / (2 * h)).norm() < 0.05);
  }
  CHECK(std::abs(a[0].velocity.x() - 1.2) < 1e-6);  // torso at walking speed
  std::vector<Scatterer> early;
  scene.dynamic_scatterers(0.5, early);
  CHECK(early[0].velocity.norm() == 0.0);  // not started yet
  std::vector<Scatterer> back;
  scene.dynamic_scatterers(1.0 + 2 * 0.5 + 8 / 1.2 + 3.0, back);  // on the way back
  CHECK(back[0].velocity.x() < -1.0);
}

TEST_CASE("sim: scene sampling is deterministic for its seed", "[scene]") {
  SceneOptions o;
  WallOptions w;
  w.points = {{0, 0}, {4, 0}, {4, 3}};
  o.walls.push_back(w);
  const Scene a(o), b(o);
  o.seed = 2;
  const Scene c(o);
  REQUIRE(a.static_scatterers().size() == c.static_scatterers().size());
  bool differs = false;
  for (std::size_t i = 0; i < a.static_scatterers().size(); ++i) {
    CHECK(a.static_scatterers()[i].position == b.static_scatterers()[i].position);
    CHECK(a.static_scatterers()[i].rcs_m2 == b.static_scatterers()[i].rcs_m2);
    differs = differs || a.static_scatterers()[i].position != c.static_scatterers()[i].position;
  }
  CHECK(differs);
}

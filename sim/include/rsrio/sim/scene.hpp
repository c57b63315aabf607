// The simulated world: surfaces sampled into point scatterers, the occluders that hide them, and
// the people who walk about (scenario section `scene`, documented in scenarios/README.md).
//
// World frame: x, y horizontal (the scenario's plan coordinates), z up, floor at z = 0.
//
// Scatterer model. Each surface (wall face, box face, pillar) is sampled on a grid of about
// `spacing_m` x `row_spacing_m`; every sample gets a deterministic random position jitter and an
// RCS drawn from an exponential distribution with the configured mean (a rough surface seen as
// many independent facets, Swerling-1-like but frozen in time). A surface scatterer reflects only
// to the side its normal faces, with RCS x cos(incidence)^incidence_exponent. Box corners carry
// an extra isotropic scatterer (vertical edges are strong reflectors). Clutter points are
// isotropic. People are seven scatterers (torso x2, head, legs x2, arms x2) that walk their own
// spline paths, legs and arms swinging at the gait frequency: they do not obey the static-world
// assumption, and their limbs add micro-Doppler.
//
// Multipath. A wall with `mirror_loss_db` set is a mirror: every non-wall scatterer (boxes,
// pillars, clutter, people) within `multipath_max_distance_m` in front of it gets an image behind
// it (the double-bounce radar -> wall -> object -> wall -> radar ghost) with its RCS lowered by
// the loss. The ghost is visible only when the line of sight to it passes through the mirror
// wall; static objects give static ghosts (consistent with ego-motion, at the wrong place),
// people give moving ones.
//
// Occlusion. Walls and box faces are vertical rectangles, pillars vertical cylinders. A
// scatterer is hidden when the straight line from the radar to it crosses another occluder below
// that occluder's top (plan-view intersection, exact height at the crossing). A ghost's line of
// sight is tested up to its mirror only (the mirrored half of the path is not).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rsrio/sim/motion.hpp"

namespace rsrio::sim {

struct WallOptions {
  std::string name;
  std::vector<Eigen::Vector2d> points;  // polyline, m
  bool closed = false;                  // join the last point to the first
  double height_m = 2.8;
  double spacing_m = 0.25;              // horizontal scatterer spacing
  double row_spacing_m = 0.5;           // vertical scatterer spacing
  double rcs_m2 = 0.02;                 // mean RCS per scatterer
  double jitter_m = 0.03;               // position jitter (uniform +-, half of it across the face)
  double incidence_exponent = 2.0;
  double mirror_loss_db = -1.0;         // >= 0: the wall is a multipath mirror with this loss
};

struct BoxOptions {
  std::string name;
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  Eigen::Vector3d size = Eigen::Vector3d(1.0, 0.5, 0.75);  // along its x, y (after yaw), height, m
  double yaw_deg = 0;
  double spacing_m = 0.2;
  double rcs_m2 = 0.03;
  double corner_rcs_m2 = 0.3;           // each vertical edge's isotropic scatterer (0: none)
  double jitter_m = 0.02;
  double incidence_exponent = 2.0;
};

struct PillarOptions {
  std::string name;
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double radius_m = 0.25;
  double height_m = 2.8;
  double spacing_m = 0.15;
  double row_spacing_m = 0.5;
  double rcs_m2 = 0.05;
  double jitter_m = 0.01;
  double incidence_exponent = 1.0;
};

struct ClutterOptions {
  std::string name;
  Eigen::Vector4d region = Eigen::Vector4d(0, 0, 1, 1);  // x_min, y_min, x_max, y_max, m
  int count = 10;
  double z_min_m = 0.0;
  double z_max_m = 2.0;
  double rcs_m2 = 0.01;                 // mean (exponential)
};

struct PersonOptions {
  std::string name;
  std::vector<Eigen::Vector2d> path;    // waypoints, m
  double speed_mps = 1.2;
  bool loop = false;                    // false: walk to the end and back (ping-pong); true: the
                                        // path is closed (last point = first) and repeats
  double start_s = 0.0;                 // stands at the first point until then
  double pause_s = 1.0;                 // standing time at the path's ends
  double height_m = 1.75;
  double rcs_m2 = 1.0;                  // total over the body
};

struct SceneOptions {
  std::uint64_t seed = 1;               // geometry jitter, RCS draws, gait phases
  std::vector<WallOptions> walls;
  std::vector<BoxOptions> boxes;
  std::vector<PillarOptions> pillars;
  std::vector<ClutterOptions> clutter;
  std::vector<PersonOptions> people;
  double multipath_max_distance_m = 6.0;
};

enum class ScattererKind : std::uint8_t { kWall, kBox, kPillar, kClutter, kPerson, kGhost };

/// One point scatterer. Position, velocity and acceleration refer to one time (construction for
/// static ones, the time asked for dynamic ones); the radar extrapolates them over a frame.
struct Scatterer {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d acceleration = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // unit outward normal; zero: isotropic
  double rcs_m2 = 0;
  double incidence_exponent = 0;
  int surface = -1;  // the occluder (or -2 - cylinder index) it lies on: skipped in its own occlusion test
  int mirror = -1;   // ghosts: the occluder it is seen through
  ScattererKind kind = ScattererKind::kClutter;
};

/// A vertical rectangle above the floor segment a-b.
struct Occluder {
  Eigen::Vector2d a = Eigen::Vector2d::Zero(), b = Eigen::Vector2d::Zero();
  double height = 0;
  double mirror_loss_db = -1;  // >= 0: multipath mirror
};

/// A vertical cylinder standing on the floor.
struct Cylinder {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double radius = 0, height = 0;
};

class Scene {
 public:
  /// Samples every surface. Throws std::invalid_argument naming the object for bad geometry.
  explicit Scene(const SceneOptions& options);
  ~Scene();
  Scene(Scene&&) noexcept;
  Scene& operator=(Scene&&) noexcept;

  /// Walls, boxes, pillars, clutter and the ghosts of the static ones.
  const std::vector<Scatterer>& static_scatterers() const { return static_; }
  /// People and their ghosts at time t, appended to `out` (which is not cleared). Allocates
  /// nothing when `out` has capacity for max_dynamic_scatterers() more.
  void dynamic_scatterers(double t, std::vector<Scatterer>& out) const;
  std::size_t max_dynamic_scatterers() const;

  const std::vector<Occluder>& occluders() const { return occluders_; }
  const std::vector<Cylinder>& cylinders() const { return cylinders_; }

  /// Indices of the occluders and cylinders that come within `range` of `from` (plan view).
  void nearby(const Eigen::Vector3d& from, double range, std::vector<int>& occluders,
              std::vector<int>& cylinders) const;
  /// Whether `s` can be seen from `from`: not hidden by any of the given occluders / cylinders,
  /// and for a ghost, seen through its mirror.
  bool line_of_sight(const Eigen::Vector3d& from, const Scatterer& s, const std::vector<int>& occluders,
                     const std::vector<int>& cylinders) const;

  /// The number of scatterers of each person (torso x2, head, legs x2, arms x2).
  static constexpr int kScatterersPerPerson = 7;

 private:
  struct Person;
  void add_wall(const WallOptions& w, std::uint64_t index);
  void add_box(const BoxOptions& b, std::uint64_t index);
  void add_pillar(const PillarOptions& p, std::uint64_t index);
  void add_clutter(const ClutterOptions& c, std::uint64_t index);
  void add_static_ghosts();
  void add_ghosts(const Scatterer& source, std::vector<Scatterer>& out) const;

  SceneOptions options_;
  std::vector<Scatterer> static_;
  std::vector<Occluder> occluders_;
  std::vector<int> mirrors_;  // indices into occluders_
  std::vector<Cylinder> cylinders_;
  std::vector<Person> people_;
};

}  // namespace rsrio::sim

#include "rsrio/sim/scene.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "random.hpp"

namespace rsrio::sim {

namespace {

constexpr double kPi = std::numbers::pi;

// Random streams, one per object, so that adding an object never changes the others.
enum Stream : std::uint64_t { kWallStream = 1, kBoxStream, kPillarStream, kClutterStream, kPersonStream };

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

Eigen::Vector2d left_normal(const Eigen::Vector2d& dir) { return Eigen::Vector2d(-dir.y(), dir.x()); }

double distance_to_segment(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d e = b - a;
  const double t = std::clamp((p - a).dot(e) / std::max(e.squaredNorm(), 1e-18), 0.0, 1.0);
  return (a + t * e - p).norm();
}

// Where the segment r -> q crosses the segment a -> b: the parameter along r -> q, or -1.
double crossing(const Eigen::Vector2d& r, const Eigen::Vector2d& q, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d d = q - r, e = b - a;
  const double den = cross2(d, e);
  if (std::abs(den) < 1e-15) return -1;  // parallel: a grazing ray hides nothing
  const Eigen::Vector2d ar = a - r;
  const double t = cross2(ar, e) / den;
  const double u = cross2(ar, d) / den;
  if (u < 0 || u > 1) return -1;
  return t;
}

// Mirror image of a vector across the vertical plane with horizontal unit normal n.
Eigen::Vector3d reflect(const Eigen::Vector3d& v, const Eigen::Vector2d& n) {
  const Eigen::Vector3d n3(n.x(), n.y(), 0);
  return v - 2 * v.dot(n3) * n3;
}

// Rows of samples over a height: `count` evenly spread, centred in their cells.
int cells(double extent, double spacing) { return std::max(1, static_cast<int>(std::lround(extent / spacing))); }

}  // namespace

// ---- people -------------------------------------------------------------------------------------

struct Scene::Person {
  PersonOptions options;
  SplineTrajectory path;
  double gait_omega = 0;  // rad/s of one full gait cycle (two steps)
  double gait_phase = 0;
  double q0 = 0;          // swing envelope q / (q + q0) of q = |v|^2

  Person(const PersonOptions& o, const TrajectoryOptions& t, double phase)
      : options(o), path(t), gait_omega(2 * kPi * o.speed_mps / 1.4), gait_phase(phase),
        q0(std::pow(0.3 * o.speed_mps, 2)) {}

  // Path state at t with the ping-pong / loop time mapping.
  RigState body(double t) const {
    const double period = path.duration();
    double tau = std::max(0.0, t - options.start_s);
    if (options.loop) return path.state(std::fmod(tau, period));
    const double c = std::fmod(tau, 2 * period);
    if (c <= period) return path.state(c);
    RigState s = path.state(2 * period - c);  // walking back: time runs backwards on the path
    s.velocity = -s.velocity;
    s.rotation = s.rotation * Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    s.angular_velocity = -s.angular_velocity;
    return s;
  }
};

// ---- construction -------------------------------------------------------------------------------

Scene::Scene(const SceneOptions& options) : options_(options) {
  for (std::size_t i = 0; i < options.walls.size(); ++i) add_wall(options.walls[i], i);
  for (std::size_t i = 0; i < options.boxes.size(); ++i) add_box(options.boxes[i], i);
  for (std::size_t i = 0; i < options.pillars.size(); ++i) add_pillar(options.pillars[i], i);
  for (std::size_t i = 0; i < options.clutter.size(); ++i) add_clutter(options.clutter[i], i);
  for (std::size_t i = 0; i < options.people.size(); ++i) {
    const PersonOptions& p = options.people[i];
    if (p.path.size() < 2) throw std::invalid_argument("person '" + p.name + "' needs a path of at least two points");
    TrajectoryOptions t;
    t.waypoints = p.path;
    if (p.loop && (p.path.back() - p.path.front()).norm() > 1e-6) t.waypoints.push_back(p.path.front());
    t.speed_mps = p.speed_mps;
    t.knot_interval_s = 0.5;
    t.still_start_s = p.pause_s / 2;
    t.still_end_s = p.pause_s / 2;
    t.height_m = 0;
    detail::Random rng(detail::stream_seed(options.seed, kPersonStream, i));
    people_.emplace_back(p, t, rng.uniform(0, 2 * kPi));
  }
  add_static_ghosts();
}

Scene::~Scene() = default;
Scene::Scene(Scene&&) noexcept = default;
Scene& Scene::operator=(Scene&&) noexcept = default;

void Scene::add_wall(const WallOptions& w, std::uint64_t index) {
  if (w.points.size() < 2) throw std::invalid_argument("wall '" + w.name + "' needs at least two points");
  detail::Random rng(detail::stream_seed(options_.seed, kWallStream, index));
  std::vector<Eigen::Vector2d> pts = w.points;
  if (w.closed) pts.push_back(pts.front());
  const int rows = cells(w.height_m, w.row_spacing_m);
  for (std::size_t k = 0; k + 1 < pts.size(); ++k) {
    const Eigen::Vector2d a = pts[k], b = pts[k + 1];
    const double len = (b - a).norm();
    if (len < 1e-6) continue;
    const Eigen::Vector2d dir = (b - a) / len, n = left_normal(dir);
    const int occluder = static_cast<int>(occluders_.size());
    occluders_.push_back({a, b, w.height_m, w.mirror_loss_db});
    if (w.mirror_loss_db >= 0) mirrors_.push_back(occluder);
    const int cols = cells(len, w.spacing_m);
    // Both faces: a wall between two rooms is seen from either side; the back face is culled.
    for (double side : {1.0, -1.0}) {
      for (int i = 0; i < cols; ++i) {
        for (int r = 0; r < rows; ++r) {
          const double s = (i + 0.5) * len / cols + rng.uniform(-w.jitter_m, w.jitter_m);
          const double z = (r + 0.5) * w.height_m / rows + rng.uniform(-w.jitter_m, w.jitter_m);
          const double depth = 0.002 + 0.5 * rng.uniform(0.0, w.jitter_m);  // roughness, on its own side
          const Eigen::Vector2d p = a + s * dir + side * depth * n;
          Scatterer sc;
          sc.position = Eigen::Vector3d(p.x(), p.y(), std::clamp(z, 0.0, w.height_m));
          sc.normal = Eigen::Vector3d(side * n.x(), side * n.y(), 0);
          sc.rcs_m2 = w.rcs_m2 * rng.exponential();
          sc.incidence_exponent = w.incidence_exponent;
          sc.surface = occluder;
          sc.kind = ScattererKind::kWall;
          static_.push_back(sc);
        }
      }
    }
  }
}

void Scene::add_box(const BoxOptions& b, std::uint64_t index) {
  if (!(b.size.x() > 0 && b.size.y() > 0 && b.size.z() > 0))
    throw std::invalid_argument("box '" + b.name + "' needs a positive size");
  detail::Random rng(detail::stream_seed(options_.seed, kBoxStream, index));
  const double yaw = b.yaw_deg * kPi / 180;
  const Eigen::Vector2d ex(std::cos(yaw), std::sin(yaw)), ey(-std::sin(yaw), std::cos(yaw));
  const double hx = b.size.x() / 2, hy = b.size.y() / 2, h = b.size.z();
  // Corners counter-clockwise seen from above, so each face's outward normal is its right normal.
  const Eigen::Vector2d corner[4] = {b.center - hx * ex - hy * ey, b.center + hx * ex - hy * ey,
                                     b.center + hx * ex + hy * ey, b.center - hx * ex + hy * ey};
  const int rows = cells(h, b.spacing_m);
  for (int f = 0; f < 4; ++f) {
    const Eigen::Vector2d a = corner[f], e = corner[(f + 1) % 4];
    const double len = (e - a).norm();
    const Eigen::Vector2d dir = (e - a) / len, n = -left_normal(dir);
    const int occluder = static_cast<int>(occluders_.size());
    occluders_.push_back({a, e, h, -1.0});
    const int cols = cells(len, b.spacing_m);
    for (int i = 0; i < cols; ++i) {
      for (int r = 0; r < rows; ++r) {
        const double s = (i + 0.5) * len / cols + rng.uniform(-b.jitter_m, b.jitter_m);
        const double z = (r + 0.5) * h / rows + rng.uniform(-b.jitter_m, b.jitter_m);
        const Eigen::Vector2d p = a + s * dir + (0.002 + 0.5 * rng.uniform(0.0, b.jitter_m)) * n;
        Scatterer sc;
        sc.position = Eigen::Vector3d(p.x(), p.y(), std::clamp(z, 0.0, h));
        sc.normal = Eigen::Vector3d(n.x(), n.y(), 0);
        sc.rcs_m2 = b.rcs_m2 * rng.exponential();
        sc.incidence_exponent = b.incidence_exponent;
        sc.surface = occluder;
        sc.kind = ScattererKind::kBox;
        static_.push_back(sc);
      }
    }
  }
  if (b.corner_rcs_m2 > 0) {
    for (int f = 0; f < 4; ++f) {
      // Just outside the corner, so neither adjoining face hides it.
      const Eigen::Vector2d out = (corner[f] - b.center).normalized();
      for (int r = 0; r < rows; ++r) {
        const Eigen::Vector2d p = corner[f] + 0.01 * out;
        Scatterer sc;
        sc.position = Eigen::Vector3d(p.x(), p.y(), (r + 0.5) * h / rows);
        sc.rcs_m2 = b.corner_rcs_m2 / rows * rng.exponential();
        sc.kind = ScattererKind::kBox;
        static_.push_back(sc);
      }
    }
  }
}

void Scene::add_pillar(const PillarOptions& p, std::uint64_t index) {
  if (!(p.radius_m > 0 && p.height_m > 0))
    throw std::invalid_argument("pillar '" + p.name + "' needs a positive radius and height");
  detail::Random rng(detail::stream_seed(options_.seed, kPillarStream, index));
  const int cyl = static_cast<int>(cylinders_.size());
  cylinders_.push_back({p.center, p.radius_m, p.height_m});
  const int around = std::max(3, static_cast<int>(std::lround(2 * kPi * p.radius_m / p.spacing_m)));
  const int rows = cells(p.height_m, p.row_spacing_m);
  for (int i = 0; i < around; ++i) {
    for (int r = 0; r < rows; ++r) {
      const double ang = 2 * kPi * (i + 0.5) / around + rng.uniform(-p.jitter_m, p.jitter_m) / p.radius_m;
      const Eigen::Vector2d n(std::cos(ang), std::sin(ang));
      const Eigen::Vector2d pos = p.center + (p.radius_m + 0.002 + 0.5 * rng.uniform(0.0, p.jitter_m)) * n;
      Scatterer sc;
      const double z = (r + 0.5) * p.height_m / rows + rng.uniform(-p.jitter_m, p.jitter_m);
      sc.position = Eigen::Vector3d(pos.x(), pos.y(), z);
      sc.normal = Eigen::Vector3d(n.x(), n.y(), 0);
      sc.rcs_m2 = p.rcs_m2 * rng.exponential();
      sc.incidence_exponent = p.incidence_exponent;
      sc.surface = -2 - cyl;
      sc.kind = ScattererKind::kPillar;
      static_.push_back(sc);
    }
  }
}

void Scene::add_clutter(const ClutterOptions& c, std::uint64_t index) {
  detail::Random rng(detail::stream_seed(options_.seed, kClutterStream, index));
  for (int i = 0; i < c.count; ++i) {
    Scatterer sc;
    sc.position = Eigen::Vector3d(rng.uniform(c.region[0], c.region[2]), rng.uniform(c.region[1], c.region[3]),
                                  rng.uniform(c.z_min_m, c.z_max_m));
    sc.rcs_m2 = c.rcs_m2 * rng.exponential();
    sc.kind = ScattererKind::kClutter;
    static_.push_back(sc);
  }
}

void Scene::add_ghosts(const Scatterer& src, std::vector<Scatterer>& out) const {
  const double max_d = options_.multipath_max_distance_m;
  for (int m : mirrors_) {
    const Occluder& o = occluders_[m];
    const Eigen::Vector2d e = o.b - o.a;
    const double len = e.norm();
    const Eigen::Vector2d dir = e / len, n = left_normal(dir);
    const Eigen::Vector2d p(src.position.x(), src.position.y());
    const double delta = n.dot(p - o.a), along = dir.dot(p - o.a);
    if (std::abs(delta) > max_d || std::abs(delta) < 0.05 || along < -max_d || along > len + max_d) continue;
    if (src.position.z() > o.height) continue;  // above the mirror
    Scatterer g = src;
    const Eigen::Vector2d q = p - 2 * delta * n;
    g.position = Eigen::Vector3d(q.x(), q.y(), src.position.z());
    g.velocity = reflect(src.velocity, n);
    g.acceleration = reflect(src.acceleration, n);
    g.normal = reflect(src.normal, n);
    g.rcs_m2 = src.rcs_m2 * std::pow(10.0, -o.mirror_loss_db / 10);
    g.surface = -1;
    g.mirror = m;
    g.kind = ScattererKind::kGhost;
    out.push_back(g);
  }
}

void Scene::add_static_ghosts() {
  if (mirrors_.empty()) return;
  const std::size_t n = static_.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Scatterer src = static_[i];  // a copy: add_ghosts appends to static_
    if (src.kind == ScattererKind::kWall) continue;
    add_ghosts(src, static_);
  }
}

// ---- dynamic scatterers -------------------------------------------------------------------------

std::size_t Scene::max_dynamic_scatterers() const {
  return people_.size() * kScatterersPerPerson * (1 + mirrors_.size());
}

void Scene::dynamic_scatterers(double t, std::vector<Scatterer>& out) const {
  struct Limb {
    double forward_swing;  // multiple of the swing
    double lateral, height, rcs;
  };
  // Offsets in the walker's frame (x forward, y left); heights and RCS as fractions of the body.
  static constexpr Limb kLimbs[kScatterersPerPerson] = {
      {0, 0, 0.55, 0.3},  {0, 0, 0.72, 0.3},     {0, 0, 0.93, 0.1},   {1, 0.1, 0.28, 0.1},
      {-1, -0.1, 0.28, 0.1}, {-0.6, 0.22, 0.6, 0.05}, {0.6, -0.22, 0.6, 0.05}};
  constexpr double kSwing = 0.25;  // m, leg swing amplitude at walking speed
  for (const Person& person : people_) {
    const RigState s = person.body(t);
    const Eigen::Vector3d h = s.rotation.col(0), l = s.rotation.col(1);
    const double yr = s.angular_velocity.z(), ya = s.angular_acceleration.z();
    // Swing amplitude follows the speed (a standing person does not swing its legs).
    const double q = s.velocity.squaredNorm(), qd = 2 * s.velocity.dot(s.acceleration);
    const double env = q / (q + person.q0), env_d = person.q0 * qd / ((q + person.q0) * (q + person.q0));
    const double w = person.gait_omega, ph = w * t + person.gait_phase;
    const double sw = kSwing * env * std::sin(ph);
    const double sw_d = kSwing * (env_d * std::sin(ph) + env * w * std::cos(ph));
    const double sw_dd = kSwing * (2 * env_d * w * std::cos(ph) - env * w * w * std::sin(ph));
    for (const Limb& limb : kLimbs) {
      const double f = limb.forward_swing * sw, fd = limb.forward_swing * sw_d, fdd = limb.forward_swing * sw_dd;
      const double lat = limb.lateral;
      Scatterer sc;
      sc.position = s.position + f * h + lat * l + Eigen::Vector3d(0, 0, limb.height * person.options.height_m);
      // d/dt h = yaw_rate l, d/dt l = -yaw_rate h.
      sc.velocity = s.velocity + fd * h + (f * yr) * l - (lat * yr) * h;
      sc.acceleration = s.acceleration + fdd * h + 2 * fd * yr * l + f * (ya * l - yr * yr * h) -
                        lat * (ya * h + yr * yr * l);
      sc.rcs_m2 = limb.rcs * person.options.rcs_m2;
      sc.kind = ScattererKind::kPerson;
      out.push_back(sc);
      if (!mirrors_.empty()) add_ghosts(sc, out);
    }
  }
}

// ---- visibility ---------------------------------------------------------------------------------

void Scene::nearby(const Eigen::Vector3d& from, double range, std::vector<int>& occ, std::vector<int>& cyl) const {
  occ.clear();
  cyl.clear();
  const Eigen::Vector2d p(from.x(), from.y());
  for (std::size_t i = 0; i < occluders_.size(); ++i)
    if (distance_to_segment(p, occluders_[i].a, occluders_[i].b) <= range) occ.push_back(static_cast<int>(i));
  for (std::size_t i = 0; i < cylinders_.size(); ++i)
    if ((cylinders_[i].center - p).norm() - cylinders_[i].radius <= range) cyl.push_back(static_cast<int>(i));
}

bool Scene::line_of_sight(const Eigen::Vector3d& from, const Scatterer& s, const std::vector<int>& occ,
                          const std::vector<int>& cyl) const {
  const Eigen::Vector2d r(from.x(), from.y()), q(s.position.x(), s.position.y());
  const double plan = (q - r).norm();
  if (plan < 1e-9) return true;
  // Stop 1 mm short of the scatterer: it may sit right at the edge of a neighbouring surface.
  double t_end = 1.0 - 1e-3 / plan;
  auto z_at = [&](double t) { return from.z() + t * (s.position.z() - from.z()); };
  if (s.mirror >= 0) {
    const Occluder& m = occluders_[s.mirror];
    const double t = crossing(r, q, m.a, m.b);
    if (!(t > 0 && t < 1)) return false;
    const double z = z_at(t);
    if (z < 0 || z > m.height) return false;
    t_end = t;
  }
  for (int i : occ) {
    if (i == s.surface || i == s.mirror) continue;
    const Occluder& o = occluders_[i];
    const double t = crossing(r, q, o.a, o.b);
    if (t > 0 && t < t_end && z_at(t) < o.height) return false;
  }
  for (int i : cyl) {
    if (-2 - i == s.surface) continue;
    const Cylinder& c = cylinders_[i];
    // First entry of the plan-view ray r + t (q - r) into the circle.
    const Eigen::Vector2d d = q - r, f = r - c.center;
    const double a = d.squaredNorm(), b = 2 * f.dot(d), cc = f.squaredNorm() - c.radius * c.radius;
    const double disc = b * b - 4 * a * cc;
    if (disc <= 0) continue;
    const double t = (-b - std::sqrt(disc)) / (2 * a);
    if (t > 0 && t < t_end && z_at(t) < c.height) return false;
  }
  return true;
}

}  // namespace rsrio::sim

#include "rsrio/sim/motion.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace rsrio::sim {

namespace {

constexpr double kPi = std::numbers::pi;

double wrap_angle(double a) {
  a = std::fmod(a + kPi, 2 * kPi);
  if (a < 0) a += 2 * kPi;
  return a - kPi;
}

// Uniform cubic B-spline basis on one knot interval, u in [0, 1], and its u-derivatives.
struct Basis {
  double b[4], d1[4], d2[4], d3[4];
  explicit Basis(double u) {
    const double u2 = u * u, u3 = u2 * u, w = 1 - u;
    b[0] = w * w * w / 6;
    b[1] = (3 * u3 - 6 * u2 + 4) / 6;
    b[2] = (-3 * u3 + 3 * u2 + 3 * u + 1) / 6;
    b[3] = u3 / 6;
    d1[0] = -w * w / 2;
    d1[1] = (3 * u2 - 4 * u) / 2;
    d1[2] = (-3 * u2 + 2 * u + 1) / 2;
    d1[3] = u2 / 2;
    d2[0] = w;
    d2[1] = 3 * u - 2;
    d2[2] = -3 * u + 1;
    d2[3] = u;
    d3[0] = -1;
    d3[1] = 3;
    d3[2] = -3;
    d3[3] = 1;
  }
};

// A sway term env(t) * sin(rate * t + phase) with its first two time derivatives.
struct Sway {
  double value, rate, acc;
};
Sway sway(double amplitude, double env, double env_d, double env_dd, double omega, double t, double phase) {
  const double s = std::sin(omega * t + phase), c = std::cos(omega * t + phase);
  return {amplitude * env * s, amplitude * (env_d * s + env * omega * c),
          amplitude * (env_dd * s + 2 * env_d * omega * c - env * omega * omega * s)};
}

}  // namespace

Eigen::Matrix3d rotation_from_rpy(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

RigState attached(const RigState& parent, const Mount& mount) {
  RigState c;
  c.time = parent.time;
  const Eigen::Vector3d& w = parent.angular_velocity;
  const Eigen::Vector3d& alpha = parent.angular_acceleration;
  const Eigen::Vector3d& l = mount.translation;
  c.position = parent.position + parent.rotation * l;
  c.rotation = parent.rotation * mount.rotation;
  c.velocity = parent.velocity + parent.rotation * w.cross(l);
  c.acceleration = parent.acceleration + parent.rotation * (alpha.cross(l) + w.cross(w.cross(l)));
  c.angular_velocity = mount.rotation.transpose() * w;
  c.angular_acceleration = mount.rotation.transpose() * alpha;
  return c;
}

// ---- simple motions ---------------------------------------------------------------------------

StaticMotion::StaticMotion(Eigen::Vector3d position, Eigen::Matrix3d rotation)
    : position_(std::move(position)), rotation_(std::move(rotation)) {}

RigState StaticMotion::state(double t) const {
  RigState s;
  s.time = t;
  s.position = position_;
  s.rotation = rotation_;
  return s;
}

LinearMotion::LinearMotion(Eigen::Vector3d start, Eigen::Vector3d velocity, Eigen::Matrix3d rotation,
                           double duration_s)
    : start_(std::move(start)), velocity_(std::move(velocity)), rotation_(std::move(rotation)),
      duration_(duration_s) {}

RigState LinearMotion::state(double t) const {
  RigState s;
  s.time = t;
  s.position = start_ + velocity_ * t;
  s.rotation = rotation_;
  s.velocity = velocity_;
  return s;
}

CircularMotion::CircularMotion(Eigen::Vector3d center, double radius_m, double angular_rate_rad_s, double duration_s)
    : center_(std::move(center)), radius_(radius_m), rate_(angular_rate_rad_s), duration_(duration_s) {}

RigState CircularMotion::state(double t) const {
  const double phi = rate_ * t, c = std::cos(phi), s = std::sin(phi);
  RigState st;
  st.time = t;
  st.position = center_ + radius_ * Eigen::Vector3d(c, s, 0);
  st.velocity = radius_ * rate_ * Eigen::Vector3d(-s, c, 0);
  st.acceleration = -radius_ * rate_ * rate_ * Eigen::Vector3d(c, s, 0);
  // Body x along the direction of travel.
  const double yaw = phi + (rate_ >= 0 ? kPi / 2 : -kPi / 2);
  st.rotation = rotation_from_rpy(0, 0, yaw);
  st.angular_velocity = Eigen::Vector3d(0, 0, rate_);
  return st;
}

// ---- the walking trajectory -------------------------------------------------------------------

SplineTrajectory::SplineTrajectory(const TrajectoryOptions& o) : options_(o) {
  const auto& w = o.waypoints;
  const std::size_t n_seg = w.size() < 2 ? 0 : w.size() - 1;
  if (w.size() < 2) throw std::invalid_argument("a trajectory needs at least two waypoints");
  if (!(o.knot_interval_s > 0)) throw std::invalid_argument("knot_interval_s must be positive");
  if (!o.segment_speeds_mps.empty() && o.segment_speeds_mps.size() != n_seg)
    throw std::invalid_argument("segment_speeds_mps needs one speed per segment (" + std::to_string(n_seg) + ")");
  if (!o.pauses_s.empty() && o.pauses_s.size() != w.size())
    throw std::invalid_argument("pauses_s needs one entry per waypoint (" + std::to_string(w.size()) + ")");
  std::vector<double> speed(n_seg, o.speed_mps), pause(w.size(), 0.0), heading(n_seg);
  if (!o.segment_speeds_mps.empty()) speed = o.segment_speeds_mps;
  if (!o.pauses_s.empty()) pause = o.pauses_s;
  for (std::size_t j = 0; j < n_seg; ++j) {
    const Eigen::Vector2d d = w[j + 1] - w[j];
    if (d.norm() < 1e-6)
      throw std::invalid_argument("waypoints " + std::to_string(j) + " and " + std::to_string(j + 1) + " coincide");
    if (!(speed[j] > 0)) throw std::invalid_argument("walking speeds must be positive");
    // Headings unwrapped along the path so the heading spline never turns the long way round.
    const double raw = std::atan2(d.y(), d.x());
    heading[j] = j == 0 ? raw : heading[j - 1] + wrap_angle(raw - heading[j - 1]);
  }
  for (double p : pause)
    if (p < 0) throw std::invalid_argument("pauses must not be negative");
  if (o.still_start_s < 0 || o.still_end_s < 0) throw std::invalid_argument("still times must not be negative");

  dt_ = o.knot_interval_s;
  // Arc length of every waypoint along the polyline, and of every walking control point (-1 for
  // the coincident points of a stand): the heading is blended around corners by arc length.
  std::vector<double> waypoint_s(w.size(), 0.0);
  for (std::size_t j = 0; j < n_seg; ++j) waypoint_s[j + 1] = waypoint_s[j] + (w[j + 1] - w[j]).norm();
  std::vector<double> control_s;
  // k coincident control points hold the spline still for (k - 3) knot intervals, and the
  // spline leaves and reaches them with zero velocity and acceleration. A change of heading
  // while standing is a linear ramp over the stand (turning on the spot).
  auto stand = [&](const Eigen::Vector2d& p, double seconds, double yaw_in, double yaw_out) {
    const int k = 3 + static_cast<int>(std::lround(seconds / dt_));
    for (int i = 0; i < k; ++i) {
      const double f = k > 3 ? std::clamp((i - 1.0) / (k - 3.0), 0.0, 1.0) : (i < k / 2 ? 0.0 : 1.0);
      control_.push_back(p);
      control_s.push_back(-1);
      yaw_control_.push_back(yaw_in + f * (yaw_out - yaw_in));
    }
  };
  stand(w[0], o.still_start_s, heading[0], heading[0]);
  // Walk the polyline in steps of speed * dt; a step that would pass a waypoint where the walker
  // stops (a pause, or the end) ends on it instead.
  std::size_t seg = 0;
  double along = 0;  // distance from w[seg] along segment seg
  while (seg < n_seg) {
    double step = speed[seg] * dt_;
    bool stopped = false;
    while (true) {
      const double len = (w[seg + 1] - w[seg]).norm();
      if (along + step < len - 1e-9) {
        along += step;
        break;
      }
      step -= len - along;
      const std::size_t wp = seg + 1;
      ++seg;
      along = 0;
      if (seg == n_seg) {
        stand(w[wp], o.still_end_s, heading[n_seg - 1], heading[n_seg - 1]);
        stopped = true;
        break;
      }
      if (pause[wp] > 0) {
        stand(w[wp], pause[wp], heading[wp - 1], heading[wp]);
        stopped = true;
        break;
      }
      if (step <= 1e-9) break;  // landed exactly on a waypoint
    }
    if (seg == n_seg) break;
    if (stopped) continue;
    const Eigen::Vector2d dir = (w[seg + 1] - w[seg]).normalized();
    control_.push_back(w[seg] + along * dir);
    control_s.push_back(waypoint_s[seg] + along);
    yaw_control_.push_back(heading[seg]);
  }
  // Walking round a corner, the heading turns linearly over +-turn_distance_m of arc length (at
  // most half of either adjoining segment) instead of jumping between two control points.
  for (std::size_t c = 1; c + 1 < w.size(); ++c) {
    if (pause[c] > 0) continue;
    const double half = std::min({o.turn_distance_m, 0.5 * (waypoint_s[c] - waypoint_s[c - 1]),
                                  0.5 * (waypoint_s[c + 1] - waypoint_s[c])});
    if (half <= 0) continue;
    for (std::size_t i = 0; i < control_.size(); ++i) {
      const double ds = control_s[i] - waypoint_s[c];
      if (control_s[i] < 0 || std::abs(ds) >= half) continue;
      yaw_control_[i] = heading[c - 1] + (heading[c] - heading[c - 1]) * (ds + half) / (2 * half);
    }
  }
  duration_ = static_cast<double>(control_.size() - 3) * dt_;
  // The sway follows the speed through env = q / (q + q0), q = |v|^2: zero when standing, about
  // 0.92 at the nominal speed.
  double mean_speed = 0;
  for (double v : speed) mean_speed += v;
  mean_speed /= static_cast<double>(speed.size());
  envelope_q0_ = std::pow(0.3 * mean_speed, 2);
}

SplineTrajectory::Planar SplineTrajectory::planar(double t) const {
  const int n = static_cast<int>(control_.size());
  const double tt = std::clamp(t, 0.0, duration_);
  int j = static_cast<int>(std::floor(tt / dt_));
  j = std::clamp(j, 0, n - 4);
  const double u = tt / dt_ - j;
  const Basis b(u);
  Planar out{Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(),
             0, 0, 0};
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d& p = control_[j + k];
    const double y = yaw_control_[j + k];
    out.p += b.b[k] * p;
    out.v += b.d1[k] * p;
    out.a += b.d2[k] * p;
    out.j += b.d3[k] * p;
    out.yaw += b.b[k] * y;
    out.yaw_rate += b.d1[k] * y;
    out.yaw_acc += b.d2[k] * y;
  }
  if (t < 0 || t > duration_) {
    // Outside the spline the walker stands (the ends are at rest by construction anyway).
    out.v.setZero();
    out.a.setZero();
    out.j.setZero();
    out.yaw_rate = out.yaw_acc = 0;
    return out;
  }
  out.v /= dt_;
  out.a /= dt_ * dt_;
  out.j /= dt_ * dt_ * dt_;
  out.yaw_rate /= dt_;
  out.yaw_acc /= dt_ * dt_;
  return out;
}

double SplineTrajectory::speed(double t) const { return planar(t).v.norm(); }

RigState SplineTrajectory::state(double t) const {
  const Planar pl = planar(t);
  const TrajectoryOptions& o = options_;
  // Walking envelope env(q) = q / (q + q0) of q = |v|^2 and its time derivatives.
  const double q = pl.v.squaredNorm();
  const double qd = 2 * pl.v.dot(pl.a);
  const double qdd = 2 * (pl.a.squaredNorm() + pl.v.dot(pl.j));
  const double q0 = envelope_q0_;
  const double den = q + q0;
  const double env = q / den;
  const double env_d = q0 * qd / (den * den);
  const double env_dd = q0 * (qdd * den - 2 * qd * qd) / (den * den * den);
  const double omega = 2 * kPi * o.step_frequency_hz;
  const double deg = kPi / 180;
  const Sway bob = sway(o.bob_amplitude_m, env, env_d, env_dd, omega, t, 0.0);
  const Sway roll = sway(o.roll_amplitude_deg * deg, env, env_d, env_dd, omega / 2, t, 0.7);
  const Sway pitch = sway(o.pitch_amplitude_deg * deg, env, env_d, env_dd, omega, t, 1.9);

  RigState s;
  s.time = t;
  s.position = Eigen::Vector3d(pl.p.x(), pl.p.y(), o.height_m + bob.value);
  s.velocity = Eigen::Vector3d(pl.v.x(), pl.v.y(), bob.rate);
  s.acceleration = Eigen::Vector3d(pl.a.x(), pl.a.y(), bob.acc);
  const double r = roll.value, p = pitch.value, y = pl.yaw;
  const double rd = roll.rate, pd = pitch.rate, yd = pl.yaw_rate;
  const double rdd = roll.acc, pdd = pitch.acc, ydd = pl.yaw_acc;
  s.rotation = rotation_from_rpy(r, p, y);
  const double sr = std::sin(r), cr = std::cos(r), sp = std::sin(p), cp = std::cos(p);
  // Body rates of R = Rz(y) Ry(p) Rx(r) and their time derivatives.
  s.angular_velocity = Eigen::Vector3d(rd - yd * sp, pd * cr + yd * sr * cp, -pd * sr + yd * cr * cp);
  s.angular_acceleration =
      Eigen::Vector3d(rdd - ydd * sp - yd * pd * cp,
                      pdd * cr - pd * rd * sr + ydd * sr * cp + yd * (rd * cr * cp - pd * sr * sp),
                      -pdd * sr - pd * rd * cr + ydd * cr * cp + yd * (-rd * sr * cp - pd * cr * sp));
  return s;
}

double SplineTrajectory::length() const {
  // 5-point Gauss-Legendre per knot interval: the speed is the root of a quartic there, smooth
  // except where it passes through zero, so this is accurate to well below a millimetre.
  static constexpr double x[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831,
                                  0.9061798459386640};
  static constexpr double wt[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889, 0.4786286704993665,
                                   0.2369268850561891};
  double total = 0;
  const int intervals = static_cast<int>(control_.size()) - 3;
  for (int i = 0; i < intervals; ++i)
    for (int k = 0; k < 5; ++k) total += wt[k] * 0.5 * dt_ * speed((i + 0.5 + 0.5 * x[k]) * dt_);
  return total;
}

}  // namespace rsrio::sim

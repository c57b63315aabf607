#include "rsrio/eval/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <Eigen/SVD>

namespace rsrio::eval {

Trajectory read_tum(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  Trajectory out;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream s(line);
    StampedPose p;
    double qx, qy, qz, qw;
    if (!(s >> p.t >> p.p.x() >> p.p.y() >> p.p.z() >> qx >> qy >> qz >> qw))
      throw std::runtime_error(path + ":" + std::to_string(n) + ": expected 'timestamp tx ty tz qx qy qz qw'");
    p.q = Eigen::Quaterniond(qw, qx, qy, qz);
    if (std::abs(p.q.norm() - 1.0) > 1e-3)
      throw std::runtime_error(path + ":" + std::to_string(n) + ": quaternion is not unit length");
    p.q.normalize();
    if (!out.empty() && p.t <= out.back().t)
      throw std::runtime_error(path + ":" + std::to_string(n) + ": timestamps must increase");
    out.push_back(p);
  }
  return out;
}

void write_tum(const std::string& path, const Trajectory& t) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot write");
  out << std::fixed;
  for (const auto& p : t)
    out << std::setprecision(9) << p.t << ' ' << std::setprecision(6) << p.p.x() << ' ' << p.p.y() << ' ' << p.p.z()
        << ' ' << std::setprecision(9) << p.q.x() << ' ' << p.q.y() << ' ' << p.q.z() << ' ' << p.q.w() << '\n';
  if (!out) throw std::runtime_error(path + ": write failed");
}

void associate(const Trajectory& ref, const Trajectory& est, double max_dt, Trajectory& ref_out, Trajectory& est_out) {
  // As evo's associate_trajectories: every stamp of the SHORTER trajectory takes the nearest stamp
  // of the longer one (first of equals, as np.argmin), if within max_dt. So a 200 Hz ground truth
  // against a 10 Hz estimate gives one pair per estimate, not one per ground-truth sample.
  ref_out.clear();
  est_out.clear();
  if (est.empty() || ref.empty()) return;
  const bool est_shorter = est.size() < ref.size();
  const Trajectory& shorter = est_shorter ? est : ref;
  const Trajectory& longer = est_shorter ? ref : est;
  std::size_t j = 0;
  for (const auto& a : shorter) {
    while (j + 1 < longer.size() && std::abs(longer[j + 1].t - a.t) < std::abs(longer[j].t - a.t)) ++j;
    if (std::abs(longer[j].t - a.t) <= max_dt) {
      ref_out.push_back(est_shorter ? longer[j] : a);
      est_out.push_back(est_shorter ? a : longer[j]);
    }
  }
}

Trajectory resampled(const Trajectory& t, const std::vector<double>& stamps, double max_gap_s) {
  Trajectory out;
  out.reserve(stamps.size());
  std::size_t j = 0;  // t[j].t <= stamp < t[j + 1].t
  for (const double s : stamps) {
    if (t.size() < 2 || s < t.front().t || s > t.back().t) continue;
    while (j + 2 < t.size() && t[j + 1].t <= s) ++j;
    const StampedPose& a = t[j];
    const StampedPose& b = t[j + 1];
    if (b.t - a.t > max_gap_s) continue;
    const double w = b.t > a.t ? (s - a.t) / (b.t - a.t) : 0.0;
    out.push_back({s, (1 - w) * a.p + w * b.p, a.q.slerp(w, b.q).normalized()});
  }
  return out;
}

Alignment parse_alignment(const std::string& name) {
  if (name == "none") return Alignment::kNone;
  if (name == "se3") return Alignment::kSE3;
  if (name == "se2") return Alignment::kSE2;
  throw std::invalid_argument("alignment '" + name + "': expected se3, se2 or none");
}

Eigen::Isometry3d umeyama(const Trajectory& ref, const Trajectory& est, Alignment alignment) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (alignment == Alignment::kNone || ref.empty()) return T;
  const std::size_t n = std::min(ref.size(), est.size());
  Eigen::Vector3d mr = Eigen::Vector3d::Zero(), me = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    mr += ref[i].p;
    me += est[i].p;
  }
  mr /= double(n);
  me /= double(n);
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  if (alignment == Alignment::kSE3) {
    Eigen::Matrix3d S = Eigen::Matrix3d::Zero();  // covariance of ref vs est
    for (std::size_t i = 0; i < n; ++i) S += (ref[i].p - mr) * (est[i].p - me).transpose();
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(S, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
    if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) D(2, 2) = -1;
    R = svd.matrixU() * D * svd.matrixV().transpose();
  } else {
    // Yaw only: maximise sum of rotated xy dot products -> atan2 of cross and dot sums.
    double sdot = 0, scross = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector2d a = (est[i].p - me).head<2>(), b = (ref[i].p - mr).head<2>();
      sdot += a.dot(b);
      scross += a.x() * b.y() - a.y() * b.x();
    }
    R = Eigen::AngleAxisd(std::atan2(scross, sdot), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  }
  T.linear() = R;
  T.translation() = mr - R * me;
  return T;
}

Trajectory transformed(const Trajectory& t, const Eigen::Isometry3d& T) {
  Trajectory out = t;
  const Eigen::Quaterniond qT(T.rotation());
  for (auto& p : out) {
    p.p = T * p.p;
    p.q = (qT * p.q).normalized();
  }
  return out;
}

ErrorStats stats(std::vector<double> e) {
  ErrorStats s;
  s.count = e.size();
  if (e.empty()) return s;
  const double n = double(e.size());
  double sum = 0, sq = 0;
  for (double v : e) {
    sum += v;
    sq += v * v;
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(sq / n);
  s.std = std::sqrt(std::max(0.0, sq / n - s.mean * s.mean));  // population std, as numpy/evo
  std::sort(e.begin(), e.end());
  s.min = e.front();
  s.max = e.back();
  s.median = e.size() % 2 ? e[e.size() / 2] : 0.5 * (e[e.size() / 2 - 1] + e[e.size() / 2]);
  return s;
}

double path_length(const Trajectory& t) {
  double l = 0;
  for (std::size_t i = 1; i < t.size(); ++i) l += (t[i].p - t[i - 1].p).norm();
  return l;
}

namespace {
double rotation_angle_deg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return Eigen::AngleAxisd(a.conjugate() * b).angle() * 180.0 / M_PI;
}

// Heading and tilt of the world-frame error est ref^-1 (ApeResult). The twist about z of a unit
// quaternion (w, x, y, z) is 2 atan2(z, w); the tilt is where the error sends the vertical.
std::pair<double, double> heading_tilt_deg(const Eigen::Quaterniond& ref, const Eigen::Quaterniond& est) {
  const Eigen::Quaterniond w = (est * ref.conjugate()).normalized();
  double heading = 2 * std::atan2(w.z(), w.w());
  heading = std::remainder(heading, 2 * M_PI);
  const double up = std::clamp((w * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0);
  return {heading * 180.0 / M_PI, std::acos(up) * 180.0 / M_PI};
}
}  // namespace

ApeResult ape(const Trajectory& ref, const Trajectory& est, Alignment alignment) {
  if (ref.size() != est.size()) throw std::invalid_argument("ape: trajectories must be associated first");
  ApeResult r;
  r.alignment = umeyama(ref, est, alignment);
  const Trajectory aligned = transformed(est, r.alignment);
  std::vector<double> et, er, eh, ez;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    et.push_back((ref[i].p - aligned[i].p).norm());
    er.push_back(rotation_angle_deg(ref[i].q, aligned[i].q));
    const auto [heading, tilt] = heading_tilt_deg(ref[i].q, aligned[i].q);
    eh.push_back(heading);
    ez.push_back(tilt);
  }
  r.translation_m = stats(et);
  r.rotation_deg = stats(er);
  r.heading_deg = stats(eh);
  r.tilt_deg = stats(ez);
  r.path_length_m = path_length(ref);
  return r;
}

RpeResult rpe(const Trajectory& ref, const Trajectory& est, double delta_m) {
  if (ref.size() != est.size()) throw std::invalid_argument("rpe: trajectories must be associated first");
  // evo filter_pairs_by_path (all_pairs=False) on the ESTIMATE's path, as evo_rpe does by default
  // (pairs_from_reference=False): consecutive pairs whenever delta metres have been travelled.
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  std::size_t last = 0;
  double travelled = 0;
  for (std::size_t i = 1; i < est.size(); ++i) {
    travelled += (est[i].p - est[i - 1].p).norm();
    if (travelled >= delta_m) {
      pairs.emplace_back(last, i);
      last = i;
      travelled = 0;
    }
  }
  auto pose = [](const StampedPose& p) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = p.q.toRotationMatrix();
    T.translation() = p.p;
    return T;
  };
  std::vector<double> et, er;
  for (auto [i, j] : pairs) {
    const Eigen::Isometry3d dref = pose(ref[i]).inverse() * pose(ref[j]);
    const Eigen::Isometry3d dest = pose(est[i]).inverse() * pose(est[j]);
    const Eigen::Isometry3d e = dref.inverse() * dest;
    et.push_back(e.translation().norm());
    er.push_back(Eigen::AngleAxisd(e.rotation()).angle() * 180.0 / M_PI);
  }
  return {stats(et), stats(er)};
}

namespace {
// Planar velocity of the reference at pose i: central difference (one-sided at the ends).
Eigen::Vector2d planar_velocity(const Trajectory& t, std::size_t i) {
  const std::size_t a = i > 0 ? i - 1 : i, b = i + 1 < t.size() ? i + 1 : i;
  const double dt = t[b].t - t[a].t;
  if (b == a || !(dt > 0)) return Eigen::Vector2d::Zero();
  return (t[b].p - t[a].p).head<2>() / dt;
}
}  // namespace

TrackErrors track_errors(const Trajectory& ref, const Trajectory& est_aligned, double min_speed_mps) {
  if (ref.size() != est_aligned.size()) throw std::invalid_argument("track_errors: trajectories must be associated first");
  std::vector<double> along, across;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    const Eigen::Vector2d v = planar_velocity(ref, i);
    const double speed = v.norm();
    if (!(speed >= min_speed_mps) || speed == 0) continue;
    const Eigen::Vector2d d = v / speed, e = (est_aligned[i].p - ref[i].p).head<2>();
    along.push_back(e.dot(d));
    across.push_back(d.x() * e.y() - d.y() * e.x());  // d x e: positive to the left
  }
  return {stats(along), stats(across)};
}

std::vector<Leg> straight_legs(const Trajectory& ref, const Trajectory& est, double stop_speed_mps,
                               double max_turn_deg, double min_duration_s) {
  if (ref.size() != est.size()) throw std::invalid_argument("straight_legs: trajectories must be associated first");
  const double cos_max_turn = std::cos(max_turn_deg * M_PI / 180.0);
  std::vector<Leg> legs;
  std::size_t i = 0;
  while (i < ref.size()) {
    const Eigen::Vector2d v0 = planar_velocity(ref, i);
    const double speed0 = v0.norm();
    if (speed0 < stop_speed_mps || speed0 == 0) {
      ++i;
      continue;
    }
    const Eigen::Vector2d d0 = v0 / speed0;
    auto straight_on = [&](std::size_t k) {
      const Eigen::Vector2d v = planar_velocity(ref, k);
      const double speed = v.norm();
      return speed >= stop_speed_mps && speed > 0 && v.dot(d0) >= cos_max_turn * speed;
    };
    std::size_t j = i;
    while (j + 1 < ref.size() && straight_on(j + 1)) ++j;
    if (ref[j].t - ref[i].t >= min_duration_s) {
      const Eigen::Vector2d dr = (ref[j].p - ref[i].p).head<2>(), de = (est[j].p - est[i].p).head<2>();
      legs.push_back({ref[i].t, ref[j].t, std::atan2(dr.y(), dr.x()) * 180.0 / M_PI, dr.norm(), de.norm()});
    }
    i = j + 1;
  }
  return legs;
}

}  // namespace rsrio::eval

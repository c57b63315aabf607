#include "rsrio/splat/pose.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace rsrio::splat {

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

Eigen::Matrix3d so3_exp(const Eigen::Vector3d& omega) {
  const double theta2 = omega.squaredNorm();
  const Eigen::Matrix3d k = skew(omega);
  double a, b;  // sin(t)/t, (1 - cos t)/t^2
  if (theta2 < 1e-10) {
    a = 1.0 - theta2 / 6.0;
    b = 0.5 - theta2 / 24.0;
  } else {
    const double theta = std::sqrt(theta2);
    a = std::sin(theta) / theta;
    b = (1.0 - std::cos(theta)) / theta2;
  }
  return Eigen::Matrix3d::Identity() + a * k + b * k * k;
}

Eigen::Isometry3d se3_exp(const Vector6d& delta) {
  const Eigen::Vector3d rho = delta.head<3>();
  const Eigen::Vector3d omega = delta.tail<3>();
  const double theta2 = omega.squaredNorm();
  const Eigen::Matrix3d k = skew(omega);
  double b, c;  // (1 - cos t)/t^2, (t - sin t)/t^3
  if (theta2 < 1e-10) {
    b = 0.5 - theta2 / 24.0;
    c = 1.0 / 6.0 - theta2 / 120.0;
  } else {
    const double theta = std::sqrt(theta2);
    b = (1.0 - std::cos(theta)) / theta2;
    c = (theta - std::sin(theta)) / (theta2 * theta);
  }
  const Eigen::Matrix3d v = Eigen::Matrix3d::Identity() + b * k + c * k * k;
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = so3_exp(omega);
  t.translation() = v * rho;
  return t;
}

void apply_left_increment(Eigen::Isometry3d& radar_T_world, const Vector6d& delta) {
  radar_T_world = se3_exp(delta) * radar_T_world;
  // Re-orthonormalise so that rounding never accumulates over thousands of increments.
  const Eigen::Quaterniond q(radar_T_world.linear());
  radar_T_world.linear() = q.normalized().toRotationMatrix();
}

Eigen::Isometry3d PlanarPose::world_T_radar() const {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  t.translation() = Eigen::Vector3d(x, y, z);
  return t;
}

PlanarPose PlanarPose::from_world_T_radar(const Eigen::Isometry3d& world_T_radar) {
  const Eigen::Matrix3d& r = world_T_radar.linear();
  PlanarPose p;
  p.yaw = std::atan2(r(1, 0), r(0, 0));
  p.pitch = std::asin(std::clamp(-r(2, 0), -1.0, 1.0));
  p.roll = std::atan2(r(2, 1), r(2, 2));
  p.x = world_T_radar.translation().x();
  p.y = world_T_radar.translation().y();
  p.z = world_T_radar.translation().z();
  return p;
}

Eigen::Matrix<double, 6, 3> left_increment_jacobian(const PlanarPose& pose) {
  // p_radar = R_wr^T (p_world - c). A change dc of the position moves radar-frame points by
  // -R_wr^T dc (rho); a change of yaw rotates the world about z: R_wr <- Rz(d) R_wr, which is
  // the left increment omega = -d R_wr^T e_z.
  const Eigen::Matrix3d r_wr = pose.world_T_radar().linear();
  Eigen::Matrix<double, 6, 3> j = Eigen::Matrix<double, 6, 3>::Zero();
  j.block<3, 1>(0, 0) = -r_wr.transpose().col(0);
  j.block<3, 1>(0, 1) = -r_wr.transpose().col(1);
  j.block<3, 1>(3, 2) = -r_wr.transpose().col(2);
  return j;
}

Eigen::Vector3d planar_gradient(const PlanarPose& pose, const Vector6d& grad_left) {
  return left_increment_jacobian(pose).transpose() * grad_left;
}

RadarVelocity radar_velocity_from_poses(const Eigen::Isometry3d& radar_T_world_current,
                                        const Eigen::Isometry3d& radar_T_world_previous, double dt) {
  if (!(dt > 0) || !std::isfinite(dt))
    throw std::invalid_argument("radar_velocity_from_poses: dt must be positive");
  const Eigen::Matrix3d& r_k = radar_T_world_current.linear();
  const Eigen::Matrix3d& r_km1 = radar_T_world_previous.linear();
  const Eigen::Vector3d c_k = -r_k.transpose() * radar_T_world_current.translation();
  const Eigen::Vector3d c_km1 = -r_km1.transpose() * radar_T_world_previous.translation();
  RadarVelocity out;
  out.velocity = r_k * (c_k - c_km1) / dt;
  // Left increment (rho, omega) of T_k: c_k moves by -R_k^T rho and R_k <- Exp(omega) R_k, so
  // v <- v + omega x v - rho / dt.
  out.d_current.leftCols<3>() = -Eigen::Matrix3d::Identity() / dt;
  out.d_current.rightCols<3>() = -skew(out.velocity);
  // Left increment of T_{k-1}: c_{k-1} moves by -R_{k-1}^T rho; a pure rotation about the radar
  // origin leaves the position alone.
  out.d_previous.leftCols<3>() = r_k * r_km1.transpose() / dt;
  out.d_previous.rightCols<3>().setZero();
  return out;
}

namespace {

double wrap_angle(double a) { return std::remainder(a, 2.0 * std::numbers::pi); }

// R(yaw)^T (p_b - p_a) in the plane.
Eigen::Vector2d planar_displacement(const PlanarPose& a, const PlanarPose& b) {
  const double c = std::cos(a.yaw), s = std::sin(a.yaw);
  const double dx = b.x - a.x, dy = b.y - a.y;
  return {c * dx + s * dy, -s * dx + c * dy};
}

}  // namespace

double planar_yaw_prior(const PlanarPose& pose, double yaw_odom, double sigma, Eigen::Vector3d* grad) {
  if (!(sigma > 0)) throw std::invalid_argument("planar_yaw_prior: sigma must be positive");
  const double w = wrap_angle(pose.yaw - yaw_odom);
  if (grad != nullptr) grad->z() += w / (sigma * sigma);
  return 0.5 * w * w / (sigma * sigma);
}

double planar_relative_prior(const PlanarPose& a, const PlanarPose& b, const PlanarPose& a_odom,
                             const PlanarPose& b_odom, double sigma_t, double sigma_r, Eigen::Vector3d* grad_a,
                             Eigen::Vector3d* grad_b, double sigma_across) {
  if (!(sigma_t > 0) || !(sigma_r > 0) || !(sigma_across >= 0))
    throw std::invalid_argument("planar_relative_prior: sigmas must be positive (sigma_across >= 0)");
  const Eigen::Vector2d d_odom = planar_displacement(a_odom, b_odom);
  const Eigen::Vector2d u = planar_displacement(a, b) - d_odom;
  const double w = wrap_angle(b.yaw - a.yaw - (b_odom.yaw - a_odom.yaw));
  const double it2 = 1.0 / (sigma_t * sigma_t), ir2 = 1.0 / (sigma_r * sigma_r);
  // Split along and across the frontend's displacement when that is long enough to have a
  // direction n: the across part of u weighs 1 / sigma_across^2 instead of 1 / sigma_t^2, added as
  // `extra` (n^T u) n on top of the isotropic term (exactly zero when off, so that the isotropic
  // prior computes as it always did and the tables replay to the last digit).
  Eigen::Vector2d n = Eigen::Vector2d::Zero();
  double extra = 0;
  if (sigma_across > 0 && d_odom.norm() >= kAcrossMinDisplacementM) {
    n = Eigen::Vector2d(-d_odom.y(), d_odom.x()).normalized();
    extra = (1.0 / (sigma_across * sigma_across) - it2) * n.dot(u);
  }
  const double c = std::cos(a.yaw), s = std::sin(a.yaw);
  auto rotate = [&](const Eigen::Vector2d& v) { return Eigen::Vector2d(c * v.x() - s * v.y(), s * v.x() + c * v.y()); };
  // d u / d p_b = R^T, d u / d p_a = -R^T, d u / d yaw_a = dR^T/dyaw (p_b - p_a).
  const Eigen::Vector2d g_pb = it2 * rotate(u) + extra * rotate(n);  // R (information u)
  const double dx = b.x - a.x, dy = b.y - a.y;
  const Eigen::Vector2d du_dyaw(-s * dx + c * dy, -c * dx - s * dy);
  if (grad_a != nullptr)
    *grad_a += Eigen::Vector3d(-g_pb.x(), -g_pb.y(), it2 * u.dot(du_dyaw) + extra * n.dot(du_dyaw) - ir2 * w);
  if (grad_b != nullptr) *grad_b += Eigen::Vector3d(g_pb.x(), g_pb.y(), ir2 * w);
  return 0.5 * (it2 * u.squaredNorm() + extra * n.dot(u) + ir2 * w * w);
}

double vertical_prior(const Eigen::Isometry3d& radar_T_world, const Eigen::Vector3d& up_reference, double z_reference,
                      double sigma_tilt, double sigma_z, Vector6d* grad_left) {
  if (!(sigma_tilt > 0) || !(sigma_z > 0)) throw std::invalid_argument("vertical_prior: sigmas must be positive");
  const Eigen::Matrix3d& r = radar_T_world.linear();
  const Eigen::Vector3d g = r.col(2);
  const Eigen::Vector3d e = g - up_reference;
  // The radar's position c = -R^T t; z = c.z.
  const double dz = -r.col(2).dot(radar_T_world.translation()) - z_reference;
  const double it2 = 1.0 / (sigma_tilt * sigma_tilt), iz2 = 1.0 / (sigma_z * sigma_z);
  if (grad_left != nullptr) {
    // Left increment: g <- g + omega x g, and c <- c - R^T rho, so dz / d rho = -g^T.
    grad_left->head<3>() -= iz2 * dz * g;
    grad_left->tail<3>() += it2 * g.cross(e);
  }
  return 0.5 * (it2 * e.squaredNorm() + iz2 * dz * dz);
}

PlanarPose extrapolate_planar(const PlanarPose& a, double t_a, const PlanarPose& b, double t_b, double t) {
  if (!(t_b > t_a)) throw std::invalid_argument("extrapolate_planar: t_b must be after t_a");
  const double rate = (t - t_b) / (t_b - t_a);
  const Eigen::Vector2d d = rate * planar_displacement(a, b);  // in b's heading frame, as it was in a's
  const double c = std::cos(b.yaw), s = std::sin(b.yaw);
  PlanarPose out = b;
  out.x += c * d.x() - s * d.y();
  out.y += s * d.x() + c * d.y();
  out.yaw = wrap_angle(b.yaw + rate * wrap_angle(b.yaw - a.yaw));
  return out;
}

}  // namespace rsrio::splat

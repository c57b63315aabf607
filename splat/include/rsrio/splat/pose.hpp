// Poses, their increments, and the radar velocity from two poses.
//
// A pose is the paper's T_i = radar_T_world: it maps world points into the radar frame,
// p_radar = R p_world + t (Eigen::Isometry3d).
//
// 6-DoF increments are LEFT perturbations expressed in the radar frame (MonoGS style):
//     radar_T_world <- Exp(delta) * radar_T_world,   delta = (rho, omega), translation FIRST.
// To first order a radar-frame point moves by rho + omega x p_radar. Gradients with respect to a
// pose are gradients with respect to delta at delta = 0 (Vector6d, same order).
//
// 3-DoF planar poses (the paper's x, y, yaw) are the radar's position and heading in the world:
// world_T_radar = [Rz(yaw) Ry(pitch) Rx(roll) | (x, y, z)] with z, roll and pitch held fixed.
// Their gradients follow from the 6-DoF left gradient by planar_gradient().
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace rsrio::splat {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix36d = Eigen::Matrix<double, 3, 6>;

/// [v]x, the cross-product matrix.
Eigen::Matrix3d skew(const Eigen::Vector3d& v);
/// Rotation vector -> rotation matrix (Rodrigues, series near 0).
Eigen::Matrix3d so3_exp(const Eigen::Vector3d& omega);
/// se(3) (rho, omega) -> SE(3).
Eigen::Isometry3d se3_exp(const Vector6d& delta);
/// radar_T_world <- Exp(delta) * radar_T_world.
void apply_left_increment(Eigen::Isometry3d& radar_T_world, const Vector6d& delta);

struct PlanarPose {
  double x = 0, y = 0, yaw = 0;       // optimised: radar position in the world and heading [m, rad]
  double z = 0, roll = 0, pitch = 0;  // held fixed

  Eigen::Isometry3d world_T_radar() const;
  Eigen::Isometry3d radar_T_world() const { return world_T_radar().inverse(); }
  /// ZYX Euler decomposition of a world_T_radar.
  static PlanarPose from_world_T_radar(const Eigen::Isometry3d& world_T_radar);
};

/// d(delta)/d(x, y, yaw): the left increment of radar_T_world that a change of the planar
/// parameters makes, to first order (6 x 3).
Eigen::Matrix<double, 6, 3> left_increment_jacobian(const PlanarPose& pose);
/// Gradient with respect to (x, y, yaw) from the gradient with respect to the left increment.
Eigen::Vector3d planar_gradient(const PlanarPose& pose, const Vector6d& grad_left);

/// The radar velocity, in the radar frame of the current pose, by the backward difference of
/// the radar positions: v = R_k (c_k - c_{k-1}) / dt with c = -R^T t the radar position in the
/// world. Jacobians are with respect to the left increments of the two poses.
struct RadarVelocity {
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Matrix36d d_current = Matrix36d::Zero();   // d v / d delta_k
  Matrix36d d_previous = Matrix36d::Zero();  // d v / d delta_{k-1}
};
/// dt must be positive (std::invalid_argument otherwise).
RadarVelocity radar_velocity_from_poses(const Eigen::Isometry3d& radar_T_world_current,
                                        const Eigen::Isometry3d& radar_T_world_previous, double dt);

/// The frontend's planar motion from pose a to pose b as a prior on the optimised a and b:
///     u = R(yaw_a)^T (p_b - p_a) - R(yaw_a')^T (p_b' - p_a')   (2-D, in a's frame)
///     w = wrap(yaw_b - yaw_a - (yaw_b' - yaw_a'))
///     loss = 0.5 (|u|^2 / sigma_t^2 + w^2 / sigma_r^2),
/// primes: the frontend's poses (a_odom, b_odom). ADDS the gradients with respect to (x, y, yaw)
/// of a and b (either may be null). Why: the image losses alone let a pose slide along a wall or
/// turn where the map is ambiguous; the frontend's relative motion between two keyframes is good
/// to millimetres, and this keeps the backend from trading it for a wrong image match.
/// The frontend's heading as a prior on an optimised pose: w = wrap(yaw - yaw_odom),
/// loss = 0.5 w^2 / sigma^2; ADDS d loss / d (x, y, yaw) to grad (may be null). Why: the image
/// losses leave the heading of a window and its map free together (rotating both costs nothing),
/// and Adam's normalised steps turn that freedom into a random walk of the yaw; the frontend's
/// heading (gyro, zero-rate updates) drifts by a fraction of a degree over minutes.
double planar_yaw_prior(const PlanarPose& pose, double yaw_odom, double sigma_rad, Eigen::Vector3d* grad);

/// The shortest frontend displacement that planar_relative_prior splits along and across.
inline constexpr double kAcrossMinDisplacementM = 0.1;

/// planar_relative_prior (described above): sigma_across_m > 0 splits u along and across the
/// frontend's displacement b' - a' when that is at least kAcrossMinDisplacementM long (a turn on
/// the spot has no direction): along it weighs 1 / sigma_translation_m^2, across it
/// 1 / sigma_across_m^2. Why: what the frontend gets wrong between two keyframes is mostly how far
/// (its speed, a few per mille), while the direction of the motion in the keyframe's own frame is
/// the radar's Doppler sideslip, good to a few mm/s; a keyframe turned against the way it moves is
/// what the images resolve least (its map turns with it). 0: isotropic.
double planar_relative_prior(const PlanarPose& a, const PlanarPose& b, const PlanarPose& a_odom,
                             const PlanarPose& b_odom, double sigma_translation_m, double sigma_rotation_rad,
                             Eigen::Vector3d* grad_a, Eigen::Vector3d* grad_b, double sigma_across_m = 0);

/// What a 6-DoF pose may not leave: the frontend's tilt and the floor's height. The images hardly
/// see roll, pitch and z (elevation is marginalised), where the frontend's gravity-referenced tilt
/// is good to a few tenths of a degree; 3-DoF poses hold all three fixed, this holds them softly:
///     g = R e_z (the world's up in the radar frame: yaw-free, so the heading stays the images'),
///     loss = 0.5 (|g - up_reference|^2 / sigma_tilt^2 + (z - z_reference)^2 / sigma_z^2),
/// R = radar_T_world's rotation, z the radar's height in the world. ADDS d loss / d delta (left
/// increment, pose.hpp's order) to grad_left (may be null). std::invalid_argument unless both
/// sigmas are positive.
double vertical_prior(const Eigen::Isometry3d& radar_T_world, const Eigen::Vector3d& up_reference, double z_reference,
                      double sigma_tilt_rad, double sigma_z_m, Vector6d* grad_left);

/// The motion from pose a (time t_a) to pose b (t_b > t_a) continued at the same rate to time t:
/// b followed by (t - t_b) / (t_b - t_a) of a's planar displacement (in a's heading frame) and
/// heading change, each turned with the heading; z, roll and pitch are b's. The motion model of a
/// backend that tracks without a frontend (Backend::predicted). std::invalid_argument unless
/// t_b > t_a.
PlanarPose extrapolate_planar(const PlanarPose& a, double t_a, const PlanarPose& b, double t_b, double t);

}  // namespace rsrio::splat

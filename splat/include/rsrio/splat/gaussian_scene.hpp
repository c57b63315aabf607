// The Gaussian scene of RadarSplat++ (paper Sec. III-D): N anisotropic 3-D Gaussians, each with
//   mean        mu (3, world frame, metres)
//   rotation    q (4, w x y z), stored UNNORMALISED and normalised wherever it is used (so that
//               Adam may move it freely; the gradient is projected through the normalisation)
//   log-scale   log s (3, metres): the covariance is R(q) diag(s)^2 R(q)^T
//   return      log rho (1): the return ratio rho = exp(param) > 0. exp rather than softplus: the
//               radar power spans several decades, and an Adam step on log rho is a relative
//               change whatever the magnitude.
//   view return c (kViewTerms): the return's dependence on the direction it is seen from, a
//               Fourier series in the horizontal azimuth phi of the view (world frame) added to
//               log rho: rho(phi) = rho exp(c1 cos phi + c2 sin phi + c3 cos 2 phi + c4 sin 2 phi).
//               RadarSplat's reflectance is view-dependent through spherical harmonics; with
//               elevation marginalised the horizontal circle's harmonics are what is left. Zero
//               (isotropic) unless the renderer's view_dependent_return is on and it is trained.
//
// Stored as structure of arrays, one contiguous block per parameter kind with the stride given
// above (means[3 i + k], ...), which is also how gradients (SceneGradients) and the optimiser's
// moments are laid out.
//
// Bounded memory: options.max_gaussians is a hard cap. Adding points beyond it (and densifying)
// evicts the Gaussians farthest from a given position (the current radar position).
//
// Structural changes (add with eviction, prune, densify, cap, removal of non-finite Gaussians)
// keep the surviving Gaussians in their relative order and append new ones; each returns a
// SceneRemap: origin[i] = the index Gaussian i had before the change, or -1 for a new Gaussian.
// The optimiser follows with SplatAdam::remap().
//
// No NaN ever enters: additions with non-finite values are refused, sanitize() removes any
// Gaussian whose parameters became non-finite, and both are counted.
//
// Spatial index: a uniform-grid spatial hash (cells of options.index_cell_m, hashed into a
// table of ~2N buckets, rebuilt in O(N) when the means have changed) answers "which Gaussians lie
// within radius of p" without scanning all; results are exact (distance-checked) and sorted.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace rsrio::splat {

using SceneRemap = std::vector<std::int32_t>;

/// Fourier terms of a Gaussian's view-dependent return: cos phi, sin phi, cos 2 phi, sin 2 phi.
inline constexpr std::size_t kViewTerms = 4;

struct SceneOptions {
  std::size_t max_gaussians = 200'000;  // hard cap (about 30 MB with optimiser state)
  double index_cell_m = 1.0;            // spatial-hash cell size
  // Parameter bounds applied by sanitize(): exp never overflows, a Gaussian never degenerates.
  double min_log_scale = -9.0;          // ~0.1 mm
  double max_log_scale = 4.0;           // ~55 m
  double min_log_return = -60.0;
  double max_log_return = 60.0;
  // Whether each Gaussian stores view returns (the backend's view_dependent_return). Off, the
  // block stays empty: 32 B a Gaussian, and as much again in its gradients, for terms that are
  // never used (about 7 MB of the hour bench's heap).
  bool view_returns = false;
  double max_view_return = 5.0;         // |c_k|: the view factor stays within e^(+-20)
  // Pruning.
  double prune_min_return = 1e-8;       // rho below this: the Gaussian contributes nothing
  double prune_max_scale_m = 3.0;       // any axis above this: a blob that explains nothing
  // Densification (3DGS rule on the image-space gradient, see densify()).
  double densify_grad_threshold = 2e-4; // mean |dL/d(mean in bins)| per render that saw it
  double densify_split_scale_m = 0.25;  // largest axis above this: split, else clone
  double densify_split_divisor = 1.6;   // split children have scale / this (3DGS)
  std::uint64_t seed = 0x5eed;          // split sampling
};

/// Gradients of a loss for every Gaussian, laid out like the scene. Renderers ADD into it.
struct SceneGradients {
  std::vector<double> means;          // 3 N
  std::vector<double> rotations;      // 4 N (w.r.t. the stored, unnormalised quaternion)
  std::vector<double> log_scales;     // 3 N
  std::vector<double> log_returns;    // N
  std::vector<double> view_returns;   // kViewTerms N, or empty for a scene without view returns
  /// Densification statistic: sum over renders of |dL/d(mean in (range, azimuth) bins)|, and the
  /// number of renders in which the Gaussian touched a pixel.
  std::vector<double> image_mean_grad_norm;  // N
  std::vector<std::uint32_t> visible_count;  // N

  std::size_t size() const { return log_returns.size(); }
  /// Sizes for n Gaussians (view_returns: with the view returns' block) and zeroes everything.
  void reset(std::size_t n, bool view_returns);
  void set_zero() { reset(size(), !view_returns.empty()); }
  /// Zeroes the listed Gaussians' rows only. An optimisation stage draws the Gaussians near its
  /// views; zeroing all N every iteration would cost more than the rendering once the map holds
  /// ~10^5 Gaussians (rsrio-splat-hour-bench).
  void zero_rows(std::span<const std::uint32_t> rows);
  bool all_finite() const;
  /// all_finite() over the listed rows.
  bool all_finite(std::span<const std::uint32_t> rows) const;
  /// this += other (same size).
  void add(const SceneGradients& other);
};

struct AddPointsOptions {
  double scale_m = 0.1;       // isotropic initial scale
  double return_ratio = 1.0;  // initial rho
  double min_spacing_m = 0;   // > 0: skip points with an existing (or just added) Gaussian nearer
};

class GaussianScene {
 public:
  explicit GaussianScene(const SceneOptions& options = {});

  const SceneOptions& options() const { return options_; }
  std::size_t size() const { return log_returns_.size(); }
  bool empty() const { return size() == 0; }

  // ---- parameter blocks (mutable access marks the spatial index stale)
  std::span<const double> means() const { return means_; }
  std::span<const double> rotations() const { return rotations_; }
  std::span<const double> log_scales() const { return log_scales_; }
  std::span<const double> log_returns() const { return log_returns_; }
  /// kViewTerms a Gaussian when options().view_returns, empty otherwise.
  std::span<const double> view_returns() const { return view_returns_; }
  bool has_view_returns() const { return options_.view_returns; }
  std::span<double> mutable_means() {
    index_stale_ = true;
    return means_;
  }
  std::span<double> mutable_rotations() { return rotations_; }
  std::span<double> mutable_log_scales() { return log_scales_; }
  std::span<double> mutable_log_returns() { return log_returns_; }
  std::span<double> mutable_view_returns() { return view_returns_; }

  // ---- per-Gaussian views
  Eigen::Vector3d mean(std::size_t i) const { return {means_[3 * i], means_[3 * i + 1], means_[3 * i + 2]}; }
  /// The normalised rotation.
  Eigen::Quaterniond rotation(std::size_t i) const;
  Eigen::Vector3d scale(std::size_t i) const;
  double return_ratio(std::size_t i) const;
  /// R diag(s)^2 R^T, world frame.
  Eigen::Matrix3d covariance(std::size_t i) const;

  // ---- creation
  /// Appends one Gaussian (no cap check). Refuses (returns false, counts) non-finite values or a
  /// zero quaternion. `rotation` need not be normalised.
  bool add(const Eigen::Vector3d& mean, const Eigen::Quaterniond& rotation,
           const Eigen::Vector3d& log_scale, double log_return);
  /// Appends a copy of Gaussian i of `other` as it is (its view terms when both scenes have
  /// them, else none); no cap check.
  void copy_from(const GaussianScene& other, std::size_t i);
  /// Gaussians at 3-D points (e.g. the CFAR points of a keyframe, in the world frame),
  /// isotropic, identity rotation; then the cap is enforced around `eviction_center`.
  SceneRemap add_points(std::span<const Eigen::Vector3d> points, const AddPointsOptions& add_options,
                        const Eigen::Vector3d& eviction_center);

  // ---- structure
  /// Removes Gaussians with rho < prune_min_return or any scale > prune_max_scale_m.
  SceneRemap prune();
  /// Adds one render's gradients to the densification statistics.
  void accumulate_densify_stats(const SceneGradients& gradients);
  /// For every Gaussian seen in at least one render since the last densify() whose mean
  /// image-space gradient exceeds densify_grad_threshold:
  ///   largest scale > densify_split_scale_m  -> SPLIT: replaced by two children drawn from the
  ///       Gaussian N(mu, Sigma) (seeded), scales / densify_split_divisor;
  ///   otherwise                              -> CLONE: replaced by two copies displaced by
  ///       +-0.5 sigma along the largest axis.
  /// Children carry rho / 2 each: rendering is a plain sum, so the pair keeps the parent's energy;
  /// they keep its view terms.
  /// Resets the statistics and enforces the cap around `eviction_center`.
  SceneRemap densify(const Eigen::Vector3d& eviction_center);
  /// Evicts the Gaussians farthest from `center` until size() <= max_gaussians.
  SceneRemap enforce_cap(const Eigen::Vector3d& center);
  /// Removes Gaussians with a non-finite parameter (counted), renormalises degenerate
  /// quaternions to identity, clamps log-scales, log-returns and view returns into the option
  /// bounds.
  SceneRemap sanitize();

  // ---- spatial index
  /// Indices of the Gaussians with |mean - center| <= radius, ascending. Rebuilds the index if the
  /// means changed (not safe concurrently with another query then: call update_index() first).
  void query_radius(const Eigen::Vector3d& center, double radius, std::vector<std::uint32_t>& out) const;
  void update_index() const;

  // ---- counters
  std::uint64_t rejected_non_finite() const { return rejected_non_finite_; }
  std::uint64_t removed_non_finite() const { return removed_non_finite_; }
  std::uint64_t evicted() const { return evicted_; }
  std::span<const double> densify_grad_accum() const { return densify_grad_accum_; }
  std::span<const std::uint32_t> densify_count() const { return densify_count_; }

 private:
  /// Keeps Gaussians with keep[i], in order; returns the remap.
  SceneRemap compact(const std::vector<char>& keep);
  /// view == nullptr: isotropic (zero view terms).
  void push_raw(const double* mean, const double* rotation, const double* log_scale, double log_return,
                const double* view = nullptr);
  static SceneRemap compose(const SceneRemap& first, const SceneRemap& second);
  /// Whether an indexed Gaussian lies within radius of p, from the index as last built (no rebuild).
  bool any_indexed_within(const Eigen::Vector3d& p, double radius) const;
  /// The index cells a query of `radius` around p visits: the sphere's bounding box cut to the
  /// cells that hold Gaussians (the index's bounding box). A map is a thin slab in z, and a query
  /// of the radar's range (~19 m) would otherwise visit (2 r)^3 ~ 55 000 cells, most of them
  /// empty (rsrio-splat-hour-bench). False when the two boxes do not meet.
  struct CellBox {
    std::int64_t lo[3], hi[3];
    double cells() const;
  };
  bool cells_to_visit(const Eigen::Vector3d& p, double radius, CellBox& box) const;

  SceneOptions options_;
  std::vector<double> means_, rotations_, log_scales_, log_returns_, view_returns_;
  std::vector<double> densify_grad_accum_;
  std::vector<std::uint32_t> densify_count_;
  std::uint64_t rejected_non_finite_ = 0;
  std::uint64_t removed_non_finite_ = 0;
  std::uint64_t evicted_ = 0;
  std::uint64_t split_counter_ = 0;

  // Spatial hash: bucket b holds entries [bucket_start_[b], bucket_start_[b + 1]).
  mutable bool index_stale_ = true;
  mutable std::vector<std::uint32_t> bucket_start_;
  mutable std::vector<std::uint32_t> bucket_entries_;
  mutable std::vector<std::uint32_t> bucket_scratch_;
  mutable std::vector<std::uint32_t> bucket_of_;
  mutable std::uint64_t bucket_mask_ = 0;
  mutable std::int64_t cell_min_[3] = {0, 0, 0}, cell_max_[3] = {-1, -1, -1};  // the indexed cells' bounding box
};

}  // namespace rsrio::splat

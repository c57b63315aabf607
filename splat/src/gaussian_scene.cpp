#include "rsrio/splat/gaussian_scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>
#include <unordered_map>

namespace rsrio::splat {

namespace {

bool finite_all(const double* v, int n) {
  for (int k = 0; k < n; ++k)
    if (!std::isfinite(v[k])) return false;
  return true;
}

std::int64_t cell_coord(double x, double cell) { return static_cast<std::int64_t>(std::floor(x / cell)); }

std::uint64_t cell_hash(std::int64_t ix, std::int64_t iy, std::int64_t iz) {
  // Teschner et al. 2003 spatial hashing primes.
  return static_cast<std::uint64_t>(ix * 73856093LL) ^ static_cast<std::uint64_t>(iy * 19349663LL) ^
         static_cast<std::uint64_t>(iz * 83492791LL);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
void SceneGradients::reset(std::size_t n, bool with_view_returns) {
  means.assign(3 * n, 0.0);
  rotations.assign(4 * n, 0.0);
  log_scales.assign(3 * n, 0.0);
  log_returns.assign(n, 0.0);
  view_returns.assign(with_view_returns ? kViewTerms * n : 0, 0.0);
  image_mean_grad_norm.assign(n, 0.0);
  visible_count.assign(n, 0);
}

bool SceneGradients::all_finite() const {
  auto ok = [](const std::vector<double>& v) {
    return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
  };
  return ok(means) && ok(rotations) && ok(log_scales) && ok(log_returns) && ok(view_returns) &&
         ok(image_mean_grad_norm);
}

void SceneGradients::zero_rows(std::span<const std::uint32_t> rows) {
  for (const std::uint32_t i : rows) {
    std::fill_n(&means[3 * i], 3, 0.0);
    std::fill_n(&rotations[4 * i], 4, 0.0);
    std::fill_n(&log_scales[3 * i], 3, 0.0);
    log_returns[i] = 0;
    if (!view_returns.empty()) std::fill_n(&view_returns[kViewTerms * i], kViewTerms, 0.0);
    image_mean_grad_norm[i] = 0;
    visible_count[i] = 0;
  }
}

bool SceneGradients::all_finite(std::span<const std::uint32_t> rows) const {
  auto ok = [](const double* v, int n) { return std::all_of(v, v + n, [](double x) { return std::isfinite(x); }); };
  return std::all_of(rows.begin(), rows.end(), [&](std::uint32_t i) {
    return ok(&means[3 * i], 3) && ok(&rotations[4 * i], 4) && ok(&log_scales[3 * i], 3) && ok(&log_returns[i], 1) &&
           (view_returns.empty() || ok(&view_returns[kViewTerms * i], kViewTerms)) && ok(&image_mean_grad_norm[i], 1);
  });
}

void SceneGradients::add(const SceneGradients& other) {
  if (other.size() != size() || other.view_returns.size() != view_returns.size())
    throw std::invalid_argument("SceneGradients::add: the two are not laid out alike");
  auto acc = [](std::vector<double>& a, const std::vector<double>& b) {
    for (std::size_t k = 0; k < a.size(); ++k) a[k] += b[k];
  };
  acc(means, other.means);
  acc(rotations, other.rotations);
  acc(log_scales, other.log_scales);
  acc(log_returns, other.log_returns);
  acc(view_returns, other.view_returns);
  acc(image_mean_grad_norm, other.image_mean_grad_norm);
  for (std::size_t k = 0; k < visible_count.size(); ++k) visible_count[k] += other.visible_count[k];
}

// ---------------------------------------------------------------------------------------------
GaussianScene::GaussianScene(const SceneOptions& options) : options_(options) {}

Eigen::Quaterniond GaussianScene::rotation(std::size_t i) const {
  Eigen::Quaterniond q(rotations_[4 * i], rotations_[4 * i + 1], rotations_[4 * i + 2], rotations_[4 * i + 3]);
  return q.normalized();
}

Eigen::Vector3d GaussianScene::scale(std::size_t i) const {
  return {std::exp(log_scales_[3 * i]), std::exp(log_scales_[3 * i + 1]), std::exp(log_scales_[3 * i + 2])};
}

double GaussianScene::return_ratio(std::size_t i) const { return std::exp(log_returns_[i]); }

Eigen::Matrix3d GaussianScene::covariance(std::size_t i) const {
  const Eigen::Matrix3d m = rotation(i).toRotationMatrix() * scale(i).asDiagonal();
  return m * m.transpose();
}

void GaussianScene::push_raw(const double* mean, const double* rotation, const double* log_scale,
                             double log_return, const double* view) {
  means_.insert(means_.end(), mean, mean + 3);
  rotations_.insert(rotations_.end(), rotation, rotation + 4);
  log_scales_.insert(log_scales_.end(), log_scale, log_scale + 3);
  log_returns_.push_back(log_return);
  if (options_.view_returns) {
    if (view != nullptr)
      view_returns_.insert(view_returns_.end(), view, view + kViewTerms);
    else
      view_returns_.resize(view_returns_.size() + kViewTerms, 0.0);
  }
  densify_grad_accum_.push_back(0.0);
  densify_count_.push_back(0);
  index_stale_ = true;
}

void GaussianScene::copy_from(const GaussianScene& other, std::size_t i) {
  if (i >= other.size()) throw std::out_of_range("GaussianScene::copy_from: no such Gaussian");
  const bool view = options_.view_returns && other.options_.view_returns;
  push_raw(&other.means_[3 * i], &other.rotations_[4 * i], &other.log_scales_[3 * i], other.log_returns_[i],
           view ? &other.view_returns_[kViewTerms * i] : nullptr);
}

bool GaussianScene::add(const Eigen::Vector3d& mean, const Eigen::Quaterniond& rotation,
                        const Eigen::Vector3d& log_scale, double log_return) {
  const double q[4] = {rotation.w(), rotation.x(), rotation.y(), rotation.z()};
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!finite_all(mean.data(), 3) || !finite_all(q, 4) || !finite_all(log_scale.data(), 3) ||
      !std::isfinite(log_return) || !(norm > 1e-12)) {
    ++rejected_non_finite_;
    return false;
  }
  double ls[3];
  for (int k = 0; k < 3; ++k) ls[k] = std::clamp(log_scale[k], options_.min_log_scale, options_.max_log_scale);
  push_raw(mean.data(), q, ls, std::clamp(log_return, options_.min_log_return, options_.max_log_return));
  return true;
}

SceneRemap GaussianScene::add_points(std::span<const Eigen::Vector3d> points,
                                     const AddPointsOptions& add_options,
                                     const Eigen::Vector3d& eviction_center) {
  if (!(add_options.scale_m > 0) || !(add_options.return_ratio > 0) || !(add_options.min_spacing_m >= 0))
    throw std::invalid_argument("add_points: scale and return ratio must be positive, spacing >= 0");
  const std::size_t before = size();
  const double log_scale = std::log(add_options.scale_m);
  const double log_return = std::log(add_options.return_ratio);
  const double spacing = add_options.min_spacing_m;
  // Points accepted in this call, hashed by cell of size `spacing`, so that the spacing test
  // covers them as well as the Gaussians already present (found through the index, which is
  // built once here and describes exactly those).
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> accepted;
  if (spacing > 0) update_index();
  for (const Eigen::Vector3d& p : points) {
    if (!finite_all(p.data(), 3)) {
      ++rejected_non_finite_;
      continue;
    }
    if (spacing > 0) {
      bool crowded = before > 0 && any_indexed_within(p, spacing);
      const std::int64_t cx = cell_coord(p.x(), spacing), cy = cell_coord(p.y(), spacing),
                         cz = cell_coord(p.z(), spacing);
      for (std::int64_t ix = cx - 1; ix <= cx + 1 && !crowded; ++ix)
        for (std::int64_t iy = cy - 1; iy <= cy + 1 && !crowded; ++iy)
          for (std::int64_t iz = cz - 1; iz <= cz + 1 && !crowded; ++iz) {
            const auto it = accepted.find(cell_hash(ix, iy, iz));
            if (it == accepted.end()) continue;
            for (const std::size_t g : it->second)
              if ((mean(g) - p).squaredNorm() <= spacing * spacing) crowded = true;
          }
      if (crowded) continue;
      accepted[cell_hash(cx, cy, cz)].push_back(size());
    }
    const double q[4] = {1, 0, 0, 0};
    const double ls[3] = {log_scale, log_scale, log_scale};
    push_raw(p.data(), q, ls, std::clamp(log_return, options_.min_log_return, options_.max_log_return));
  }
  SceneRemap added(size());
  std::iota(added.begin(), added.begin() + static_cast<std::ptrdiff_t>(before), 0);
  std::fill(added.begin() + static_cast<std::ptrdiff_t>(before), added.end(), -1);
  return compose(added, enforce_cap(eviction_center));
}

// ---------------------------------------------------------------------------------------------
SceneRemap GaussianScene::compose(const SceneRemap& first, const SceneRemap& second) {
  SceneRemap out(second.size());
  for (std::size_t i = 0; i < second.size(); ++i)
    out[i] = second[i] < 0 ? -1 : first[static_cast<std::size_t>(second[i])];
  return out;
}

SceneRemap GaussianScene::compact(const std::vector<char>& keep) {
  SceneRemap origin;
  origin.reserve(size());
  std::size_t w = 0;
  for (std::size_t i = 0; i < size(); ++i) {
    if (!keep[i]) continue;
    if (w != i) {
      std::copy_n(&means_[3 * i], 3, &means_[3 * w]);
      std::copy_n(&rotations_[4 * i], 4, &rotations_[4 * w]);
      std::copy_n(&log_scales_[3 * i], 3, &log_scales_[3 * w]);
      log_returns_[w] = log_returns_[i];
      if (options_.view_returns)
        std::copy_n(&view_returns_[kViewTerms * i], kViewTerms, &view_returns_[kViewTerms * w]);
      densify_grad_accum_[w] = densify_grad_accum_[i];
      densify_count_[w] = densify_count_[i];
    }
    origin.push_back(static_cast<std::int32_t>(i));
    ++w;
  }
  means_.resize(3 * w);
  rotations_.resize(4 * w);
  log_scales_.resize(3 * w);
  log_returns_.resize(w);
  if (options_.view_returns) view_returns_.resize(kViewTerms * w);
  densify_grad_accum_.resize(w);
  densify_count_.resize(w);
  index_stale_ = true;
  return origin;
}

SceneRemap GaussianScene::prune() {
  std::vector<char> keep(size(), 1);
  const double log_min_return = std::log(options_.prune_min_return);
  const double log_max_scale = std::log(options_.prune_max_scale_m);
  for (std::size_t i = 0; i < size(); ++i) {
    const double* ls = &log_scales_[3 * i];
    if (log_returns_[i] < log_min_return || std::max({ls[0], ls[1], ls[2]}) > log_max_scale) keep[i] = 0;
  }
  return compact(keep);
}

void GaussianScene::accumulate_densify_stats(const SceneGradients& gradients) {
  const std::size_t n = std::min(size(), gradients.size());
  for (std::size_t i = 0; i < n; ++i) {
    if (gradients.visible_count[i] == 0) continue;
    densify_grad_accum_[i] += gradients.image_mean_grad_norm[i];
    densify_count_[i] += gradients.visible_count[i];
  }
}

SceneRemap GaussianScene::densify(const Eigen::Vector3d& eviction_center) {
  const std::size_t n = size();
  std::vector<char> keep(n, 1);
  std::mt19937_64 rng(options_.seed + split_counter_++);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double log2 = std::log(2.0);
  const double log_split_scale = std::log(options_.densify_split_scale_m);
  const double log_divisor = std::log(options_.densify_split_divisor);
  for (std::size_t i = 0; i < n; ++i) {
    if (densify_count_[i] == 0) continue;
    if (densify_grad_accum_[i] / densify_count_[i] <= options_.densify_grad_threshold) continue;
    keep[i] = 0;
    const Eigen::Vector3d mu = mean(i);
    const double* ls = &log_scales_[3 * i];
    const int major = static_cast<int>(std::max_element(ls, ls + 3) - ls);
    const Eigen::Matrix3d rot = rotation(i).toRotationMatrix();
    const Eigen::Vector3d s = scale(i);
    double q[4];
    std::copy_n(&rotations_[4 * i], 4, q);
    double child_ls[3] = {ls[0], ls[1], ls[2]};
    const double child_log_return = log_returns_[i] - log2;
    // A copy: push_raw may reallocate the block the parent's terms live in.
    double view[kViewTerms] = {};
    if (options_.view_returns) std::copy_n(&view_returns_[kViewTerms * i], kViewTerms, view);
    if (ls[major] > log_split_scale) {
      for (double& v : child_ls) v -= log_divisor;
      for (int c = 0; c < 2; ++c) {
        const Eigen::Vector3d eps(normal(rng), normal(rng), normal(rng));
        const Eigen::Vector3d child = mu + rot * s.cwiseProduct(eps);
        push_raw(child.data(), q, child_ls, child_log_return, view);
      }
    } else {
      const Eigen::Vector3d offset = 0.5 * s[major] * rot.col(major);
      const Eigen::Vector3d a = mu + offset, b = mu - offset;
      push_raw(a.data(), q, child_ls, child_log_return, view);
      push_raw(b.data(), q, child_ls, child_log_return, view);
    }
  }
  // New Gaussians sit behind the n old ones; keep them all.
  keep.resize(size(), 1);
  SceneRemap origin = compact(keep);
  for (std::int32_t& o : origin)
    if (o >= static_cast<std::int32_t>(n)) o = -1;
  std::fill(densify_grad_accum_.begin(), densify_grad_accum_.end(), 0.0);
  std::fill(densify_count_.begin(), densify_count_.end(), 0u);
  return compose(origin, enforce_cap(eviction_center));
}

SceneRemap GaussianScene::enforce_cap(const Eigen::Vector3d& center) {
  const std::size_t n = size();
  if (n <= options_.max_gaussians) {
    SceneRemap identity(n);
    std::iota(identity.begin(), identity.end(), 0);
    return identity;
  }
  std::vector<std::pair<double, std::uint32_t>> dist(n);
  for (std::size_t i = 0; i < n; ++i) dist[i] = {(mean(i) - center).squaredNorm(), static_cast<std::uint32_t>(i)};
  const std::size_t cap = options_.max_gaussians;
  // The cap nearest stay (ties broken by index, so the result is deterministic).
  std::nth_element(dist.begin(), dist.begin() + static_cast<std::ptrdiff_t>(cap), dist.end());
  std::vector<char> keep(n, 0);
  for (std::size_t k = 0; k < cap; ++k) keep[dist[k].second] = 1;
  evicted_ += n - cap;
  return compact(keep);
}

SceneRemap GaussianScene::sanitize() {
  std::vector<char> keep(size(), 1);
  for (std::size_t i = 0; i < size(); ++i) {
    double* q = &rotations_[4 * i];
    if (!finite_all(&means_[3 * i], 3) || !finite_all(q, 4) || !finite_all(&log_scales_[3 * i], 3) ||
        !std::isfinite(log_returns_[i]) ||
        (options_.view_returns && !finite_all(&view_returns_[kViewTerms * i], kViewTerms))) {
      keep[i] = 0;
      ++removed_non_finite_;
      continue;
    }
    const double norm2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    if (norm2 < 1e-24) {
      q[0] = 1;
      q[1] = q[2] = q[3] = 0;
    } else if (norm2 > 1e12 || norm2 < 1e-12) {
      // Keep the stored norm O(1): the normalisation gradient scales with 1 / |q|.
      const double inv = 1.0 / std::sqrt(norm2);
      for (int k = 0; k < 4; ++k) q[k] *= inv;
    }
    for (int k = 0; k < 3; ++k)
      log_scales_[3 * i + k] = std::clamp(log_scales_[3 * i + k], options_.min_log_scale, options_.max_log_scale);
    log_returns_[i] = std::clamp(log_returns_[i], options_.min_log_return, options_.max_log_return);
    if (options_.view_returns)
      for (std::size_t k = 0; k < kViewTerms; ++k)
        view_returns_[kViewTerms * i + k] =
            std::clamp(view_returns_[kViewTerms * i + k], -options_.max_view_return, options_.max_view_return);
  }
  return compact(keep);
}

// ---------------------------------------------------------------------------------------------
void GaussianScene::update_index() const {
  if (!index_stale_) return;
  const std::size_t n = size();
  std::size_t table = 1024;
  while (table < 2 * n) table *= 2;
  bucket_mask_ = table - 1;
  const double cell = options_.index_cell_m;
  bucket_of_.resize(n);
  bucket_start_.assign(table + 1, 0);
  for (int a = 0; a < 3; ++a) {
    cell_min_[a] = std::numeric_limits<std::int64_t>::max();
    cell_max_[a] = std::numeric_limits<std::int64_t>::min();
  }
  for (std::size_t i = 0; i < n; ++i) {
    std::int64_t c[3];
    for (int a = 0; a < 3; ++a) {
      c[a] = cell_coord(means_[3 * i + static_cast<std::size_t>(a)], cell);
      cell_min_[a] = std::min(cell_min_[a], c[a]);
      cell_max_[a] = std::max(cell_max_[a], c[a]);
    }
    const std::uint64_t b = cell_hash(c[0], c[1], c[2]) & bucket_mask_;
    bucket_of_[i] = static_cast<std::uint32_t>(b);
    ++bucket_start_[b + 1];
  }
  // Counting sort: entries of bucket b in ascending Gaussian index.
  for (std::size_t b = 0; b < table; ++b) bucket_start_[b + 1] += bucket_start_[b];
  bucket_entries_.resize(n);
  bucket_scratch_.assign(bucket_start_.begin(), bucket_start_.end() - 1);
  for (std::size_t i = 0; i < n; ++i) bucket_entries_[bucket_scratch_[bucket_of_[i]]++] = static_cast<std::uint32_t>(i);
  index_stale_ = false;
}

double GaussianScene::CellBox::cells() const {
  double n = 1;
  for (int a = 0; a < 3; ++a) n *= static_cast<double>(hi[a] - lo[a] + 1);
  return n;
}

bool GaussianScene::cells_to_visit(const Eigen::Vector3d& p, double radius, CellBox& box) const {
  const double cell = options_.index_cell_m;
  for (int a = 0; a < 3; ++a) {
    box.lo[a] = std::max(cell_coord(p[a] - radius, cell), cell_min_[a]);
    box.hi[a] = std::min(cell_coord(p[a] + radius, cell), cell_max_[a]);
    if (box.lo[a] > box.hi[a]) return false;
  }
  return true;
}

bool GaussianScene::any_indexed_within(const Eigen::Vector3d& p, double radius) const {
  const double r2 = radius * radius;
  CellBox box;
  if (!cells_to_visit(p, radius, box)) return false;
  for (std::int64_t ix = box.lo[0]; ix <= box.hi[0]; ++ix)
    for (std::int64_t iy = box.lo[1]; iy <= box.hi[1]; ++iy)
      for (std::int64_t iz = box.lo[2]; iz <= box.hi[2]; ++iz) {
        const std::uint64_t b = cell_hash(ix, iy, iz) & bucket_mask_;
        for (std::uint32_t e = bucket_start_[b]; e < bucket_start_[b + 1]; ++e)
          if ((mean(bucket_entries_[e]) - p).squaredNorm() <= r2) return true;
      }
  return false;
}

void GaussianScene::query_radius(const Eigen::Vector3d& center, double radius,
                                 std::vector<std::uint32_t>& out) const {
  out.clear();
  if (empty() || !(radius >= 0) || !finite_all(center.data(), 3)) return;
  update_index();
  const double r2 = radius * radius;
  CellBox box;
  if (!cells_to_visit(center, radius, box)) return;
  const double cells = box.cells();
  auto inside = [&](std::size_t i) {
    const double dx = means_[3 * i] - center.x(), dy = means_[3 * i + 1] - center.y(),
                 dz = means_[3 * i + 2] - center.z();
    return dx * dx + dy * dy + dz * dz <= r2;
  };
  if (cells >= static_cast<double>(size())) {
    // The sphere covers more cells than there are Gaussians: a scan is cheaper (and exact).
    for (std::size_t i = 0; i < size(); ++i)
      if (inside(i)) out.push_back(static_cast<std::uint32_t>(i));
    return;
  }
  // Distinct buckets of the cells the sphere's bounding box touches (cells may share a bucket).
  // A local list keeps concurrent queries on a fresh index safe.
  std::vector<std::uint32_t> buckets;
  buckets.reserve(static_cast<std::size_t>(cells));
  for (std::int64_t ix = box.lo[0]; ix <= box.hi[0]; ++ix)
    for (std::int64_t iy = box.lo[1]; iy <= box.hi[1]; ++iy)
      for (std::int64_t iz = box.lo[2]; iz <= box.hi[2]; ++iz)
        buckets.push_back(static_cast<std::uint32_t>(cell_hash(ix, iy, iz) & bucket_mask_));
  std::sort(buckets.begin(), buckets.end());
  buckets.erase(std::unique(buckets.begin(), buckets.end()), buckets.end());
  for (const std::uint32_t b : buckets)
    for (std::uint32_t e = bucket_start_[b]; e < bucket_start_[b + 1]; ++e)
      if (inside(bucket_entries_[e])) out.push_back(bucket_entries_[e]);
  std::sort(out.begin(), out.end());
}

}  // namespace rsrio::splat

// What the DSP would give for a world of Gaussians seen from a radar pose: the benchmarks'
// stand-in for the simulator (rsrio-splat-bench's walk through a room, rsrio-splat-hour-bench's
// hour along a corridor), so that the backend gets the work of a real stretch without the cost of
// simulating it; splat_backend_test's synthetic walks use it too. The images are the backend's own renderers' (RA, then RD from that RA at the
// radar's velocity with the DSP's Doppler lobe), on the DSP's full grid (the backend cuts them).
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Geometry>

#include "rsrio/dsp/processor.hpp"
#include "rsrio/splat/gaussian_scene.hpp"
#include "rsrio/splat/ra_renderer.hpp"
#include "rsrio/splat/rd_renderer.hpp"

namespace rsrio::splat::bench {

class FrameSynthesiser {
 public:
  explicit FrameSynthesiser(const RadarImageGrid& full_grid)
      : grid_(full_grid), ra_renderer_(full_grid), rd_renderer_(full_grid, lobe_options()) {}

  /// The frame seen from world_T_radar moving with `velocity` (radar frame, m/s): RA and RD of
  /// `world`, and a CFAR point for every `point_stride`-th Gaussian in front of the radar and
  /// nearer than max_point_range_m (a detector finds some of the scatterers, not all).
  const DspImages& render(const GaussianScene& world, const Eigen::Isometry3d& world_T_radar,
                          const Eigen::Vector3d& velocity, std::size_t point_stride, double max_point_range_m) {
    ra_renderer_.render(world, world_T_radar.inverse(), ra_);
    rd_renderer_.render(ra_, velocity, rd_);
    frame_.ra.assign(ra_.data(), ra_.data() + ra_.size());
    frame_.rd.assign(rd_.data(), rd_.data() + rd_.size());
    frame_.points.clear();
    for (std::size_t i = 0; i < world.size(); i += point_stride) {
      const Eigen::Vector3d p = world_T_radar.inverse() * world.mean(i);
      const double r = p.norm();
      if (p.x() <= 0.3 || r > max_point_range_m) continue;
      DspPoint d;
      d.x = static_cast<float>(p.x());
      d.y = static_cast<float>(p.y());
      d.z = static_cast<float>(p.z());
      d.range_m = static_cast<float>(r);
      d.range_bin = static_cast<float>(grid_.range_to_bin(r));
      d.azimuth_bin = static_cast<float>(grid_.sin_to_azimuth_bin(p.y() / r));
      d.doppler_mps = static_cast<float>(-p.dot(velocity) / r);
      d.snr_db = 20;
      d.power = 1;  // what the backend falls back on where the RA cell is empty
      frame_.points.push_back(d);
    }
    return frame_;
  }

 private:
  static RdRenderOptions lobe_options() {
    RdRenderOptions o;  // the backend's default kernel: the DSP's Doppler lobe (hann)
    o.kernel_sigma_bins = window_power_fwhm_bins("hann") / 2.355;
    return o;
  }
  RadarImageGrid grid_;
  RaRenderer<float> ra_renderer_;
  RdRenderer<float> rd_renderer_;
  Image<float> ra_, rd_;
  DspImages frame_;
};

}  // namespace rsrio::splat::bench

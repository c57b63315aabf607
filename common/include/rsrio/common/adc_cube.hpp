// The raw ADC samples of one radar frame as complex numbers, in one fixed order for every stage:
// [loop][slot][rx][sample], where `slot` is the TDM slot within a loop (TX id = tx_order[slot])
// and `rx` the RX channel in capture order. Samples keep their int16 scale (no normalisation).
#pragma once

#include <complex>
#include <cstddef>
#include <vector>

#include "rsrio/common/radar_config.hpp"

namespace rsrio {

struct AdcCube {
  int loops = 0;
  int slots = 0;
  int rx = 0;
  int samples = 0;
  std::vector<std::complex<float>> data;

  AdcCube() = default;
  AdcCube(int loops_, int slots_, int rx_, int samples_)
      : loops(loops_), slots(slots_), rx(rx_), samples(samples_),
        data(static_cast<std::size_t>(loops_) * slots_ * rx_ * samples_) {}
  /// Sized for one frame of `config`.
  static AdcCube for_config(const RadarConfig& config) {
    return AdcCube(config.loops, static_cast<int>(config.tx_order.size()),
                   static_cast<int>(config.array.rx_azimuth.size()), config.chirp.samples_per_chirp);
  }

  std::size_t index(int loop, int slot, int r, int sample) const {
    return ((static_cast<std::size_t>(loop) * slots + slot) * rx + r) * samples + sample;
  }
  std::complex<float>& at(int loop, int slot, int r, int sample) { return data[index(loop, slot, r, sample)]; }
  const std::complex<float>& at(int loop, int slot, int r, int sample) const {
    return data[index(loop, slot, r, sample)];
  }
};

}  // namespace rsrio

// Options of the DSP stage (SPEC Sec. 7): the `dsp:` section of a program's options file.
//
//   dsp:
//     range_window: hann          # none | hann | hamming | blackman (symmetric, length = samples)
//     doppler_window: hann        # same choices, length = loops
//     angle_window: none          # same choices, length = filled azimuth array
//     dc_removal: true            # subtract each chirp's mean before the range FFT
//     clutter_removal: false      # subtract the mean over loops per (channel, range bin)
//     tdm_compensation: true      # TDM-MIMO Doppler phase compensation before the angle FFT
//     calibration: true           # apply radar.calibration (complex gain, frequency offset)
//     fft_planning: estimate      # estimate | measure (see rsrio/dsp/fftw.hpp)
//     interpolation: calibrated   # sub-bin points: calibrated | gaussian (peak_interpolation.hpp) | none
//     doppler_own_peak: false     # each azimuth peak's Doppler from its own Doppler peak (processor.hpp)
//     max_angle_peaks: 2          # azimuth peaks per range-Doppler detection
//     angle_peak_db: 10.0         # further azimuth peaks within this many dB of the strongest
//     cfar:
//       type: ca                  # ca (cell averaging) | os (ordered statistic)
//       mode: 2d                  # 2d (rectangular window) | dual_pass (range pass AND Doppler pass)
//       pfa: 1.0e-4               # design false-alarm probability per cell (sets the threshold)
//       guard_range: 2            # guard cells each side of the cell under test, range
//       train_range: 8            # training cells each side beyond the guard, range
//       guard_doppler: 1
//       train_doppler: 4          # Doppler wraps around (circular)
//       os_rank: 0.75             # OS: k = round(os_rank * training cells)
//       discard_near_bins: 4      # range bins [0, near) and [N - far, N) take no part in CFAR
//       discard_far_bins: -1      # (TX-RX leakage near; IF filter band edge far); -1: N_r / 10
//       peak_grouping: true       # keep only range-Doppler local maxima (3 x 3, Doppler circular)
//       max_detections: 1024      # strongest range-Doppler detections kept per frame
//
// The angle FFT size is the radar configuration's angle_fft_size, not a DSP option.
#pragma once

#include <iosfwd>
#include <string>

namespace rsrio {

class OptionsNode;

struct CfarOptions {
  std::string type = "ca";
  std::string mode = "2d";
  double pfa = 1e-4;
  int guard_range = 2;
  int train_range = 8;
  int guard_doppler = 1;
  int train_doppler = 4;
  double os_rank = 0.75;
  int discard_near_bins = 4;
  int discard_far_bins = -1;  // -1: ceil(N_r / 10)
  bool peak_grouping = true;
  int max_detections = 1024;
};

struct DspOptions {
  std::string range_window = "hann";
  std::string doppler_window = "hann";
  std::string angle_window = "none";
  bool dc_removal = true;
  bool clutter_removal = false;
  bool tdm_compensation = true;
  bool calibration = true;
  std::string fft_planning = "estimate";
  // Sub-bin range, Doppler and azimuth of points: the three-bin log-parabola fit, mapped back
  // through what it gives for a single tone under the FFT's own window ("calibrated"), or as it
  // is ("gaussian": biased by up to 0.02 bins, towards the middle between two bins;
  // rsrio/dsp/peak_interpolation.hpp), or none (each point at its bin).
  std::string interpolation = "calibrated";
  // Off by default: the cascade's ego-velocity is half as noisy frame to frame with it, but the
  // simulated walks' frontend was not better (README, DSP).
  bool doppler_own_peak = false;
  int max_angle_peaks = 2;
  double angle_peak_db = 10.0;
  CfarOptions cfar;
};

/// Reads the keys of a `dsp` section (all optional; defaults above), checking type, range and
/// choices; rejects unknown keys. Throws ConfigError naming the file and the key.
DspOptions load_dsp_options(OptionsNode& node);

/// Checks a DspOptions made in code; throws ConfigError(file, "dsp.<key>", expected).
void validate(const DspOptions& options, const std::string& file = "<built-in>");

/// The options as a `dsp:` YAML section (what programs print at start-up).
void print(std::ostream& out, const DspOptions& options);

}  // namespace rsrio

// The DSP stage (SPEC Sec. 7): one raw ADC frame (AdcCube) -> RAD cube, RA image, RD image and
// CFAR points, with fftw3f.
//
// ------------------------------------------------------------------------------------------------
// SIGNAL MODEL the DSP assumes (the simulator must produce exactly this; tests synthesise it)
// ------------------------------------------------------------------------------------------------
// For loop m (0..L-1), TDM slot k (0..N_tx-1, TX id tx_order[k]), RX channel r, fast-time
// sample n (0..N_s-1), a sum over point scatterers i plus noise:
//
//   s[m][k][r][n] = sum_i a_i exp( j * ( 2 pi f_b,i (n - N_s / 2) / f_s
//                                      + 4 pi R_i(t_mk) / lambda
//                                      - 2 pi d (p_az(k,r) u_y,i + p_el(k,r) u_z,i) ) ) + w
//
//   t_mk    = (m N_tx + k) T_c              start of the chirp in its own TDM slot, T_c = idle + ramp end
//   R_i(t)  = R_i + v_i t                   v_i > 0: RECEDING (range increasing)
//   f_b,i   = 2 S R_i(t_mk) / c             S = slope [Hz/s]; (+2 v_i / lambda, negligible, may be added)
//   lambda  = c / f_c, f_c = derive().center_frequency_hz (centre of the sampled sweep)
//   d       = derive().element_spacing_wavelengths = 0.5 f_c / f_design (wavelengths per unit of position)
//   p_az, p_el = derive().virtual_channels[k * N_rx + r].azimuth / .elevation (half-wavelength units
//                at the design frequency, TX + RX position)
//   u = (u_x, u_y, u_z) unit direction of the scatterer in the radar frame (x forward, y left, z up):
//       u_y = cos(el) sin(az), u_z = sin(el); az > 0 to the LEFT, el > 0 UP.
//       At el = 0 the spatial phase is - pi p_az sin(az) (d / 0.5).
//   w: complex white Gaussian noise. Samples stay on the int16 scale of the ADC (no normalisation).
// This is the far-field phase 2 pi f tau of the tx * conj(rx) mixer (beat frequency and carrier
// phase grow with range) for antennas at y = +p_az lambda_design / 2, z = +p_el lambda_design / 2:
// azimuth positions count towards the radar's LEFT, elevation positions UP, and an element nearer
// the scatterer sees less phase. It is the convention of rsrio-sim
// (sim/include/rsrio/sim/radar_simulator.hpp, "SIGNAL CONVENTION"), which also models effects
// this textbook model leaves out (range-Doppler coupling, IF filter, residual video phase).
// Mirror a board's azimuth positions if they count to the right. (Checked once by hand against
// rsrio-sim point scatterers through this DSP: range, azimuth, elevation and Doppler, signs
// included, agree within a fraction of a bin for both presets.)
//
// The beat term is referred to the middle sample, where the sweep is at f_c: referred to the
// first, the carrier term would belong to the sweep's frequency there, and a moving target's
// phase would advance as at f_c + B/2 while the DSP converts it with lambda at f_c (0.66 % of
// the Doppler on the cascade: 0.023 bins at 3.5 bins). Any constant phase (e.g. 2 pi f_b t_adc,
// or 2 pi f_0 tau instead of 4 pi R / lambda) is harmless. The TDM artefact is the slot term: virtual channel of slot k carries the extra phase
// 4 pi v k T_c / lambda, which the TDM compensation removes.
//
// ------------------------------------------------------------------------------------------------
// PROCESSING (every DFT forward and unnormalised: X[q] = sum_n x[n] exp(-j 2 pi q n / N))
// ------------------------------------------------------------------------------------------------
//  1. per chirp: x - mean(x) (dc_removal), times the range window normalised to unit sum, times the
//     channel calibration g_v exp(-j 2 pi f_off,v n / f_s) (calibration; v = TX id * N_rx + r as
//     RadarConfig::calibration), zero-padded to N_r = derive().range_fft_size, range DFT.
//  2. clutter_removal: subtract, per (virtual channel, range bin), the mean over the L loops.
//  3. Doppler window (unit sum) over loops, zero-padded to N_d = derive().doppler_fft_size,
//     Doppler DFT, fftshift: output bin d holds DFT bin (d - N_d / 2) mod N_d.
//     -> channels(): [virtual][range][doppler] complex.  RD = sum over ALL virtual channels of |.|^2.
//  4. TDM compensation: channel of slot k times exp(-j 2 pi k (d - N_d / 2) / (N_tx N_d)).
//  5. Angle: the filled azimuth array = the unique azimuth positions at the lowest elevation row
//     (first virtual channel, in slot-major order, at each position), element i at FFT input
//     index max(p) - p_i (mirrored: the spatial phase falls with p, see the model), angle window
//     (unit sum), zero-padded to N_a = config.angle_fft_size, DFT, fftshift.
//     RAD = |.|^2;  RA = sum over Doppler of RAD.
//  With the unit-sum windows a single scatterer of per-sample amplitude A gives a peak of A^2 in
//  channels() power and in RAD, and N_virtual A^2 in RD (on the bin, no scalloping).
//
// ------------------------------------------------------------------------------------------------
// GRIDS (grids() holds them)
// ------------------------------------------------------------------------------------------------
//   range     r = 0..N_r-1   range_m[r]     = r * derive().range_bin_size_m
//   Doppler   d = 0..N_d-1   doppler_mps[d] = (d - N_d/2) * derive().velocity_bin_size_mps
//                            (positive = receding; unambiguous [-v_max, v_max) )
//   azimuth   a = 0..N_a-1   azimuth_sin[a] = (a - N_a/2) / (N_a d)      (= u_y, sin(az) at el 0)
//                            azimuth_deg[a] = asin(azimuth_sin[a]), NaN where |sin| > 1
//                            The grid spans u_y in [-1/(2d), 1/(2d)); with d > 1/2 (the cascade's
//                            0.513 at the chirps' centre) a return beyond its edge wraps by 1/d
//                            to the other side, so a point with |u_y| > azimuth_unambiguous_sin
//                            = 1/d - 1 may be such an alias (DspPoint::azimuth_ambiguous).
//   Layouts (row-major, last index fastest):
//     rad  float32 [range][doppler][azimuth]   (the angle spectrum of each range-Doppler cell
//                                              contiguous)
//     ra   float32 [range][azimuth]
//     rd   float32 [range][doppler]
//     channels complex64 [virtual][range][doppler] (after step 3, before step 4)
//
// ------------------------------------------------------------------------------------------------
// DETECTION
// ------------------------------------------------------------------------------------------------
// CFAR (rsrio/dsp/cfar.hpp for the threshold design) runs on RD over range bins
// [discard_near, N_r - discard_far) (discard_far -1: ceil(N_r / 10), the IF filter's band edge)
// and every Doppler bin (Doppler training wraps around); the discarded bins are not training
// cells either (the window is cut at the region's edges and the threshold designed for the
// cells that remain). peak_grouping keeps RD local maxima (3 x 3, Doppler circular).
// Each detection becomes up to max_angle_peaks points: local maxima of RAD[r][d][.] (circular,
// |sin| <= 1) within angle_peak_db of the strongest. A peak at azimuth bin a is measured in
// Doppler bin d' = d, or with doppler_own_peak in its own Doppler bin: RAD[r][.][a] climbed from
// d to its maximum, at most the Doppler window's main lobe (2 resolution cells) away, since a
// return at another azimuth of the range ring reaches bin d from anywhere in that lobe (without
// it such a return's Doppler comes out up to a bin off, at d). The range and Doppler fits and the
// elevation are made at d', the azimuth fit at d where the peak was found (with two returns, the
// xwr1843's 8-element array's sidelobes moved it more at d'). Each point gets, in the radar frame:
//   range_m     (r + dr) * range bin,  dr from a Gaussian (log-parabolic) fit over RAD at d',
//               |dr| <= 0.5, mapped back through what the fit gives for a single tone under the
//               range window (DspOptions::interpolation "calibrated"; peak_interpolation.hpp;
//               so are dd under the Doppler window and da under the filled array's aperture)
//   doppler_mps (d' + dd - N_d/2) * velocity bin (same fit; positive = receding)
//   u_y         (a + da - N_a/2) / (N_a d)
//   u_z         elevation: where the array has virtual channels above the lowest row at the same
//               azimuth position as a filled-array element: both rows beamformed to u_y, their
//               cross products (at Doppler bin d') phase-fitted over a u_z grid of step 0.005
//               (all rows jointly);
//               otherwise 0 and elevation_measured = false
//   azimuth_deg = atan2(u_y, u_x), elevation_deg = asin(u_z), u_x = sqrt(1 - u_y^2 - u_z^2)
//   x, y, z     = range_m * (u_x, u_y, u_z)   (x forward, y left, z up)
//   snr_db      coherent SNR of the beamformed point: 10 log10( RAD[r][d'][a] /
//               (noise_rd / N_virtual * sum_i w_i^2) ), w = unit-sum angle window, noise_rd the
//               CFAR's estimate of the mean noise power of an RD cell.
//
// Real-time use: plans are made once in the constructor (under fftw_planner_mutex()); process()
// allocates nothing (every buffer, the detection and point lists included, is sized at
// construction). One DspProcessor per thread.
#pragma once

#include <complex>
#include <cstddef>
#include <memory>
#include <span>
#include <vector>

#include "rsrio/common/adc_cube.hpp"
#include "rsrio/common/radar_config.hpp"
#include "rsrio/dsp/dsp_options.hpp"

namespace rsrio {

struct DspGrids {
  int range_bins = 0;    // N_r
  int doppler_bins = 0;  // N_d
  int azimuth_bins = 0;  // N_a
  double range_bin_m = 0;
  double velocity_bin_mps = 0;
  double azimuth_sin_bin = 0;  // 1 / (N_a d)
  double azimuth_unambiguous_sin = 0;  // 1/d - 1: beyond, a point may be a wrapped return
  double element_spacing_wavelengths = 0;
  double wavelength_m = 0;
  std::vector<double> range_m;
  std::vector<double> doppler_mps;
  std::vector<double> azimuth_sin;
  std::vector<double> azimuth_deg;
  /// The filled azimuth array: element i sits at FFT input index azimuth_positions[i]
  /// (= max position - its position) and is virtual channel azimuth_channels[i] (index into
  /// derive().virtual_channels), in increasing order of position.
  std::vector<int> azimuth_positions;
  std::vector<int> azimuth_channels;
  /// Whether the array can measure elevation (virtual channels above the lowest row that pair
  /// with filled-array elements).
  bool has_elevation = false;
};

/// One CFAR detection on the RD image.
struct DspDetection {
  int range_bin = 0;
  int doppler_bin = 0;
  float power = 0;  // RD power
  float noise = 0;  // CFAR estimate of the mean noise power of an RD cell
  float threshold = 0;
  float snr_db = 0;  // 10 log10(power / noise), non-coherent over the virtual channels
};

/// One point (a detection's azimuth peak), radar frame: x forward, y left, z up.
struct DspPoint {
  float range_m = 0;
  float azimuth_deg = 0;    // > 0 to the left
  float elevation_deg = 0;  // > 0 up
  float doppler_mps = 0;    // > 0 receding (range increasing)
  float snr_db = 0;         // coherent, see header comment
  float x = 0, y = 0, z = 0;
  float power = 0;      // RAD at the peak
  float range_bin = 0;  // fractional grid positions (after interpolation)
  float doppler_bin = 0;
  float azimuth_bin = 0;
  bool elevation_measured = false;
  // |u_y| beyond grids().azimuth_unambiguous_sin: the return may lie 1/d across, on the other
  // side (a wall 80 deg to the left comes out at -77 deg on the cascade), and its side is unknown.
  bool azimuth_ambiguous = false;
  int detection = 0;  // index into DspResult::detections
};

/// Views into the processor's buffers; valid until the next process() or the processor's end.
struct DspResult {
  std::span<const float> rad;                     // [range][doppler][azimuth]
  std::span<const float> ra;                      // [range][azimuth]
  std::span<const float> rd;                      // [range][doppler]
  std::span<const std::complex<float>> channels;  // [virtual][range][doppler]
  std::span<const DspDetection> detections;       // sorted by (range bin, Doppler bin)
  std::span<const DspPoint> points;               // grouped by detection, strongest peak first
  std::size_t cells_tested = 0;                   // RD cells the CFAR evaluated
  std::size_t frames = 0;                         // frames processed so far
};

/// An owning copy of a frame's images and points: DspResult only views the processor's buffers,
/// valid until its next frame. What keeps a frame for later (the daemon's keyframe hand-over,
/// tests); view() is a DspResult over the copy.
struct DspImages {
  std::vector<float> ra, rd;
  std::vector<DspPoint> points;
  DspResult view() const {
    DspResult r;
    r.ra = ra;
    r.rd = rd;
    r.points = points;
    return r;
  }
};

class DspProcessor {
 public:
  /// Validates `options` and makes the plans. Throws ConfigError for options that do not fit
  /// the radar (e.g. a CFAR window wider than the Doppler axis), std::invalid_argument for a
  /// radar configuration the DSP cannot process.
  explicit DspProcessor(const RadarConfig& config, const DspOptions& options = {});
  ~DspProcessor();
  DspProcessor(DspProcessor&&) noexcept;
  DspProcessor& operator=(DspProcessor&&) noexcept;
  DspProcessor(const DspProcessor&) = delete;
  DspProcessor& operator=(const DspProcessor&) = delete;

  /// Processes one frame. Allocation-free. Throws std::invalid_argument when the cube's shape is
  /// not the configuration's.
  const DspResult& process(const AdcCube& cube);
  const DspResult& result() const;

  const DspGrids& grids() const;
  const RadarConfig& config() const;
  const DspOptions& options() const;
  /// The CFAR scale factor used for a cell in range bin r (2d mode; the range pass in dual_pass).
  double cfar_alpha(int range_bin) const;
  /// The number of training cells for range bin r (same pass as cfar_alpha).
  int cfar_training_cells(int range_bin) const;
  /// The equivalent Gamma shape of the RD noise (number of virtual channels, Satterthwaite-
  /// corrected for unequal calibration gains).
  double cfar_shape() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rsrio

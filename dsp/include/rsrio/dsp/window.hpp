// Tapering windows of the DSP chain (n = 0 .. N-1):
//   none      w = 1
//   hann      w = 0.5 - 0.5 cos(2 pi (n + 1) / (N + 1))      (MATLAB hanning(N), TI's chain: no zero ends)
//   hamming   w = 0.54 - 0.46 cos(2 pi n / (N - 1))
//   blackman  w = 0.42 - 0.5 cos(2 pi n / (N - 1)) + 0.08 cos(4 pi n / (N - 1))
// (N = 1 gives w = 1 for every type.)
#pragma once

#include <string_view>
#include <vector>

namespace rsrio {

/// Throws std::invalid_argument for an unknown type or n < 1.
std::vector<double> make_window(std::string_view type, int n);

}  // namespace rsrio

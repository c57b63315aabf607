#include "rsrio/dsp/window.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace rsrio {

std::vector<double> make_window(std::string_view type, int n) {
  if (n < 1) throw std::invalid_argument("window length must be >= 1");
  std::vector<double> w(static_cast<std::size_t>(n), 1.0);
  if (type == "none" || n == 1) {
    if (type != "none" && type != "hann" && type != "hamming" && type != "blackman")
      throw std::invalid_argument("unknown window '" + std::string(type) + "'");
    return w;
  }
  const double pi = std::numbers::pi;
  for (int i = 0; i < n; ++i) {
    const double x = static_cast<double>(i) / (n - 1);
    if (type == "hann")
      w[i] = 0.5 - 0.5 * std::cos(2 * pi * (i + 1) / (n + 1));
    else if (type == "hamming")
      w[i] = 0.54 - 0.46 * std::cos(2 * pi * x);
    else if (type == "blackman")
      w[i] = 0.42 - 0.5 * std::cos(2 * pi * x) + 0.08 * std::cos(4 * pi * x);
    else
      throw std::invalid_argument("unknown window '" + std::string(type) + "'");
  }
  return w;
}

}  // namespace rsrio

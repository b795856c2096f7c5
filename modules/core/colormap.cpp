#include <diffreg/core/colormap.h>

#include <algorithm>
#include <cmath>

namespace diffreg {

std::array<std::uint8_t, 3> viridis(double s) {
  // Viridis sampled at 9 evenly spaced stops, linearly interpolated.
  static const double stops[9][3] = {
      {0.267, 0.005, 0.329}, {0.279, 0.175, 0.483}, {0.230, 0.322, 0.546},
      {0.173, 0.449, 0.558}, {0.128, 0.567, 0.551}, {0.158, 0.684, 0.502},
      {0.369, 0.789, 0.383}, {0.678, 0.864, 0.190}, {0.993, 0.906, 0.144}};
  if (!std::isfinite(s)) s = 0.0;
  s = std::clamp(s, 0.0, 1.0) * 8.0;
  const int i = std::min(7, static_cast<int>(s));
  const double f = s - i;
  std::array<std::uint8_t, 3> rgb{};
  for (int c = 0; c < 3; ++c) {
    const double v = (1.0 - f) * stops[i][c] + f * stops[i + 1][c];
    rgb[c] = static_cast<std::uint8_t>(std::lround(255.0 * v));
  }
  return rgb;
}

}  // namespace diffreg

// Perceptual colour maps for scalar fields (weights, distortion).
#pragma once

#include <array>
#include <cstdint>

namespace diffreg {

/// Viridis, a perceptually uniform map: s in [0, 1] (clamped; NaN maps to 0) to 8-bit RGB.
std::array<std::uint8_t, 3> viridis(double s);

}  // namespace diffreg

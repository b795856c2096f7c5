// RGB images for figures: pixel access, PNG reading and writing (libpng), text (Cairo, DejaVu
// Sans), and multi-panel composition.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace diffreg {

/// An 8-bit RGB colour.
using Rgb = std::array<std::uint8_t, 3>;

namespace colors {
inline constexpr Rgb white{255, 255, 255};
inline constexpr Rgb black{0, 0, 0};
inline constexpr Rgb darkGray{40, 40, 40};
inline constexpr Rgb red{220, 30, 30};
}  // namespace colors

/// Linear mix of two colours: t = 0 gives a, t = 1 gives b (t clamped to [0, 1]).
Rgb mix(const Rgb& a, const Rgb& b, double t);

/// A width x height RGB image, rows top to bottom, 3 bytes per pixel.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;

  Image() = default;
  /// A width x height image filled with `background`.
  /// \throw InvalidParameter when a size is negative or the image would exceed 2^28 pixels.
  Image(int width, int height, const Rgb& background = colors::white);

  bool contains(int x, int y) const { return x >= 0 && y >= 0 && x < width && y < height; }
  /// Sets pixel (x, y); pixels outside the image are ignored (drawing clips).
  void set(int x, int y, const Rgb& color);
  /// Blends `color` over pixel (x, y) with opacity alpha in [0, 1]; outside pixels are ignored.
  void blend(int x, int y, const Rgb& color, double alpha);
  /// Pixel (x, y). \throw InvalidParameter when (x, y) is outside the image.
  Rgb get(int x, int y) const;
  void fill(const Rgb& color);
  /// Fills the rectangle [x, x + w) x [y, y + h), clipped to the image.
  void fillRect(int x, int y, int w, int h, const Rgb& color);
  /// Copies `other` with its top-left corner at (x, y), clipped to this image.
  void blit(const Image& other, int x, int y);
};

/// Writes `image` as an 8-bit RGB PNG. The file appears complete or not at all: the data go to
/// a temporary file in the same directory that is renamed onto `path`.
/// \throw InvalidParameter for an empty image. \throw IoError when the directory does not
///        exist or is not writable, or writing fails (nothing is left behind).
void writePng(const std::string& path, const Image& image);

/// Reads a PNG (any bit depth or colour type; alpha is composited over white) as 8-bit RGB.
/// \throw IoError when the file cannot be opened or is not a valid PNG.
Image readPng(const std::string& path);

/// Loads what draws text (Cairo, libcairo.so.2, loaded on first use rather than at start), so
/// that a run that will draw a figure fails before its work when it is missing.
/// \throw IoError naming the library when it cannot be loaded.
void requireTextRendering();

/// Height of a line of text in pixels at `scale` (the font's ascent plus descent; the font is
/// 9 * scale pixels). \throw InvalidParameter when scale < 1.
int textHeight(int scale);
/// Width in pixels of `text` (UTF-8) drawn at `scale`. \throw InvalidParameter when scale < 1.
int textWidth(const std::string& text, int scale);
/// Draws `text` (UTF-8; Cairo draws nothing for invalid UTF-8) in DejaVu Sans, anti-aliased,
/// top-left corner at (x, y), inside the box textWidth x textHeight. Clips to the image.
/// \throw InvalidParameter when scale < 1.
void drawText(Image& image, int x, int y, const std::string& text, const Rgb& color, int scale = 1);

/// Lays `panels` out row by row in `columns` columns, each cell as large as the largest panel
/// (panels centred in their cells), `spacing` pixels between and around cells.
/// \throw InvalidParameter when panels is empty, columns < 1 or spacing < 0.
Image composeGrid(const std::vector<Image>& panels, int columns, int spacing = 10,
                  const Rgb& background = colors::white);

}  // namespace diffreg

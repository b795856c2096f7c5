// Text in figures, drawn by Cairo with DejaVu Sans (found through fontconfig), anti-aliased and
// blended onto the image: textHeight, textWidth and drawText of image.h.
#include <diffreg/render/image.h>

#include <diffreg/core/error.h>

#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

namespace diffreg {

namespace {

constexpr const char* kFontFamily = "DejaVu Sans";
constexpr double kPixelsPerScale = 9.0;  // font size in pixels at scale 1

struct SurfaceDeleter {
  void operator()(cairo_surface_t* s) const { cairo_surface_destroy(s); }
};
struct ContextDeleter {
  void operator()(cairo_t* c) const { cairo_destroy(c); }
};
using Surface = std::unique_ptr<cairo_surface_t, SurfaceDeleter>;
using Context = std::unique_ptr<cairo_t, ContextDeleter>;

/// A Cairo context on `surface` with the figure font at `scale`.
Context fontContext(cairo_surface_t* surface, int scale) {
  Context cr(cairo_create(surface));
  cairo_select_font_face(cr.get(), kFontFamily, CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr.get(), kPixelsPerScale * scale);
  return cr;
}

/// Font and text measures at `scale` (a scratch surface: measuring draws nothing).
struct Measures {
  cairo_font_extents_t font{};
  cairo_text_extents_t text{};
};
Measures measure(const std::string& text, int scale) {
  const Surface scratch(cairo_image_surface_create(CAIRO_FORMAT_A8, 1, 1));
  const Context cr = fontContext(scratch.get(), scale);
  Measures m;
  cairo_font_extents(cr.get(), &m.font);
  if (!text.empty()) cairo_text_extents(cr.get(), text.c_str(), &m.text);
  return m;
}

void checkScale(const char* function, int scale) {
  if (scale < 1)
    throw InvalidParameter(std::string(function) + ": scale must be >= 1, got " +
                           std::to_string(scale));
}

}  // namespace

int textHeight(int scale) {
  checkScale("textHeight", scale);
  const Measures m = measure("", scale);
  return static_cast<int>(std::ceil(m.font.ascent + m.font.descent));
}

int textWidth(const std::string& text, int scale) {
  checkScale("textWidth", scale);
  if (text.empty()) return 0;
  const Measures m = measure(text, scale);
  // The advance, or the ink's right edge where a glyph reaches past it.
  return static_cast<int>(
      std::ceil(std::max(m.text.x_advance, m.text.x_bearing + m.text.width)));
}

void drawText(Image& image, int x, int y, const std::string& text, const Rgb& color, int scale) {
  checkScale("drawText", scale);
  const int w = textWidth(text, scale), h = textHeight(scale);
  if (w == 0 || h == 0) return;
  // The coverage of the text in an alpha-only surface of exactly its box, blended onto the
  // image: nothing is drawn outside the box textWidth x textHeight.
  const Surface surface(cairo_image_surface_create(CAIRO_FORMAT_A8, w, h));
  {
    const Context cr = fontContext(surface.get(), scale);
    cairo_font_extents_t font{};
    cairo_font_extents(cr.get(), &font);
    cairo_move_to(cr.get(), 0.0, font.ascent);
    cairo_show_text(cr.get(), text.c_str());
  }
  cairo_surface_flush(surface.get());
  const unsigned char* data = cairo_image_surface_get_data(surface.get());
  const int stride = cairo_image_surface_get_stride(surface.get());
  if (data == nullptr) return;  // Cairo could not allocate the surface: no text
  for (int row = 0; row < h; ++row)
    for (int col = 0; col < w; ++col) {
      const unsigned char coverage = data[row * stride + col];
      if (coverage > 0) image.blend(x + col, y + row, color, coverage / 255.0);
    }
}

}  // namespace diffreg

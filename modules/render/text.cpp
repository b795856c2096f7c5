// Text in figures, drawn by Cairo with DejaVu Sans (found through fontconfig), anti-aliased and
// blended onto the image: textHeight, textWidth and drawText of image.h.
//
// Cairo is loaded when the first text is measured or drawn, not linked: with its X11, fontconfig
// and FreeType dependencies it would add about 2 ms to the start of every diffreg run, most of
// which draw nothing.
#include <diffreg/render/image.h>

#include <diffreg/core/error.h>

#include <cairo.h>  // types and signatures only; the functions come from cairo() below
#include <dlfcn.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

namespace diffreg {

namespace {

constexpr const char* kFontFamily = "DejaVu Sans";
constexpr double kPixelsPerScale = 9.0;  // font size in pixels at scale 1
constexpr const char* kCairoLibrary = "libcairo.so.2";

// The Cairo functions used here, from the library loaded once (kept loaded for the process).
struct Cairo {
  decltype(&cairo_image_surface_create) imageSurfaceCreate;
  decltype(&cairo_image_surface_get_data) imageSurfaceGetData;
  decltype(&cairo_image_surface_get_stride) imageSurfaceGetStride;
  decltype(&cairo_surface_flush) surfaceFlush;
  decltype(&cairo_surface_destroy) surfaceDestroy;
  decltype(&cairo_create) create;
  decltype(&cairo_destroy) destroy;
  decltype(&cairo_select_font_face) selectFontFace;
  decltype(&cairo_set_font_size) setFontSize;
  decltype(&cairo_font_extents) fontExtents;
  decltype(&cairo_text_extents) textExtents;
  decltype(&cairo_move_to) moveTo;
  decltype(&cairo_show_text) showText;
};

template <class F>
void bind(void* library, F& function, const char* name) {
  function = reinterpret_cast<F>(dlsym(library, name));
  if (!function)
    throw IoError(std::string("text in figures: ") + kCairoLibrary + " has no " + name);
}

Cairo loadCairo() {
  void* library = dlopen(kCairoLibrary, RTLD_NOW | RTLD_LOCAL);
  if (!library) {
    const char* why = dlerror();
    throw IoError(std::string("text in figures needs Cairo: cannot load ") + kCairoLibrary +
                  (why ? std::string(" (") + why + ")" : std::string()) + " (Debian: libcairo2)");
  }
  Cairo c{};
  bind(library, c.imageSurfaceCreate, "cairo_image_surface_create");
  bind(library, c.imageSurfaceGetData, "cairo_image_surface_get_data");
  bind(library, c.imageSurfaceGetStride, "cairo_image_surface_get_stride");
  bind(library, c.surfaceFlush, "cairo_surface_flush");
  bind(library, c.surfaceDestroy, "cairo_surface_destroy");
  bind(library, c.create, "cairo_create");
  bind(library, c.destroy, "cairo_destroy");
  bind(library, c.selectFontFace, "cairo_select_font_face");
  bind(library, c.setFontSize, "cairo_set_font_size");
  bind(library, c.fontExtents, "cairo_font_extents");
  bind(library, c.textExtents, "cairo_text_extents");
  bind(library, c.moveTo, "cairo_move_to");
  bind(library, c.showText, "cairo_show_text");
  return c;
}

// Loaded on first use; a failure is thrown to every caller (and tried again by the next).
const Cairo& cairo() {
  static const Cairo api = loadCairo();
  return api;
}

struct SurfaceDeleter {
  void operator()(cairo_surface_t* s) const { cairo().surfaceDestroy(s); }
};
struct ContextDeleter {
  void operator()(cairo_t* c) const { cairo().destroy(c); }
};
using Surface = std::unique_ptr<cairo_surface_t, SurfaceDeleter>;
using Context = std::unique_ptr<cairo_t, ContextDeleter>;

/// A Cairo context on `surface` with the figure font at `scale`.
Context fontContext(cairo_surface_t* surface, int scale) {
  Context cr(cairo().create(surface));
  cairo().selectFontFace(cr.get(), kFontFamily, CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo().setFontSize(cr.get(), kPixelsPerScale * scale);
  return cr;
}

/// Font and text measures at `scale` (a scratch surface: measuring draws nothing).
struct Measures {
  cairo_font_extents_t font{};
  cairo_text_extents_t text{};
};
Measures measure(const std::string& text, int scale) {
  const Surface scratch(cairo().imageSurfaceCreate(CAIRO_FORMAT_A8, 1, 1));
  const Context cr = fontContext(scratch.get(), scale);
  Measures m;
  cairo().fontExtents(cr.get(), &m.font);
  if (!text.empty()) cairo().textExtents(cr.get(), text.c_str(), &m.text);
  return m;
}

void checkScale(const char* function, int scale) {
  if (scale < 1)
    throw InvalidParameter(std::string(function) + ": scale must be >= 1, got " +
                           std::to_string(scale));
}

}  // namespace

void requireTextRendering() { cairo(); }

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
  return static_cast<int>(std::ceil(std::max(m.text.x_advance, m.text.x_bearing + m.text.width)));
}

void drawText(Image& image, int x, int y, const std::string& text, const Rgb& color, int scale) {
  checkScale("drawText", scale);
  const int w = textWidth(text, scale), h = textHeight(scale);
  if (w == 0 || h == 0) return;
  // The coverage of the text in an alpha-only surface of exactly its box, blended onto the
  // image: nothing is drawn outside the box textWidth x textHeight.
  const Surface surface(cairo().imageSurfaceCreate(CAIRO_FORMAT_A8, w, h));
  {
    const Context cr = fontContext(surface.get(), scale);
    cairo_font_extents_t font{};
    cairo().fontExtents(cr.get(), &font);
    cairo().moveTo(cr.get(), 0.0, font.ascent);
    cairo().showText(cr.get(), text.c_str());
  }
  cairo().surfaceFlush(surface.get());
  const unsigned char* data = cairo().imageSurfaceGetData(surface.get());
  const int stride = cairo().imageSurfaceGetStride(surface.get());
  if (data == nullptr) return;  // Cairo could not allocate the surface: no text
  for (int row = 0; row < h; ++row)
    for (int col = 0; col < w; ++col) {
      const unsigned char coverage = data[row * stride + col];
      if (coverage > 0) image.blend(x + col, y + row, color, coverage / 255.0);
    }
}

}  // namespace diffreg

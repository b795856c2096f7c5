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

// The Cairo functions used here, each named once: X(name) stands for cairo_<name>, bound from the
// library loaded once (kept loaded for the process) to a member of that name and type.
#define DIFFREG_CAIRO_FUNCTIONS(X) \
  X(image_surface_create)          \
  X(image_surface_get_data)        \
  X(image_surface_get_stride)      \
  X(surface_flush)                 \
  X(surface_destroy)               \
  X(create)                        \
  X(destroy)                       \
  X(select_font_face)              \
  X(set_font_size)                 \
  X(font_extents)                  \
  X(text_extents)                  \
  X(move_to)                       \
  X(show_text)

struct Cairo {
#define DIFFREG_CAIRO_MEMBER(name) decltype(&cairo_##name) name;
  DIFFREG_CAIRO_FUNCTIONS(DIFFREG_CAIRO_MEMBER)
#undef DIFFREG_CAIRO_MEMBER
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
#define DIFFREG_CAIRO_BIND(name) bind(library, c.name, "cairo_" #name);
  DIFFREG_CAIRO_FUNCTIONS(DIFFREG_CAIRO_BIND)
#undef DIFFREG_CAIRO_BIND
  return c;
}
#undef DIFFREG_CAIRO_FUNCTIONS

// Loaded on first use; a failure is thrown to every caller (and tried again by the next).
const Cairo& cairo() {
  static const Cairo api = loadCairo();
  return api;
}

struct SurfaceDeleter {
  void operator()(cairo_surface_t* s) const { cairo().surface_destroy(s); }
};
struct ContextDeleter {
  void operator()(cairo_t* c) const { cairo().destroy(c); }
};
using Surface = std::unique_ptr<cairo_surface_t, SurfaceDeleter>;
using Context = std::unique_ptr<cairo_t, ContextDeleter>;

/// A Cairo context on `surface` with the figure font at `scale`.
Context fontContext(cairo_surface_t* surface, int scale) {
  Context cr(cairo().create(surface));
  cairo().select_font_face(cr.get(), kFontFamily, CAIRO_FONT_SLANT_NORMAL,
                           CAIRO_FONT_WEIGHT_NORMAL);
  cairo().set_font_size(cr.get(), kPixelsPerScale * scale);
  return cr;
}

/// Font and text measures at `scale` (a scratch surface: measuring draws nothing).
struct Measures {
  cairo_font_extents_t font{};
  cairo_text_extents_t text{};
};
Measures measure(const std::string& text, int scale) {
  const Surface scratch(cairo().image_surface_create(CAIRO_FORMAT_A8, 1, 1));
  const Context cr = fontContext(scratch.get(), scale);
  Measures m;
  cairo().font_extents(cr.get(), &m.font);
  if (!text.empty()) cairo().text_extents(cr.get(), text.c_str(), &m.text);
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
  const Surface surface(cairo().image_surface_create(CAIRO_FORMAT_A8, w, h));
  {
    const Context cr = fontContext(surface.get(), scale);
    cairo_font_extents_t font{};
    cairo().font_extents(cr.get(), &font);
    cairo().move_to(cr.get(), 0.0, font.ascent);
    cairo().show_text(cr.get(), text.c_str());
  }
  cairo().surface_flush(surface.get());
  const unsigned char* data = cairo().image_surface_get_data(surface.get());
  const int stride = cairo().image_surface_get_stride(surface.get());
  if (data == nullptr) return;  // Cairo could not allocate the surface: no text
  for (int row = 0; row < h; ++row)
    for (int col = 0; col < w; ++col) {
      const unsigned char coverage = data[row * stride + col];
      if (coverage > 0) image.blend(x + col, y + row, color, coverage / 255.0);
    }
}

}  // namespace diffreg

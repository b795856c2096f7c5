#include <diffreg/render/image.h>

#include <diffreg/core/error.h>
#include <diffreg/core/file.h>

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace diffreg {

Rgb mix(const Rgb& a, const Rgb& b, double t) {
  if (!(t > 0.0)) return a;
  if (t >= 1.0) return b;
  Rgb out{};
  for (int c = 0; c < 3; ++c)
    out[c] = static_cast<std::uint8_t>(std::lround((1.0 - t) * a[c] + t * b[c]));
  return out;
}

Image::Image(int w, int h, const Rgb& background) : width(w), height(h) {
  if (w < 0 || h < 0 || static_cast<long long>(w) * h > (1LL << 28)) {
    throw InvalidParameter("Image: invalid size " + std::to_string(w) + " x " + std::to_string(h));
  }
  rgb.resize(static_cast<std::size_t>(w) * h * 3);
  fill(background);
}

void Image::set(int x, int y, const Rgb& color) {
  if (!contains(x, y)) return;
  std::uint8_t* p = &rgb[(static_cast<std::size_t>(y) * width + x) * 3];
  p[0] = color[0];
  p[1] = color[1];
  p[2] = color[2];
}

void Image::blend(int x, int y, const Rgb& color, double alpha) {
  if (!contains(x, y) || !(alpha > 0.0)) return;
  set(x, y, mix(get(x, y), color, alpha));
}

Rgb Image::get(int x, int y) const {
  if (!contains(x, y)) {
    throw InvalidParameter("Image::get: pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                           ") outside " + std::to_string(width) + " x " + std::to_string(height));
  }
  const std::uint8_t* p = &rgb[(static_cast<std::size_t>(y) * width + x) * 3];
  return {p[0], p[1], p[2]};
}

void Image::fill(const Rgb& color) { fillRect(0, 0, width, height, color); }

void Image::fillRect(int x, int y, int w, int h, const Rgb& color) {
  const int x0 = std::max(0, x), y0 = std::max(0, y);
  const int x1 = std::min(width, x + w), y1 = std::min(height, y + h);
  for (int j = y0; j < y1; ++j)
    for (int i = x0; i < x1; ++i) set(i, j, color);
}

void Image::blit(const Image& other, int x, int y) {
  const int x0 = std::max(0, x), y0 = std::max(0, y);
  const int x1 = std::min(width, x + other.width), y1 = std::min(height, y + other.height);
  if (x0 >= x1) return;
  for (int j = y0; j < y1; ++j) {
    const std::uint8_t* src =
        &other.rgb[(static_cast<std::size_t>(j - y) * other.width + (x0 - x)) * 3];
    std::copy(src, src + (x1 - x0) * 3, &rgb[(static_cast<std::size_t>(j) * width + x0) * 3]);
  }
}

void writePng(const std::string& path, const Image& image) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgb.size() != static_cast<std::size_t>(image.width) * image.height * 3) {
    throw InvalidParameter("writePng: '" + path + "': empty or inconsistent image");
  }
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(image.width);
  png.height = static_cast<png_uint_32>(image.height);
  png.format = PNG_FORMAT_RGB;
  // Encoded in memory (a first call for the size), then written all or nothing.
  png_alloc_size_t size = 0;
  std::vector<char> encoded;
  bool ok = png_image_write_to_memory(&png, nullptr, &size, 0, image.rgb.data(), 0, nullptr) != 0;
  if (ok) {
    encoded.resize(size);
    ok = png_image_write_to_memory(&png, encoded.data(), &size, 0, image.rgb.data(), 0, nullptr) !=
         0;
  }
  const std::string pngMessage = png.message;
  png_image_free(&png);
  if (!ok) throw IoError("writePng: cannot write '" + path + "': " + pngMessage);
  writeFileAtomically(path, [&](std::ostream& out) {
    out.write(encoded.data(), static_cast<std::streamsize>(size));
  });
}

Image readPng(const std::string& path) {
  checkNoNul(path, "read");
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&png, path.c_str())) {
    const std::string reason = png.message;
    png_image_free(&png);
    throw IoError("readPng: cannot read '" + path + "': " + reason);
  }
  png.format = PNG_FORMAT_RGB;
  if (png.width > (1u << 16) || png.height > (1u << 16)) {
    png_image_free(&png);
    throw IoError("readPng: '" + path + "' is too large");
  }
  Image image(static_cast<int>(png.width), static_cast<int>(png.height));
  png_color white{255, 255, 255};
  if (!png_image_finish_read(&png, &white, image.rgb.data(), 0, nullptr)) {
    const std::string reason = png.message;
    png_image_free(&png);
    throw IoError("readPng: cannot read '" + path + "': " + reason);
  }
  return image;
}

Image composeGrid(const std::vector<Image>& panels, int columns, int spacing,
                  const Rgb& background) {
  if (panels.empty()) throw InvalidParameter("composeGrid: no panels");
  if (columns < 1) throw InvalidParameter("composeGrid: columns must be >= 1");
  if (spacing < 0) throw InvalidParameter("composeGrid: spacing must be >= 0");
  int cellW = 0, cellH = 0;
  for (const Image& p : panels) {
    cellW = std::max(cellW, p.width);
    cellH = std::max(cellH, p.height);
  }
  const int n = static_cast<int>(panels.size());
  const int cols = std::min(columns, n);
  const int rows = (n + cols - 1) / cols;
  Image out(cols * cellW + (cols + 1) * spacing, rows * cellH + (rows + 1) * spacing, background);
  for (int k = 0; k < n; ++k) {
    const int x = spacing + (k % cols) * (cellW + spacing) + (cellW - panels[k].width) / 2;
    const int y = spacing + (k / cols) * (cellH + spacing) + (cellH - panels[k].height) / 2;
    out.blit(panels[k], x, y);
  }
  return out;
}

}  // namespace diffreg

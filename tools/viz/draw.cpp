// Pixels, lines, the bitmap font and the colour maps.
#include "draw.hpp"

#include <algorithm>
#include <cmath>

namespace tc::viz {
namespace {
#include "font_data.inc"

/// Coverage (0..255) of font pixel (gx, gy) of character `c` at `scale`.
int coverage(char ch, int gx, int gy, int scale) {
  auto code = static_cast<unsigned char>(ch);
  if (code < 32 || code > 126) code = '?';
  const int g = code - 32;
  if (scale <= 1) return kSmallGlyphs[g][gy * kSmallWidth + gx];
  const int block = scale / 2;  // scale 2: the large font; larger: its pixels repeated
  return kLargeGlyphs[g][(gy / block) * kLargeWidth + gx / block];
}

std::array<int, 2> cell_size(int scale) {
  if (scale <= 1) return {kSmallWidth, kSmallHeight};
  const int block = scale / 2;
  return {kLargeWidth * block, kLargeHeight * block};
}

}  // namespace

namespace detail {

void put_pixel(Image& img, int x, int y, Rgb c) {
  if (x < 0 || y < 0 || x >= img.width || y >= img.height) return;
  const std::size_t i = (static_cast<std::size_t>(y) * img.width + x) * 3;
  img.rgb[i] = c[0];
  img.rgb[i + 1] = c[1];
  img.rgb[i + 2] = c[2];
}

void blend_pixel(Image& img, int x, int y, Rgb c, double alpha) {
  if (x < 0 || y < 0 || x >= img.width || y >= img.height || !(alpha > 0)) return;
  alpha = std::min(alpha, 1.0);
  const std::size_t i = (static_cast<std::size_t>(y) * img.width + x) * 3;
  for (int k = 0; k < 3; ++k)
    img.rgb[i + k] =
        static_cast<std::uint8_t>(std::lround(alpha * c[k] + (1.0 - alpha) * img.rgb[i + k]));
}

void fill_rect(Image& img, int x, int y, int w, int h, Rgb c) {
  for (int j = std::max(0, y); j < std::min(img.height, y + h); ++j)
    for (int i = std::max(0, x); i < std::min(img.width, x + w); ++i) put_pixel(img, i, j, c);
}

void draw_rect_outline(Image& img, int x, int y, int w, int h, Rgb c) {
  fill_rect(img, x, y, w, 1, c);
  fill_rect(img, x, y + h - 1, w, 1, c);
  fill_rect(img, x, y, 1, h, c);
  fill_rect(img, x + w - 1, y, 1, h, c);
}

void draw_line(Image& img, double x0, double y0, double x1, double y1, Rgb c, double width) {
  if (!std::isfinite(x0) || !std::isfinite(y0) || !std::isfinite(x1) || !std::isfinite(y1)) return;
  const double r = 0.5 * width;
  const double lim = 4.0 * (img.width + img.height);
  x0 = std::clamp(x0, -lim, lim), x1 = std::clamp(x1, -lim, lim);
  y0 = std::clamp(y0, -lim, lim), y1 = std::clamp(y1, -lim, lim);
  const int ix0 = std::max(0, static_cast<int>(std::floor(std::min(x0, x1) - r - 1)));
  const int ix1 = std::min(img.width - 1, static_cast<int>(std::ceil(std::max(x0, x1) + r + 1)));
  const int iy0 = std::max(0, static_cast<int>(std::floor(std::min(y0, y1) - r - 1)));
  const int iy1 = std::min(img.height - 1, static_cast<int>(std::ceil(std::max(y0, y1) + r + 1)));
  const double dx = x1 - x0, dy = y1 - y0;
  const double len2 = dx * dx + dy * dy;
  for (int y = iy0; y <= iy1; ++y)
    for (int x = ix0; x <= ix1; ++x) {
      const double px = x + 0.5, py = y + 0.5;
      double s = len2 > 0 ? ((px - x0) * dx + (py - y0) * dy) / len2 : 0.0;
      s = std::clamp(s, 0.0, 1.0);
      const double d = std::hypot(px - (x0 + s * dx), py - (y0 + s * dy));
      const double cover = std::clamp(r + 0.5 - d, 0.0, 1.0);
      if (cover > 0) blend_pixel(img, x, y, c, cover);
    }
}

void draw_text_vertical(Image& img, int x, int y, std::string_view text, Rgb c, int scale) {
  const auto [tw, th] = text_size(text, scale);
  if (tw <= 0 || th <= 0) return;
  // Draw horizontally into a coverage mask, then copy rotated.
  Image mask;
  mask.width = tw;
  mask.height = th;
  mask.rgb.assign(static_cast<std::size_t>(tw) * th * 3, 0);
  draw_text(mask, 0, 0, text, {255, 255, 255}, scale);
  for (int my = 0; my < th; ++my)
    for (int mx = 0; mx < tw; ++mx) {
      const int a = mask.rgb[(static_cast<std::size_t>(my) * tw + mx) * 3];
      if (a == 0) continue;
      // (mx, my) -> (my, tw - 1 - mx): counter-clockwise rotation.
      blend_pixel(img, x + my, y + tw - 1 - mx, c, a / 255.0);
    }
}

}  // namespace detail

std::array<int, 2> text_size(std::string_view text, int scale) {
  const auto [cw, ch] = cell_size(scale);
  int lines = text.empty() ? 0 : 1, cols = 0, longest = 0;
  for (const char c : text) {
    if (c == '\n') {
      ++lines;
      cols = 0;
    } else {
      longest = std::max(longest, ++cols);
    }
  }
  return {longest * cw, lines * ch};
}

void draw_text(Image& image, int x, int y, std::string_view text, std::array<std::uint8_t, 3> color,
               int scale) {
  scale = std::clamp(scale, 1, 16);
  const auto [cw, ch] = cell_size(scale);
  int cx = x, cy = y;
  for (const char c : text) {
    if (c == '\n') {
      cx = x;
      cy += ch;
      continue;
    }
    if (c != ' ' && cx < image.width && cy < image.height && cx + cw > 0 && cy + ch > 0)
      for (int gy = 0; gy < ch; ++gy)
        for (int gx = 0; gx < cw; ++gx) {
          const int a = coverage(c, gx, gy, scale);
          if (a > 0) detail::blend_pixel(image, cx + gx, cy + gy, color, a / 255.0);
        }
    cx += cw;
  }
}

namespace {
// Viridis (matplotlib's perceptual map, CC0): 16 samples at t = k/15, interpolated
// linearly in between.
constexpr float kViridis[16][3] = {
    {68.0f, 1.0f, 84.0f},    {72.0f, 26.0f, 108.0f},  {71.0f, 47.0f, 125.0f},
    {65.0f, 68.0f, 135.0f},  {57.0f, 86.0f, 140.0f},  {49.0f, 104.0f, 142.0f},
    {42.0f, 120.0f, 142.0f}, {36.0f, 136.0f, 142.0f}, {31.0f, 152.0f, 139.0f},
    {34.0f, 168.0f, 132.0f}, {53.0f, 183.0f, 121.0f}, {84.0f, 197.0f, 104.0f},
    {122.0f, 209.0f, 81.0f}, {165.0f, 219.0f, 54.0f}, {210.0f, 226.0f, 27.0f},
    {253.0f, 231.0f, 37.0f},
};
// Blue - white - red (ColorBrewer RdBu ends, reversed), 5 samples.
constexpr float kBwr[5][3] = {
    {33.0f, 102.0f, 172.0f},  {146.0f, 197.0f, 222.0f}, {247.0f, 247.0f, 247.0f},
    {244.0f, 165.0f, 130.0f}, {178.0f, 24.0f, 43.0f},
};

/// Linear interpolation in a table of last + 1 colours at t = k / last.
std::array<std::uint8_t, 3> sample(const float (*table)[3], std::size_t last, double t) {
  if (!std::isfinite(t)) t = 0;
  t = std::clamp(t, 0.0, 1.0) * static_cast<double>(last);
  const auto i = std::min(static_cast<std::size_t>(t), last - 1);
  const double f = t - static_cast<double>(i);
  std::array<std::uint8_t, 3> out{};
  for (int k = 0; k < 3; ++k)
    out[k] = static_cast<std::uint8_t>(std::lround((1 - f) * table[i][k] + f * table[i + 1][k]));
  return out;
}
}  // namespace

std::array<std::uint8_t, 3> viridis(double t) {
  return sample(kViridis, 15, t);
}

std::array<std::uint8_t, 3> blue_white_red(double t) {
  return sample(kBwr, 4, t);
}

}  // namespace tc::viz

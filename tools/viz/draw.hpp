// Internal to tools/viz: pixel helpers shared by the renderer and the plots.
#pragma once

#include <array>
#include <cstdint>

#include "render.hpp"

namespace tc::viz::detail {

using Rgb = std::array<std::uint8_t, 3>;

/// Sets one pixel; ignored outside the image.
void put_pixel(Image& img, int x, int y, Rgb c);
/// Blends `c` over pixel (x, y) with coverage alpha in [0, 1]; ignored outside.
void blend_pixel(Image& img, int x, int y, Rgb c, double alpha);
/// Filled axis-aligned rectangle, clipped.
void fill_rect(Image& img, int x, int y, int w, int h, Rgb c);
/// One-pixel outline of a rectangle, clipped.
void draw_rect_outline(Image& img, int x, int y, int w, int h, Rgb c);
/// Anti-aliased line of the given width (pixels) between pixel-space points; coordinates
/// are continuous (pixel (i, j) covers [i, i+1) x [j, j+1)). Non-finite points: nothing.
void draw_line(Image& img, double x0, double y0, double x1, double y1, Rgb c, double width);
/// Text rotated 90 degrees counter-clockwise (reads bottom to top), its top-left corner
/// (after rotation) at (x, y).
void draw_text_vertical(Image& img, int x, int y, std::string_view text, Rgb c, int scale = 1);

}  // namespace tc::viz::detail

// Internal to tools/viz: a line chart laid out once (ranges, "nice" ticks and their
// labels, the plot area, every series in pixels, the legend's place), for the two
// writers on top of it: plot_lines (a raster Image, plot.cpp) and plot_lines_svg (SVG,
// chart_svg.cpp). Sizes follow the built-in 8x13 bitmap font, which the SVG writer
// matches with a 13 px monospace font.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "draw.hpp"
#include "render.hpp"

namespace tc::viz::detail {

struct ChartTick {
  double at = 0.0;  ///< pixel column (x ticks) or row (y ticks), unrounded
  std::string label;
};

struct ChartLayout {
  int width = 0, height = 0;  ///< the picture
  int char_h = 0;             ///< text height, pixels
  /// The plot area [px0, px1] x [py0, py1]; `drawable` false when it would be too small
  /// (then only the background is drawn).
  int px0 = 0, px1 = 0, py0 = 0, py1 = 0;
  bool drawable = false;
  double x_lo = 0.0, x_hi = 1.0, y_lo = 0.0, y_hi = 1.0;  ///< value ranges on the axes
  std::vector<ChartTick> x_ticks, y_ticks;
  /// Per series, the value drawn at each x: y, or the running sum when stacked (a
  /// non-finite value counts as 0 in a stack; NaN breaks a line).
  std::vector<std::vector<double>> tops;
  /// The legend box (empty without series), in the plot corner where it hides the least
  /// data; one row of `legend_row` pixels per series.
  int legend_x = 0, legend_y = 0, legend_w = 0, legend_h = 0, legend_row = 0;

  [[nodiscard]] double to_px(double v) const {
    return px0 + (v - x_lo) / (x_hi - x_lo) * (px1 - px0);
  }
  [[nodiscard]] double to_py(double v) const {
    return py1 - (v - y_lo) / (y_hi - y_lo) * (py1 - py0);
  }
};

ChartLayout layout_chart(std::span<const double> x, std::span<const Series> series,
                         const PlotOptions& options);

/// Colours of the charts.
inline constexpr Rgb kChartAxis{40, 40, 40};
inline constexpr Rgb kChartGrid{225, 228, 232};
inline constexpr Rgb kChartText{25, 25, 25};
inline constexpr Rgb kChartLegendOutline{180, 180, 180};
/// A stacked band: its series' colour, lightened.
Rgb band_color(Rgb c);

}  // namespace tc::viz::detail

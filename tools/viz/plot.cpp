// Line plots and stacked-area plots as a raster Image: the layout of chart.hpp drawn with
// the pixel helpers (axes, ticks, labels, bands, lines, legend).
#include <algorithm>
#include <cmath>

#include "chart.hpp"
#include "draw.hpp"
#include "render.hpp"

namespace tc::viz {

Image plot_lines(std::span<const double> x, std::span<const Series> series,
                 const PlotOptions& options) {
  using namespace detail;
  const ChartLayout c = layout_chart(x, series, options);
  Image img;
  img.width = c.width;
  img.height = c.height;
  img.rgb.assign(static_cast<std::size_t>(img.width) * img.height * 3, 255);
  if (!c.drawable) return img;
  const std::size_t n = x.size();
  const int ch = c.char_h;
  const int px0 = c.px0, px1 = c.px1, py0 = c.py0, py1 = c.py1;

  // Grid and ticks.
  for (const ChartTick& t : c.x_ticks) {
    const int p = static_cast<int>(std::lround(t.at));
    fill_rect(img, p, py0, 1, py1 - py0, kChartGrid);
    fill_rect(img, p, py1, 1, 5, kChartAxis);
    draw_text(img, p - text_size(t.label)[0] / 2, py1 + 8, t.label, kChartText);
  }
  for (const ChartTick& t : c.y_ticks) {
    const int p = static_cast<int>(std::lround(t.at));
    fill_rect(img, px0, p, px1 - px0, 1, kChartGrid);
    fill_rect(img, px0 - 5, p, 5, 1, kChartAxis);
    draw_text(img, px0 - 8 - text_size(t.label)[0], p - ch / 2, t.label, kChartText);
  }

  // Stacked bands: fill each pixel column between the band's lower and upper curves.
  if (options.stacked && n >= 2) {
    for (int col = px0; col < px1; ++col) {
      const double xv = c.x_lo + (col + 0.5 - px0) / (px1 - px0) * (c.x_hi - c.x_lo);
      // Segment i with x[i] <= xv <= x[i+1] (x assumed increasing; others skipped).
      for (std::size_t i = 0; i + 1 < n; ++i) {
        if (!(x[i] <= xv && xv <= x[i + 1]) || !(x[i + 1] > x[i])) continue;
        const double f = (xv - x[i]) / (x[i + 1] - x[i]);
        double below = 0;
        for (std::size_t s = 0; s < series.size(); ++s) {
          const double up = c.tops[s][i] + f * (c.tops[s][i + 1] - c.tops[s][i]);
          const double ya = c.to_py(up), yb = c.to_py(below);
          const Rgb fill = band_color(series[s].color);
          for (int r = static_cast<int>(std::ceil(ya - 0.5)); r < static_cast<int>(yb); ++r)
            if (r >= py0 && r < py1) put_pixel(img, col, r, fill);
          below = up;
        }
        break;
      }
    }
  }

  // Lines (top of each band when stacked); NaN breaks a line.
  for (std::size_t s = 0; s < series.size(); ++s)
    for (std::size_t i = 0; i + 1 < n; ++i) {
      const double a = c.tops[s][i], b = c.tops[s][i + 1];
      if (!std::isfinite(a) || !std::isfinite(b) || !std::isfinite(x[i]) ||
          !std::isfinite(x[i + 1]))
        continue;
      draw_line(img, c.to_px(x[i]), c.to_py(a), c.to_px(x[i + 1]), c.to_py(b), series[s].color,
                2.0);
    }
  // A single point of a series is drawn as a dot.
  if (n == 1)
    for (std::size_t s = 0; s < series.size(); ++s)
      if (std::isfinite(c.tops[s][0]) && std::isfinite(x[0]))
        draw_line(img, c.to_px(x[0]), c.to_py(c.tops[s][0]), c.to_px(x[0]), c.to_py(c.tops[s][0]),
                  series[s].color, 6.0);

  // Axes.
  fill_rect(img, px0, py0, 1, py1 - py0 + 1, kChartAxis);
  fill_rect(img, px0, py1, px1 - px0 + 1, 1, kChartAxis);

  // Labels and title.
  if (!options.title.empty()) {
    const int tw = text_size(options.title, 2)[0];
    draw_text(img, std::max(4, (px0 + px1) / 2 - tw / 2), 8, options.title, kChartText, 2);
  }
  if (!options.x_label.empty()) {
    const int tw = text_size(options.x_label)[0];
    draw_text(img, (px0 + px1) / 2 - tw / 2, img.height - ch - 6, options.x_label, kChartText);
  }
  if (!options.y_label.empty()) {
    const int tw = text_size(options.y_label)[0];
    draw_text_vertical(img, 6, (py0 + py1) / 2 - tw / 2, options.y_label, kChartText);
  }

  // Legend; stacked: listed top band first.
  if (!series.empty()) {
    const int bx = c.legend_x, by = c.legend_y;
    fill_rect(img, bx, by, c.legend_w, c.legend_h, {255, 255, 255});
    draw_rect_outline(img, bx, by, c.legend_w, c.legend_h, kChartLegendOutline);
    for (std::size_t k = 0; k < series.size(); ++k) {
      const std::size_t s = options.stacked ? series.size() - 1 - k : k;
      const int ry = by + 5 + static_cast<int>(k) * c.legend_row;
      if (options.stacked) fill_rect(img, bx + 8, ry + 3, 20, ch - 6, band_color(series[s].color));
      draw_line(img, bx + 8, ry + ch / 2.0, bx + 28, ry + ch / 2.0, series[s].color, 2.0);
      draw_text(img, bx + 34, ry, series[s].name, kChartText);
    }
  }
  return img;
}

}  // namespace tc::viz

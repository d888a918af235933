// Line plots and stacked-area plots: axes, "nice" ticks, labels, legend.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "draw.hpp"
#include "render.hpp"

namespace tc::viz {
namespace {

using detail::Rgb;

const Rgb kAxis{40, 40, 40};
const Rgb kGrid{225, 228, 232};
const Rgb kText{25, 25, 25};
const Rgb kWhite{255, 255, 255};

/// A step of 1, 2 or 5 times a power of ten giving about `target` intervals over `span`.
double nice_step(double span, int target) {
  if (!(span > 0) || !std::isfinite(span)) return 1.0;
  const double raw = span / std::max(1, target);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / mag;
  const double nice = f < 1.5 ? 1.0 : f < 3.5 ? 2.0 : f < 7.5 ? 5.0 : 10.0;
  return nice * mag;
}

/// Tick label: as few digits as the step needs.
std::string tick_label(double v, double step) {
  if (std::abs(v) < step * 1e-9) v = 0;
  char buf[32];
  const double a = std::max(std::abs(v), step);
  if (a >= 1e6 || a < 1e-4) {
    std::snprintf(buf, sizeof buf, "%.3g", v);
  } else {
    const int decimals = std::clamp(static_cast<int>(-std::floor(std::log10(step) + 1e-9)), 0, 8);
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  }
  return buf;
}

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    if (!std::isfinite(v)) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  /// Makes the range usable (non-empty, finite) and rounds it out to whole steps.
  double finish(int target, bool from_zero) {
    if (!(hi >= lo)) lo = 0, hi = 1;
    if (from_zero) lo = std::min(lo, 0.0);
    if (hi == lo) {
      const double pad = lo == 0 ? 1.0 : 0.1 * std::abs(lo);
      lo -= pad;
      hi += pad;
      if (from_zero) lo = std::min(lo + pad, 0.0);
    }
    const double step = nice_step(hi - lo, target);
    lo = std::floor(lo / step + 1e-9) * step;
    hi = std::ceil(hi / step - 1e-9) * step;
    return step;
  }
};

Rgb lighten(Rgb c, double f) {
  return {static_cast<std::uint8_t>(std::lround(c[0] + f * (255 - c[0]))),
          static_cast<std::uint8_t>(std::lround(c[1] + f * (255 - c[1]))),
          static_cast<std::uint8_t>(std::lround(c[2] + f * (255 - c[2])))};
}

}  // namespace

Image plot_lines(std::span<const double> x, std::span<const Series> series,
                 const PlotOptions& options) {
  Image img;
  img.width = std::clamp(options.width, 200, 8192);
  img.height = std::clamp(options.height, 150, 8192);
  img.rgb.assign(static_cast<std::size_t>(img.width) * img.height * 3, 255);
  const std::size_t n = x.size();

  // Stacked: cumulative sums in series order (non-finite values count as 0).
  std::vector<std::vector<double>> top(series.size(), std::vector<double>(n, 0.0));
  for (std::size_t s = 0; s < series.size(); ++s)
    for (std::size_t i = 0; i < n; ++i) {
      const double v =
          i < series[s].y.size() ? series[s].y[i] : std::numeric_limits<double>::quiet_NaN();
      if (options.stacked) {
        const double below = s > 0 ? top[s - 1][i] : 0.0;
        top[s][i] = below + (std::isfinite(v) ? v : 0.0);
      } else {
        top[s][i] = v;
      }
    }

  Range xr, yr;
  for (std::size_t i = 0; i < n; ++i) xr.add(x[i]);
  for (const auto& t : top)
    for (const double v : t) yr.add(v);
  const double xstep = xr.finish(8, false);
  const double ystep = yr.finish(6, options.stacked);

  // Layout: room for the y tick labels and the y label on the left, the title on top,
  // the x tick labels and the x label below.
  const auto [cw, ch] = text_size("0");
  int max_label = 0;
  for (double v = yr.lo; v <= yr.hi + 0.5 * ystep; v += ystep)
    max_label = std::max(max_label, text_size(tick_label(v, ystep))[0]);
  const int left = max_label + 14 + (options.y_label.empty() ? 0 : ch + 10);
  const int top_margin = options.title.empty() ? 16 : text_size(options.title, 2)[1] + 18;
  const int bottom = 2 * ch + 18 + (options.x_label.empty() ? 0 : 4);
  const int right = 24;
  const int px0 = left, px1 = img.width - right;
  const int py0 = top_margin, py1 = img.height - bottom;
  if (px1 - px0 < 20 || py1 - py0 < 20) return img;
  const auto to_px = [&](double v) { return px0 + (v - xr.lo) / (xr.hi - xr.lo) * (px1 - px0); };
  const auto to_py = [&](double v) { return py1 - (v - yr.lo) / (yr.hi - yr.lo) * (py1 - py0); };

  // Grid and ticks.
  for (double v = xr.lo; v <= xr.hi + 0.5 * xstep; v += xstep) {
    const int p = static_cast<int>(std::lround(to_px(v)));
    detail::fill_rect(img, p, py0, 1, py1 - py0, kGrid);
    detail::fill_rect(img, p, py1, 1, 5, kAxis);
    const std::string s = tick_label(v, xstep);
    draw_text(img, p - text_size(s)[0] / 2, py1 + 8, s, kText);
  }
  for (double v = yr.lo; v <= yr.hi + 0.5 * ystep; v += ystep) {
    const int p = static_cast<int>(std::lround(to_py(v)));
    detail::fill_rect(img, px0, p, px1 - px0, 1, kGrid);
    detail::fill_rect(img, px0 - 5, p, 5, 1, kAxis);
    const std::string s = tick_label(v, ystep);
    draw_text(img, px0 - 8 - text_size(s)[0], p - ch / 2, s, kText);
  }

  // Stacked bands: fill each pixel column between the band's lower and upper curves.
  if (options.stacked && n >= 2) {
    for (int c = px0; c < px1; ++c) {
      const double xv = xr.lo + (c + 0.5 - px0) / (px1 - px0) * (xr.hi - xr.lo);
      // Segment i with x[i] <= xv <= x[i+1] (x assumed increasing; others skipped).
      for (std::size_t i = 0; i + 1 < n; ++i) {
        if (!(x[i] <= xv && xv <= x[i + 1]) || !(x[i + 1] > x[i])) continue;
        const double f = (xv - x[i]) / (x[i + 1] - x[i]);
        double below = 0;
        for (std::size_t s = 0; s < series.size(); ++s) {
          const double up = top[s][i] + f * (top[s][i + 1] - top[s][i]);
          const double ya = to_py(up), yb = to_py(below);
          const Rgb fill = lighten(series[s].color, 0.35);
          for (int r = static_cast<int>(std::ceil(ya - 0.5)); r < static_cast<int>(yb); ++r)
            if (r >= py0 && r < py1) detail::put_pixel(img, c, r, fill);
          below = up;
        }
        break;
      }
    }
  }

  // Lines (top of each band when stacked); NaN breaks a line.
  for (std::size_t s = 0; s < series.size(); ++s)
    for (std::size_t i = 0; i + 1 < n; ++i) {
      const double a = top[s][i], b = top[s][i + 1];
      if (!std::isfinite(a) || !std::isfinite(b) || !std::isfinite(x[i]) ||
          !std::isfinite(x[i + 1]))
        continue;
      detail::draw_line(img, to_px(x[i]), to_py(a), to_px(x[i + 1]), to_py(b), series[s].color,
                        2.0);
    }
  // A single point of a series is drawn as a dot.
  if (n == 1)
    for (std::size_t s = 0; s < series.size(); ++s)
      if (std::isfinite(top[s][0]) && std::isfinite(x[0]))
        detail::draw_line(img, to_px(x[0]), to_py(top[s][0]), to_px(x[0]), to_py(top[s][0]),
                          series[s].color, 6.0);

  // Axes.
  detail::fill_rect(img, px0, py0, 1, py1 - py0 + 1, kAxis);
  detail::fill_rect(img, px0, py1, px1 - px0 + 1, 1, kAxis);

  // Labels and title.
  if (!options.title.empty()) {
    const int tw = text_size(options.title, 2)[0];
    draw_text(img, std::max(4, (px0 + px1) / 2 - tw / 2), 8, options.title, kText, 2);
  }
  if (!options.x_label.empty()) {
    const int tw = text_size(options.x_label)[0];
    draw_text(img, (px0 + px1) / 2 - tw / 2, img.height - ch - 6, options.x_label, kText);
  }
  if (!options.y_label.empty()) {
    const int tw = text_size(options.y_label)[0];
    detail::draw_text_vertical(img, 6, (py0 + py1) / 2 - tw / 2, options.y_label, kText);
  }

  // Legend in the plot corner where it hides the fewest data pixels (ties: top-left,
  // top-right, bottom-left, bottom-right); stacked: listed top band first.
  if (!series.empty()) {
    int lw = 0;
    for (const Series& s : series) lw = std::max(lw, text_size(s.name)[0]);
    const int row = ch + 4;
    const int box_w = lw + 40, box_h = static_cast<int>(series.size()) * row + 10;
    int bx = px0 + 12, by = py0 + 10;
    long best = -1;
    for (const auto& [cx, cy] : {std::pair{px0 + 12, py0 + 10},
                                 {px1 - 12 - box_w, py0 + 10},
                                 {px0 + 12, py1 - 10 - box_h},
                                 {px1 - 12 - box_w, py1 - 10 - box_h}}) {
      long hidden = 0;
      for (int yy = std::max(cy, 0); yy < std::min(cy + box_h, img.height); ++yy)
        for (int xx = std::max(cx, 0); xx < std::min(cx + box_w, img.width); ++xx) {
          const Rgb p = img.pixel(xx, yy);
          hidden += p != kWhite && p != kGrid;
        }
      if (best < 0 || hidden < best) best = hidden, bx = cx, by = cy;
    }
    detail::fill_rect(img, bx, by, box_w, box_h, kWhite);
    detail::draw_rect_outline(img, bx, by, box_w, box_h, {180, 180, 180});
    for (std::size_t k = 0; k < series.size(); ++k) {
      const std::size_t s = options.stacked ? series.size() - 1 - k : k;
      const int ry = by + 5 + static_cast<int>(k) * row;
      if (options.stacked)
        detail::fill_rect(img, bx + 8, ry + 3, 20, ch - 6, lighten(series[s].color, 0.35));
      detail::draw_line(img, bx + 8, ry + ch / 2.0, bx + 28, ry + ch / 2.0, series[s].color, 2.0);
      draw_text(img, bx + 34, ry, series[s].name, kText);
    }
  }
  (void)cw;
  return img;
}

}  // namespace tc::viz

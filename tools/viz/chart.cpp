// The line chart's layout (chart.hpp), computed once for the raster and SVG writers.
#include "chart.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

namespace tc::viz::detail {
namespace {

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

/// The ticks from lo to hi every `step`, placed by `at`.
template <class At>
std::vector<ChartTick> ticks(double lo, double hi, double step, At&& at) {
  std::vector<ChartTick> out;
  for (double v = lo; v <= hi + 0.5 * step; v += step) out.push_back({at(v), tick_label(v, step)});
  return out;
}

/// How much data a legend box at (bx, by) would hide: per pixel column of the box, the
/// rows of it that a series' line crosses, or (stacked) that the bands fill.
long hidden_by(const ChartLayout& c, std::span<const double> x, bool stacked, int bx, int by) {
  const std::size_t n = x.size();
  long hidden = 0;
  for (int col = bx; col < bx + c.legend_w; ++col) {
    const double xv = c.x_lo + (col + 0.5 - c.px0) / (c.px1 - c.px0) * (c.x_hi - c.x_lo);
    for (std::size_t i = 0; i + 1 < n; ++i) {
      if (!(x[i] <= xv && xv <= x[i + 1]) || !(x[i + 1] > x[i])) continue;
      const double f = (xv - x[i]) / (x[i + 1] - x[i]);
      double lowest = c.py1;  // the bottom of the stack
      for (const auto& t : c.tops) {
        if (!std::isfinite(t[i]) || !std::isfinite(t[i + 1])) continue;
        const double row = c.to_py(t[i] + f * (t[i + 1] - t[i]));
        if (stacked) {
          lowest = std::min(lowest, row);
        } else if (row >= by && row < by + c.legend_h) {
          hidden += 3;  // a 2-pixel line, anti-aliased
        }
      }
      if (stacked)
        hidden += std::max(0L, static_cast<long>(by + c.legend_h - std::max<double>(lowest, by)));
      break;
    }
  }
  return hidden;
}

}  // namespace

Rgb band_color(Rgb c) {
  constexpr double f = 0.35;  // how far towards white
  return {static_cast<std::uint8_t>(std::lround(c[0] + f * (255 - c[0]))),
          static_cast<std::uint8_t>(std::lround(c[1] + f * (255 - c[1]))),
          static_cast<std::uint8_t>(std::lround(c[2] + f * (255 - c[2])))};
}

ChartLayout layout_chart(std::span<const double> x, std::span<const Series> series,
                         const PlotOptions& options) {
  ChartLayout c;
  c.width = std::clamp(options.width, 200, 8192);
  c.height = std::clamp(options.height, 150, 8192);
  const std::size_t n = x.size();

  // Stacked: cumulative sums in series order (non-finite values count as 0).
  c.tops.assign(series.size(), std::vector<double>(n, 0.0));
  for (std::size_t s = 0; s < series.size(); ++s)
    for (std::size_t i = 0; i < n; ++i) {
      const double v =
          i < series[s].y.size() ? series[s].y[i] : std::numeric_limits<double>::quiet_NaN();
      if (options.stacked) {
        const double below = s > 0 ? c.tops[s - 1][i] : 0.0;
        c.tops[s][i] = below + (std::isfinite(v) ? v : 0.0);
      } else {
        c.tops[s][i] = v;
      }
    }

  Range xr, yr;
  for (std::size_t i = 0; i < n; ++i) xr.add(x[i]);
  for (const auto& t : c.tops)
    for (const double v : t) yr.add(v);
  const double xstep = xr.finish(8, false);
  const double ystep = yr.finish(6, options.stacked);
  c.x_lo = xr.lo, c.x_hi = xr.hi, c.y_lo = yr.lo, c.y_hi = yr.hi;

  // Room for the y tick labels and the y label on the left, the title on top, the x
  // tick labels and the x label below.
  c.char_h = text_size("0")[1];
  const int ch = c.char_h;
  int max_label = 0;
  for (double v = yr.lo; v <= yr.hi + 0.5 * ystep; v += ystep)
    max_label = std::max(max_label, text_size(tick_label(v, ystep))[0]);
  const int left = max_label + 14 + (options.y_label.empty() ? 0 : ch + 10);
  const int top_margin = options.title.empty() ? 16 : text_size(options.title, 2)[1] + 18;
  const int bottom = 2 * ch + 18 + (options.x_label.empty() ? 0 : 4);
  const int right = 24;
  c.px0 = left, c.px1 = c.width - right;
  c.py0 = top_margin, c.py1 = c.height - bottom;
  c.drawable = c.px1 - c.px0 >= 20 && c.py1 - c.py0 >= 20;
  if (!c.drawable) return c;
  c.x_ticks = ticks(xr.lo, xr.hi, xstep, [&](double v) { return c.to_px(v); });
  c.y_ticks = ticks(yr.lo, yr.hi, ystep, [&](double v) { return c.to_py(v); });

  // The legend, in the corner hiding the least data (ties: top-left, top-right,
  // bottom-left, bottom-right).
  if (!series.empty()) {
    int lw = 0;
    for (const Series& s : series) lw = std::max(lw, text_size(s.name)[0]);
    c.legend_row = ch + 4;
    c.legend_w = lw + 40;
    c.legend_h = static_cast<int>(series.size()) * c.legend_row + 10;
    long best = -1;
    for (const auto& [bx, by] : {std::pair{c.px0 + 12, c.py0 + 10},
                                 {c.px1 - 12 - c.legend_w, c.py0 + 10},
                                 {c.px0 + 12, c.py1 - 10 - c.legend_h},
                                 {c.px1 - 12 - c.legend_w, c.py1 - 10 - c.legend_h}}) {
      const long hidden = hidden_by(c, x, options.stacked, bx, by);
      if (best < 0 || hidden < best) best = hidden, c.legend_x = bx, c.legend_y = by;
    }
  }
  return c;
}

}  // namespace tc::viz::detail

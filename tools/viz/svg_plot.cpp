#include "svg_plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "svg.hpp"

namespace tc::viz {
namespace {

using detail::svg_num;

constexpr double kWidth = 960, kHeight = 600;
constexpr double kLeft = 90, kRight = 690, kTop = 56, kBottom = 520;  // plot area

const char* const kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd",
                               "#8c564b", "#e377c2", "#17becf", "#7f7f7f", "#bcbd22"};

std::string color_of(int i) {
  return kColors[static_cast<std::size_t>(i) % std::size(kColors)];
}

// A decade label: 1e-3 -> "0.001", 1e4 -> "10000", beyond that 1e+06.
std::string decade_label(int e) {
  char buf[32];
  if (e >= -4 && e <= 4) {
    std::snprintf(buf, sizeof buf, "%.*f", e < 0 ? -e : 0, std::pow(10.0, e));
  } else {
    std::snprintf(buf, sizeof buf, "1e%+d", e);
  }
  return buf;
}

// Marker of a given shape centred at (x, y).
std::string marker(int shape, double x, double y, const std::string& color, bool filled) {
  const double r = 6.5;
  const std::string style = "fill=\"" + (filled ? color : std::string("white")) + "\" stroke=\"" +
                            color + "\" stroke-width=\"2\"";
  std::ostringstream s;
  switch (shape % 5) {
    case 0:
      s << "<circle cx=\"" << svg_num(x) << "\" cy=\"" << svg_num(y) << "\" r=\"" << svg_num(r)
        << "\" " << style << "/>";
      break;
    case 1:
      s << "<rect x=\"" << svg_num(x - r) << "\" y=\"" << svg_num(y - r) << "\" width=\""
        << svg_num(2 * r) << "\" height=\"" << svg_num(2 * r) << "\" " << style << "/>";
      break;
    case 2:
      s << "<polygon points=\"" << svg_num(x) << "," << svg_num(y - 1.2 * r) << " "
        << svg_num(x + 1.1 * r) << "," << svg_num(y + 0.8 * r) << " " << svg_num(x - 1.1 * r) << ","
        << svg_num(y + 0.8 * r) << "\" " << style << "/>";
      break;
    case 3:
      s << "<polygon points=\"" << svg_num(x) << "," << svg_num(y - 1.3 * r) << " "
        << svg_num(x + 1.3 * r) << "," << svg_num(y) << " " << svg_num(x) << ","
        << svg_num(y + 1.3 * r) << " " << svg_num(x - 1.3 * r) << "," << svg_num(y) << "\" "
        << style << "/>";
      break;
    default:
      s << "<polygon points=\"" << svg_num(x) << "," << svg_num(y + 1.2 * r) << " "
        << svg_num(x + 1.1 * r) << "," << svg_num(y - 0.8 * r) << " " << svg_num(x - 1.1 * r) << ","
        << svg_num(y - 0.8 * r) << "\" " << style << "/>";
  }
  return s.str();
}

struct Axis {
  int lo = 0, hi = 1;  // decades
  double screen_lo = 0, screen_hi = 1;
  [[nodiscard]] double map(double v) const {
    const double t = (std::log10(v) - lo) / (hi - lo);
    return screen_lo + t * (screen_hi - screen_lo);
  }
};

Axis make_axis(const std::vector<double>& values, double screen_lo, double screen_hi) {
  double mn = 1e300, mx = -1e300;
  for (const double v : values)
    if (v > 0.0 && std::isfinite(v)) {
      mn = std::min(mn, v);
      mx = std::max(mx, v);
    }
  Axis a;
  if (mn > mx) {
    mn = 1.0;
    mx = 10.0;
  }
  a.lo = static_cast<int>(std::floor(std::log10(mn)));
  a.hi = static_cast<int>(std::ceil(std::log10(mx)));
  if (a.hi <= a.lo) a.hi = a.lo + 1;
  a.screen_lo = screen_lo;
  a.screen_hi = screen_hi;
  return a;
}

}  // namespace

std::string plot_loglog_svg(const LogLogPlot& plot) {
  std::vector<double> xs, ys;
  for (const PlotPoint& p : plot.points) {
    xs.push_back(p.x);
    ys.push_back(p.y);
  }
  const Axis ax = make_axis(xs, kLeft, kRight);
  const Axis ay = make_axis(ys, kBottom, kTop);
  detail::SvgDocument svg(kWidth, kHeight, "DejaVu Sans, Arial, sans-serif");
  svg.text((kLeft + kRight) / 2, 30, plot.title, 18, "middle");

  // Grid: decades (solid) and 2, 5 (dotted), with labels at decades.
  const auto grid = [&](const Axis& a, bool vertical) {
    for (int e = a.lo; e <= a.hi; ++e) {
      for (const int m : {1, 2, 5}) {
        const double v = m * std::pow(10.0, e);
        if (std::log10(v) > a.hi + 1e-9) break;
        const double at = a.map(v);
        const char* stroke = m == 1 ? "#bbbbbb" : "#e4e4e4";
        const char* dash = m == 1 ? "" : "stroke-dasharray=\"3,3\"";
        if (vertical) {
          svg.line(at, kTop, at, kBottom, stroke, 1, dash);
          if (m == 1) svg.text(at, kBottom + 20, decade_label(e), 13, "middle");
        } else {
          svg.line(kLeft, at, kRight, at, stroke, 1, dash);
          if (m == 1) svg.text(kLeft - 8, at + 4, decade_label(e), 13, "end");
        }
      }
    }
  };
  grid(ax, true);
  grid(ay, false);
  svg.rect(kLeft, kTop, kRight - kLeft, kBottom - kTop, "none", "black");
  svg.text((kLeft + kRight) / 2, kBottom + 48, plot.x_label, 15, "middle");
  svg.vertical_text(24, (kTop + kBottom) / 2, plot.y_label, 15);

  for (const auto& [a, b] : plot.links) {
    const PlotPoint& p = plot.points[a];
    const PlotPoint& q = plot.points[b];
    svg.line(ax.map(p.x), ay.map(p.y), ax.map(q.x), ay.map(q.y), color_of(p.color), 1.2,
             "opacity=\"0.6\"");
  }
  for (const PlotPoint& p : plot.points)
    svg.raw(marker(p.shape, ax.map(p.x), ay.map(p.y), color_of(p.color), p.filled));

  // Legend.
  double y = kTop + 6;
  const double lx = kRight + 24;
  svg.text(lx, y + 4, "method", 14, "start", "font-weight=\"bold\"");
  y += 22;
  for (std::size_t i = 0; i < plot.color_names.size(); ++i, y += 22) {
    svg.raw(marker(0, lx + 8, y, color_of(static_cast<int>(i)), true));
    svg.text(lx + 24, y + 5, plot.color_names[i], 14, "start");
  }
  y += 10;
  svg.text(lx, y + 4, "mesh", 14, "start", "font-weight=\"bold\"");
  y += 22;
  for (std::size_t i = 0; i < plot.shape_names.size(); ++i, y += 22) {
    svg.raw(marker(static_cast<int>(i), lx + 8, y, "#444444", true));
    svg.text(lx + 24, y + 5, plot.shape_names[i], 14, "start");
  }
  y += 10;
  for (const std::string& note : plot.notes) {
    svg.text(lx, y + 5, note, 13, "start");
    y += 19;
  }
  return svg.finish();
}

}  // namespace tc::viz

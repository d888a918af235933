#include "svg_plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "core/common/xml.hpp"

namespace tc::cli {
namespace {

constexpr double kWidth = 960, kHeight = 600;
constexpr double kLeft = 90, kRight = 690, kTop = 56, kBottom = 520;  // plot area

const char* const kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd",
                               "#8c564b", "#e377c2", "#17becf", "#7f7f7f", "#bcbd22"};

std::string color_of(int i) {
  return kColors[static_cast<std::size_t>(i) % std::size(kColors)];
}

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
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
      s << "<circle cx=\"" << num(x) << "\" cy=\"" << num(y) << "\" r=\"" << num(r) << "\" "
        << style << "/>";
      break;
    case 1:
      s << "<rect x=\"" << num(x - r) << "\" y=\"" << num(y - r) << "\" width=\"" << num(2 * r)
        << "\" height=\"" << num(2 * r) << "\" " << style << "/>";
      break;
    case 2:
      s << "<polygon points=\"" << num(x) << "," << num(y - 1.2 * r) << " " << num(x + 1.1 * r)
        << "," << num(y + 0.8 * r) << " " << num(x - 1.1 * r) << "," << num(y + 0.8 * r) << "\" "
        << style << "/>";
      break;
    case 3:
      s << "<polygon points=\"" << num(x) << "," << num(y - 1.3 * r) << " " << num(x + 1.3 * r)
        << "," << num(y) << " " << num(x) << "," << num(y + 1.3 * r) << " " << num(x - 1.3 * r)
        << "," << num(y) << "\" " << style << "/>";
      break;
    default:
      s << "<polygon points=\"" << num(x) << "," << num(y + 1.2 * r) << " " << num(x + 1.1 * r)
        << "," << num(y - 0.8 * r) << " " << num(x - 1.1 * r) << "," << num(y - 0.8 * r) << "\" "
        << style << "/>";
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

std::string render_svg(const LogLogPlot& plot) {
  std::vector<double> xs, ys;
  for (const PlotPoint& p : plot.points) {
    xs.push_back(p.x);
    ys.push_back(p.y);
  }
  const Axis ax = make_axis(xs, kLeft, kRight);
  const Axis ay = make_axis(ys, kBottom, kTop);
  std::ostringstream s;
  s << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << kWidth << "\" height=\"" << kHeight
    << "\" viewBox=\"0 0 " << kWidth << " " << kHeight
    << "\" font-family=\"DejaVu Sans, Arial, sans-serif\">\n";
  s << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  s << "<text x=\"" << num((kLeft + kRight) / 2) << "\" y=\"30\" font-size=\"18\" "
    << "text-anchor=\"middle\">" << tc::xml_escape(plot.title) << "</text>\n";

  // Grid: decades (solid) and 2, 5 (dotted), with labels at decades.
  for (int e = ax.lo; e <= ax.hi; ++e) {
    for (const int m : {1, 2, 5}) {
      const double v = m * std::pow(10.0, e);
      if (std::log10(v) > ax.hi + 1e-9) break;
      const double x = ax.map(v);
      s << "<line x1=\"" << num(x) << "\" y1=\"" << kTop << "\" x2=\"" << num(x) << "\" y2=\""
        << kBottom << "\" stroke=\"" << (m == 1 ? "#bbbbbb" : "#e4e4e4") << "\""
        << (m == 1 ? "" : " stroke-dasharray=\"3,3\"") << "/>\n";
      if (m == 1)
        s << "<text x=\"" << num(x) << "\" y=\"" << kBottom + 20 << "\" font-size=\"13\" "
          << "text-anchor=\"middle\">" << decade_label(e) << "</text>\n";
    }
  }
  for (int e = ay.lo; e <= ay.hi; ++e) {
    for (const int m : {1, 2, 5}) {
      const double v = m * std::pow(10.0, e);
      if (std::log10(v) > ay.hi + 1e-9) break;
      const double y = ay.map(v);
      s << "<line x1=\"" << kLeft << "\" y1=\"" << num(y) << "\" x2=\"" << kRight << "\" y2=\""
        << num(y) << "\" stroke=\"" << (m == 1 ? "#bbbbbb" : "#e4e4e4") << "\""
        << (m == 1 ? "" : " stroke-dasharray=\"3,3\"") << "/>\n";
      if (m == 1)
        s << "<text x=\"" << kLeft - 8 << "\" y=\"" << num(y + 4) << "\" font-size=\"13\" "
          << "text-anchor=\"end\">" << decade_label(e) << "</text>\n";
    }
  }
  s << "<rect x=\"" << kLeft << "\" y=\"" << kTop << "\" width=\"" << kRight - kLeft
    << "\" height=\"" << kBottom - kTop << "\" fill=\"none\" stroke=\"black\"/>\n";
  s << "<text x=\"" << num((kLeft + kRight) / 2) << "\" y=\"" << kBottom + 48
    << "\" font-size=\"15\" text-anchor=\"middle\">" << tc::xml_escape(plot.x_label) << "</text>\n";
  s << "<text transform=\"translate(24," << num((kTop + kBottom) / 2)
    << ") rotate(-90)\" font-size=\"15\" text-anchor=\"middle\">" << tc::xml_escape(plot.y_label)
    << "</text>\n";

  for (const auto& [a, b] : plot.links) {
    const PlotPoint& p = plot.points[a];
    const PlotPoint& q = plot.points[b];
    s << "<line x1=\"" << num(ax.map(p.x)) << "\" y1=\"" << num(ay.map(p.y)) << "\" x2=\""
      << num(ax.map(q.x)) << "\" y2=\"" << num(ay.map(q.y)) << "\" stroke=\"" << color_of(p.color)
      << "\" stroke-width=\"1.2\" opacity=\"0.6\"/>\n";
  }
  for (const PlotPoint& p : plot.points)
    s << marker(p.shape, ax.map(p.x), ay.map(p.y), color_of(p.color), p.filled) << "\n";

  // Legend.
  double y = kTop + 6;
  const double lx = kRight + 24;
  s << "<text x=\"" << lx << "\" y=\"" << num(y + 4) << "\" font-size=\"14\" "
    << "font-weight=\"bold\">method</text>\n";
  y += 22;
  for (std::size_t i = 0; i < plot.color_names.size(); ++i, y += 22) {
    s << marker(0, lx + 8, y, color_of(static_cast<int>(i)), true) << "\n";
    s << "<text x=\"" << lx + 24 << "\" y=\"" << num(y + 5) << "\" font-size=\"14\">"
      << tc::xml_escape(plot.color_names[i]) << "</text>\n";
  }
  y += 10;
  s << "<text x=\"" << lx << "\" y=\"" << num(y + 4) << "\" font-size=\"14\" "
    << "font-weight=\"bold\">mesh</text>\n";
  y += 22;
  for (std::size_t i = 0; i < plot.shape_names.size(); ++i, y += 22) {
    s << marker(static_cast<int>(i), lx + 8, y, "#444444", true) << "\n";
    s << "<text x=\"" << lx + 24 << "\" y=\"" << num(y + 5) << "\" font-size=\"14\">"
      << tc::xml_escape(plot.shape_names[i]) << "</text>\n";
  }
  y += 10;
  for (const std::string& note : plot.notes) {
    s << "<text x=\"" << lx << "\" y=\"" << num(y + 5) << "\" font-size=\"13\">"
      << tc::xml_escape(note) << "</text>\n";
    y += 19;
  }
  s << "</svg>\n";
  return s.str();
}

}  // namespace tc::cli

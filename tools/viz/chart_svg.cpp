// Line plots and stacked-area plots as SVG: the layout of chart.hpp written as SVG
// elements, the same places and colours as the raster writer (plot.cpp).
#include <cmath>
#include <cstdio>

#include "chart.hpp"
#include "core/common/xml.hpp"
#include "svg.hpp"

namespace tc::viz {
namespace detail {

std::string svg_color(Rgb c) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", c[0], c[1], c[2]);
  return buf;
}

std::string svg_num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
}

SvgDocument::SvgDocument(double width, double height, std::string_view font) {
  out_ << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height
       << "\" viewBox=\"0 0 " << width << " " << height << "\" font-family=\"" << font
       << "\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
}

void SvgDocument::text(double x, double y, std::string_view text, double size,
                       std::string_view anchor, std::string_view attributes) {
  out_ << "<text x=\"" << svg_num(x) << "\" y=\"" << svg_num(y) << "\" font-size=\"" << size
       << "\" text-anchor=\"" << anchor << "\"" << (attributes.empty() ? "" : " ") << attributes
       << ">" << xml_escape(text) << "</text>\n";
}

void SvgDocument::vertical_text(double x, double y, std::string_view text, double size) {
  out_ << "<text transform=\"translate(" << svg_num(x) << "," << svg_num(y)
       << ") rotate(-90)\" font-size=\"" << size << "\" text-anchor=\"middle\">" << xml_escape(text)
       << "</text>\n";
}

void SvgDocument::line(double x1, double y1, double x2, double y2, std::string_view stroke,
                       double width, std::string_view attributes) {
  out_ << "<line x1=\"" << svg_num(x1) << "\" y1=\"" << svg_num(y1) << "\" x2=\"" << svg_num(x2)
       << "\" y2=\"" << svg_num(y2) << "\" stroke=\"" << stroke << "\" stroke-width=\"" << width
       << "\"" << (attributes.empty() ? "" : " ") << attributes << "/>\n";
}

void SvgDocument::rect(double x, double y, double w, double h, std::string_view fill,
                       std::string_view stroke) {
  out_ << "<rect x=\"" << svg_num(x) << "\" y=\"" << svg_num(y) << "\" width=\"" << svg_num(w)
       << "\" height=\"" << svg_num(h) << "\" fill=\"" << fill << "\" stroke=\"" << stroke
       << "\"/>\n";
}

void SvgDocument::raw(std::string_view element) {
  out_ << element << "\n";
}

std::string SvgDocument::finish() {
  out_ << "</svg>\n";
  return out_.str();
}

}  // namespace detail

std::string plot_lines_svg(std::span<const double> x, std::span<const Series> series,
                           const PlotOptions& options) {
  using namespace detail;
  const ChartLayout c = layout_chart(x, series, options);
  // The bitmap font is DejaVu Sans Mono at 14 px (font_data.inc): the same font in SVG
  // takes the room the layout counted.
  SvgDocument svg(c.width, c.height, "DejaVu Sans Mono, monospace");
  if (!c.drawable) return svg.finish();
  const std::size_t n = x.size();
  const double ch = c.char_h;
  const double size = 14.0;          // font size of a text cell ch high
  const double baseline = 0.8 * ch;  // from the top of a text cell to its baseline
  const double title_h = text_size(options.title, 2)[1];
  const std::string axis = svg_color(kChartAxis), grid = svg_color(kChartGrid);
  // Pixel rows and columns are drawn through their centres, as the raster fills them.
  const double px0 = c.px0 + 0.5, px1 = c.px1 + 0.5, py0 = c.py0 + 0.5, py1 = c.py1 + 0.5;

  // Grid and ticks.
  for (const ChartTick& t : c.x_ticks) {
    const double p = std::lround(t.at) + 0.5;
    svg.line(p, py0, p, py1, grid, 1);
    svg.line(p, py1, p, py1 + 5, axis, 1);
    svg.text(p, c.py1 + 8 + baseline, t.label, size, "middle");
  }
  for (const ChartTick& t : c.y_ticks) {
    const double p = std::lround(t.at) + 0.5;
    svg.line(px0, p, px1, p, grid, 1);
    svg.line(px0 - 5, p, px0, p, axis, 1);
    svg.text(c.px0 - 8, p - ch / 2 + baseline, t.label, size, "end");
  }

  // Stacked bands: each the polygon between its upper and lower curves.
  if (options.stacked && n >= 2)
    for (std::size_t s = 0; s < series.size(); ++s) {
      std::string points;
      for (std::size_t i = 0; i < n; ++i)
        points += svg_num(c.to_px(x[i])) + "," + svg_num(c.to_py(c.tops[s][i])) + " ";
      for (std::size_t i = n; i-- > 0;)
        points +=
            svg_num(c.to_px(x[i])) + "," + svg_num(c.to_py(s > 0 ? c.tops[s - 1][i] : 0.0)) + " ";
      svg.raw("<polygon fill=\"" + svg_color(band_color(series[s].color)) + "\" points=\"" +
              points + "\"/>");
    }

  // Lines (top of each band when stacked); NaN breaks a line.
  for (std::size_t s = 0; s < series.size(); ++s) {
    const std::string color = svg_color(series[s].color);
    std::string points;
    std::size_t count = 0;
    const auto flush = [&] {
      if (count >= 2)
        svg.raw("<polyline fill=\"none\" stroke=\"" + color +
                "\" stroke-width=\"2\" stroke-linejoin=\"round\" points=\"" + points + "\"/>");
      points.clear();
      count = 0;
    };
    for (std::size_t i = 0; i < n; ++i) {
      const double v = c.tops[s][i];
      if (!std::isfinite(v) || !std::isfinite(x[i])) {
        flush();
        continue;
      }
      points += svg_num(c.to_px(x[i])) + "," + svg_num(c.to_py(v)) + " ";
      ++count;
    }
    flush();
    // A single point of a series is drawn as a dot.
    if (n == 1 && std::isfinite(c.tops[s][0]) && std::isfinite(x[0]))
      svg.raw("<circle cx=\"" + svg_num(c.to_px(x[0])) + "\" cy=\"" +
              svg_num(c.to_py(c.tops[s][0])) + "\" r=\"3\" fill=\"" + color + "\"/>");
  }

  // Axes.
  svg.line(px0, py0, px0, py1, axis, 1);
  svg.line(px0, py1, px1, py1, axis, 1);

  // Labels and title.
  if (!options.title.empty())
    svg.text((c.px0 + c.px1) / 2.0, 8 + 0.8 * title_h, options.title, size * title_h / ch,
             "middle");
  if (!options.x_label.empty())
    svg.text((c.px0 + c.px1) / 2.0, c.height - ch - 6 + baseline, options.x_label, size, "middle");
  if (!options.y_label.empty())
    svg.vertical_text(6 + baseline, (c.py0 + c.py1) / 2.0, options.y_label, size);

  // Legend; stacked: listed top band first.
  if (!series.empty()) {
    const int bx = c.legend_x, by = c.legend_y;
    svg.rect(bx + 0.5, by + 0.5, c.legend_w - 1, c.legend_h - 1, "white",
             svg_color(kChartLegendOutline));
    for (std::size_t k = 0; k < series.size(); ++k) {
      const std::size_t s = options.stacked ? series.size() - 1 - k : k;
      const int ry = by + 5 + static_cast<int>(k) * c.legend_row;
      if (options.stacked)
        svg.rect(bx + 8, ry + 3, 20, ch - 6, svg_color(band_color(series[s].color)), "none");
      svg.line(bx + 8, ry + ch / 2, bx + 28, ry + ch / 2, svg_color(series[s].color), 2);
      svg.text(bx + 34, ry + baseline, series[s].name, size, "start");
    }
  }
  return svg.finish();
}

}  // namespace tc::viz

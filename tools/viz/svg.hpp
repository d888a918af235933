// Internal to tools/viz: a standalone SVG document written element by element, for the
// charts (plot_lines_svg, chart_svg.cpp; the log-log scatter, svg_plot.cpp). Coordinates
// in pixels with one decimal; text is XML-escaped.
#pragma once

#include <sstream>
#include <string>
#include <string_view>

#include "draw.hpp"

namespace tc::viz::detail {

/// "#rrggbb".
std::string svg_color(Rgb c);
/// A coordinate: one decimal.
std::string svg_num(double v);

class SvgDocument {
 public:
  /// The header and a white background; `font` is the SVG font-family of the texts.
  SvgDocument(double width, double height, std::string_view font);
  /// Text with its baseline at y; `attributes` are added as they are (e.g. a weight).
  void text(double x, double y, std::string_view text, double size, std::string_view anchor,
            std::string_view attributes = {});
  /// Text turned 90 degrees counter-clockwise, its baseline centre at (x, y).
  void vertical_text(double x, double y, std::string_view text, double size);
  void line(double x1, double y1, double x2, double y2, std::string_view stroke, double width,
            std::string_view attributes = {});
  void rect(double x, double y, double w, double h, std::string_view fill, std::string_view stroke);
  /// Any other element, as written.
  void raw(std::string_view element);
  /// The document, closed.
  std::string finish();

 private:
  std::ostringstream out_;
};

}  // namespace tc::viz::detail

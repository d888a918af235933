// A log-log scatter plot as SVG for the bench reports (`tetcollide bench --plot`): decade
// grid with labelled ticks, axis titles, markers coded by colour (a series, e.g. a
// method) and shape (a group, e.g. a mesh), filled or hollow, optional links between
// markers, and a legend beside the plot. Positive values only (the caller clamps).
// Written with the same SVG writer as plot_lines_svg (svg.hpp).
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace tc::viz {

struct PlotPoint {
  double x = 0.0;
  double y = 0.0;
  int color = 0;  ///< index into LogLogPlot::color_names
  int shape = 0;  ///< index into LogLogPlot::shape_names
  bool filled = true;
};

struct LogLogPlot {
  std::string title;
  std::string x_label;
  std::string y_label;
  std::vector<std::string> color_names;  ///< legend entries for the colours
  std::vector<std::string> shape_names;  ///< legend entries for the shapes
  std::vector<std::string> notes;        ///< extra legend lines (e.g. what filled means)
  std::vector<PlotPoint> points;
  std::vector<std::pair<int, int>> links;  ///< thin lines between two points (indices)
};

/// The plot as a standalone SVG document (about 960 x 600 px).
std::string plot_loglog_svg(const LogLogPlot& plot);

}  // namespace tc::viz

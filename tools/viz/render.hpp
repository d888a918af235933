// Headless pictures without ParaView: a small deterministic software rasterizer for the
// boundary surfaces of tet meshes, a PNG writer (zlib), a built-in bitmap font and line
// plots. Used by `tetcollide render` and by the demo to write frames and timing plots.
//
// Rendering model: perspective pinhole camera, z-buffer, per-pixel Lambert shading with
// a headlight (a directional light fixed to the camera) plus ambient and a little
// Blinn-Phong specular, two-sided faces
// (back faces are shaded with the flipped normal, so open or inverted surfaces still
// look solid), 2x2 supersampling then a box filter. Scalars use a perceptual colour map
// (viridis, or blue-white-red when the range straddles 0) and add a colour bar with
// min/max labels. Everything runs on one thread in a fixed order, so the same input
// gives the same bytes.
//
// Robustness: triangles with a non-finite vertex, a node index out of range or zero
// area are skipped; triangles crossing the near plane are clipped; an empty scene gives
// the background; a camera inside an object sees the inside faces (two-sided shading).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/common/result.hpp"

namespace tc::viz {

/// A perspective camera. `eye`, `target` in the scene's units (metres); `up` need not be
/// orthogonal to the view direction (it is re-orthogonalised; if parallel, another axis
/// is used). `fov_deg` is the vertical field of view. width x height: output pixels.
struct Camera {
  Eigen::Vector3d eye{0, 0, 1}, target{0, 0, 0}, up{0, 0, 1};
  double fov_deg = 35.0;
  int width = 1024, height = 768;
};

/// One object's boundary to draw.
struct Surface {
  /// All nodes of the object, 3 x n, metres. Not owned; must outlive render().
  const Eigen::Matrix3Xd* positions = nullptr;
  /// k outward boundary faces (node indices into positions).
  std::vector<std::array<std::int32_t, 3>> triangles;
  /// n values per node (e.g. depth or |force|), or empty for a plain colour.
  std::vector<double> scalar;
  /// Colour-map range; values outside are clamped. Non-finite values draw grey.
  double scalar_min = 0, scalar_max = 1;
  /// Colour where `scalar` is empty, linear 0..1 RGB.
  Eigen::Vector3f base_color{0.8f, 0.8f, 0.8f};
  /// < 1: blended over what is behind it (drawn after the opaque surfaces, no
  /// depth write; overlapping transparent surfaces are blended in draw order).
  float opacity = 1.0f;
  /// Draw the triangle edges as dark lines (shows the tets' faces).
  bool wireframe = false;
  /// Name shown on the colour bar (e.g. "depth [m]"); empty: none.
  std::string scalar_name;
};

/// An 8-bit RGB image, rows top to bottom, 3 bytes per pixel.
struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;

  /// Pixel (x, y) as {r, g, b}; (x, y) must be inside.
  [[nodiscard]] std::array<std::uint8_t, 3> pixel(int x, int y) const {
    const std::size_t i = (static_cast<std::size_t>(y) * width + x) * 3;
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

/// Extra drawing options of render().
struct RenderOptions {
  bool colour_bar = true;  ///< draw a colour bar when some surface has a scalar
  bool background_gradient = true;
  int supersample = 2;  ///< samples per pixel per axis (1..4)
  std::string title;    ///< drawn top-left when non-empty
  /// Direction toward the light in camera coordinates (x right, y up, z from the eye
  /// into the scene). The light moves with the camera. Default: a headlight raised up
  /// and a little to the right, so that top faces read brighter than front ones; {0, 0, -1} is a
  /// pure headlight (a face seen straight on gets full diffuse light).
  Eigen::Vector3d light{0.15, 0.6, -1.0};
};

/// A camera looking along `view_dir` (from the eye toward the scene) that frames the
/// bounding sphere of all finite positions used by the surfaces' triangles. Up is +z
/// unless the view is vertical (then +y).
Camera fit_camera(std::span<const Surface> surfaces, const Eigen::Vector3d& view_dir, int width,
                  int height);

/// Renders the surfaces (z-buffer rasterizer). Width and height are clamped to
/// [1, 16384].
Image render(std::span<const Surface> surfaces, const Camera& camera);
Image render(std::span<const Surface> surfaces, const Camera& camera, const RenderOptions& options);

/// Encodes an image as PNG bytes (8-bit RGB, no interlace, zlib level 6, fixed filter:
/// deterministic).
std::vector<std::uint8_t> encode_png(const Image& image);
/// Writes encode_png() to `path` (kIo error naming the file when it cannot; kInvalidArgument
/// for an empty or inconsistent image).
tc::Status write_png(const Image& image, const std::string& path);

/// Draws ASCII text (32..126; other bytes draw as '?') with a built-in 8x13 bitmap font,
/// top-left corner at (x, y), each font pixel a scale x scale block. Clipped to the
/// image. '\n' starts a new line.
void draw_text(Image& image, int x, int y, std::string_view text, std::array<std::uint8_t, 3> color,
               int scale = 1);
/// Size in pixels of draw_text(text, scale): {width, height}.
std::array<int, 2> text_size(std::string_view text, int scale = 1);

/// Colour maps, t in [0, 1] clamped, result 8-bit RGB. viridis: perceptual, sequential.
std::array<std::uint8_t, 3> viridis(double t);
/// Blue (t=0) - white (t=0.5) - red (t=1), for signed data.
std::array<std::uint8_t, 3> blue_white_red(double t);

/// One line of a plot: y values at the shared x values (same length; NaN = gap).
struct Series {
  std::string name;
  std::vector<double> y;
  std::array<std::uint8_t, 3> color{31, 119, 180};
};

struct PlotOptions {
  std::string title, x_label, y_label;
  int width = 1000, height = 500;
  /// Stacked areas (series summed in order, each band filled), e.g. time by stage.
  bool stacked = false;
};

/// A line plot (or stacked areas): axes, ticks with "nice" numbers, axis labels, title,
/// legend. Empty input gives axes with a default 0..1 range.
Image plot_lines(std::span<const double> x, std::span<const Series> series,
                 const PlotOptions& options);
/// The same chart as a standalone SVG document (options.width x options.height pixels,
/// the same layout: ticks, labels, bands, lines, legend).
std::string plot_lines_svg(std::span<const double> x, std::span<const Series> series,
                           const PlotOptions& options);

}  // namespace tc::viz

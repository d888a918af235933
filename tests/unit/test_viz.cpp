// tools/viz: PNG encoding (decoded back with libpng), rasterizer shading, z-buffer,
// colour maps, determinism, hostile input, font, plots, the .vtu reader.
#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <random>

#include "core/io/mesh_io.hpp"
#include "core/mesh/topology.hpp"
#include "render.hpp"
#include "test_meshes.hpp"
#include "vtu_reader.hpp"

namespace tc::viz {
namespace {

using Rgb = std::array<std::uint8_t, 3>;

/// Decodes PNG bytes with libpng's simplified API into 8-bit RGB.
Image decode_png(const std::vector<std::uint8_t>& bytes) {
  png_image pi{};
  pi.version = PNG_IMAGE_VERSION;
  Image out;
  if (!png_image_begin_read_from_memory(&pi, bytes.data(), bytes.size())) return out;
  pi.format = PNG_FORMAT_RGB;
  std::vector<std::uint8_t> buf(PNG_IMAGE_SIZE(pi));
  if (!png_image_finish_read(&pi, nullptr, buf.data(), 0, nullptr)) return out;
  out.width = static_cast<int>(pi.width);
  out.height = static_cast<int>(pi.height);
  out.rgb = std::move(buf);
  return out;
}

/// A mesh's boundary as a Surface (positions owned by the caller).
Surface surface_of(const TetMesh& mesh, const Eigen::Matrix3Xd& positions) {
  Surface s;
  s.positions = &positions;
  s.triangles = build_topology(mesh.tets, mesh.num_nodes()).boundary_faces;
  return s;
}

Image empty_render(int w, int h) {
  Camera cam;
  cam.width = w;
  cam.height = h;
  return render({}, cam);
}

bool near_rgb(Rgb a, Rgb b, int tol) {
  for (int k = 0; k < 3; ++k)
    if (std::abs(int(a[k]) - int(b[k])) > tol) return false;
  return true;
}

class PngRoundTrip : public ::testing::TestWithParam<std::array<int, 2>> {};

TEST_P(PngRoundTrip, DecodesToTheSamePixels) {
  const auto [w, h] = GetParam();
  Image img;
  img.width = w;
  img.height = h;
  img.rgb.resize(static_cast<std::size_t>(w) * h * 3);
  std::mt19937 rng(42);
  // Half noise, half smooth gradient, so every PNG filter gets chosen somewhere.
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < 3; ++k)
        img.rgb[(static_cast<std::size_t>(y) * w + x) * 3 + k] =
            y % 2 == 0 ? static_cast<std::uint8_t>(rng() & 255)
                       : static_cast<std::uint8_t>((x * 7 + y * 3 + k * 50) & 255);
  const std::vector<std::uint8_t> bytes = encode_png(img);
  const Image back = decode_png(bytes);
  ASSERT_EQ(back.width, w);
  ASSERT_EQ(back.height, h);
  EXPECT_EQ(back.rgb, img.rgb);

  const auto path = std::filesystem::temp_directory_path() /
                    ("tc_viz_" + std::to_string(w) + "x" + std::to_string(h) + ".png");
  ASSERT_TRUE(write_png(img, path.string()).ok());
  png_image pi{};
  pi.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&pi, path.c_str()));
  pi.format = PNG_FORMAT_RGB;
  std::vector<std::uint8_t> buf(PNG_IMAGE_SIZE(pi));
  ASSERT_TRUE(png_image_finish_read(&pi, nullptr, buf.data(), 0, nullptr));
  EXPECT_EQ(buf, img.rgb);
  std::filesystem::remove(path);
}

INSTANTIATE_TEST_SUITE_P(Sizes, PngRoundTrip,
                         ::testing::Values(std::array<int, 2>{1, 1}, std::array<int, 2>{2, 3},
                                           std::array<int, 2>{37, 23}, std::array<int, 2>{300, 7}));

TEST(Png, RejectsEmptyImageAndUnwritablePath) {
  EXPECT_EQ(write_png(Image{}, "/tmp/never.png").error().code, ErrorCode::kInvalidArgument);
  Image img;
  img.width = img.height = 2;
  img.rgb.assign(12, 0);
  const Status st = write_png(img, "/nonexistent-dir/x.png");
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kIo);
  EXPECT_NE(st.error().message.find("/nonexistent-dir/x.png"), std::string::npos);
}

// Pure headlight shading of a face seen straight on: base * (ambient + diffuse) +
// specular = base * 1.0 + 0.12 (see render.cpp), so base (0.2, 0.4, 0.6) gives
// (82, 133, 184).
RenderOptions headlight() {
  RenderOptions o;
  o.light = {0, 0, -1};
  return o;
}

TEST(Render, CubeFromPlusXShowsShadedFaceAndBackgroundCorners) {
  const TetMesh cube = test::cube_six_tets(1.0);
  const Eigen::Matrix3Xd p = cube.positions;
  Surface s = surface_of(cube, p);
  s.base_color = {0.2f, 0.4f, 0.6f};
  Camera cam;
  cam.eye = {4.0, 0.5, 0.5};
  cam.target = {0.5, 0.5, 0.5};
  cam.width = 160;
  cam.height = 120;
  const Image img = render(std::span<const Surface>(&s, 1), cam, headlight());
  ASSERT_EQ(img.width, 160);
  ASSERT_EQ(img.height, 120);
  EXPECT_TRUE(near_rgb(img.pixel(80, 60), {82, 133, 184}, 2))
      << int(img.pixel(80, 60)[0]) << " " << int(img.pixel(80, 60)[1]) << " "
      << int(img.pixel(80, 60)[2]);
  // The face spans 1/3.5 of the distance: half-height tan(17.5 deg) * 3.5 = 1.10 > 0.5,
  // so the corners are background.
  const Image bg = empty_render(160, 120);
  for (const auto& [x, y] : {std::pair{0, 0}, {159, 0}, {0, 119}, {159, 119}})
    EXPECT_EQ(img.pixel(x, y), bg.pixel(x, y)) << x << "," << y;
  // Background gradient: lighter at the top than at the bottom.
  EXPECT_GT(bg.pixel(0, 0)[0], bg.pixel(0, 119)[0]);
}

TEST(Render, ObliqueFaceIsDarkerThanFaceOn) {
  const TetMesh cube = test::cube_six_tets(1.0);
  const Eigen::Matrix3Xd p = cube.positions;
  Surface s = surface_of(cube, p);
  Camera cam;
  cam.target = {0.5, 0.5, 0.5};
  cam.width = cam.height = 100;
  cam.eye = {5.0, 0.5, 0.5};
  const int straight = render(std::span<const Surface>(&s, 1), cam, headlight()).pixel(50, 50)[0];
  cam.eye = {5.0, 3.5, 0.5};  // the +x face at 34 degrees, the +y face at 56
  const Image img = render(std::span<const Surface>(&s, 1), cam, headlight());
  const Image bg = empty_render(100, 100);
  // Both faces are visible and lit less than face-on.
  int darker = 0;
  for (int x = 0; x < 100; ++x)
    if (img.pixel(x, 50)[0] < straight - 10 && img.pixel(x, 50) != bg.pixel(x, 50)) ++darker;
  EXPECT_GT(darker, 10);
}

TEST(Render, NearObjectOccludesFarObjectWhateverTheOrder) {
  const TetMesh cube = test::cube_six_tets(1.0);
  const Eigen::Matrix3Xd near_p = cube.positions;  // [0,1]^3
  const Eigen::Matrix3Xd far_p = (cube.positions * 3.0).colwise() + Eigen::Vector3d(-4, -1, -1);
  Surface near_s = surface_of(cube, near_p), far_s = surface_of(cube, far_p);
  near_s.base_color = {1.0f, 0.0f, 0.0f};
  far_s.base_color = {0.0f, 0.0f, 1.0f};
  Camera cam;
  cam.eye = {6.0, 0.5, 0.5};
  cam.target = {0.5, 0.5, 0.5};
  cam.width = cam.height = 200;
  const std::vector<Surface> a = {near_s, far_s}, b = {far_s, near_s};
  const Image ia = render(a, cam), ib = render(b, cam);
  EXPECT_EQ(ia.rgb, ib.rgb);
  const Rgb centre = ia.pixel(100, 100);
  EXPECT_GT(centre[0], 200);
  EXPECT_LT(centre[2], 60);
  // Beside the near cube the far one shows (blue).
  const Rgb side = ia.pixel(100, 40);
  EXPECT_GT(side[2], 200);
  EXPECT_LT(side[0], 60);
}

TEST(Render, TransparentSurfaceBlendsWithWhatIsBehind) {
  const TetMesh cube = test::cube_six_tets(1.0);
  const Eigen::Matrix3Xd near_p = cube.positions;
  const Eigen::Matrix3Xd far_p = (cube.positions * 3.0).colwise() + Eigen::Vector3d(-4, -1, -1);
  Surface near_s = surface_of(cube, near_p), far_s = surface_of(cube, far_p);
  near_s.base_color = {1.0f, 0.0f, 0.0f};
  near_s.opacity = 0.5f;
  far_s.base_color = {0.0f, 0.0f, 1.0f};
  Camera cam;
  cam.eye = {6.0, 0.5, 0.5};
  cam.target = {0.5, 0.5, 0.5};
  cam.width = cam.height = 200;
  const std::vector<Surface> both = {near_s, far_s};
  // Half of the red face (255, 31, 31) over the blue face (31, 31, 255): front faces only.
  const Rgb c = render(both, cam, headlight()).pixel(100, 100);
  EXPECT_TRUE(near_rgb(c, {143, 31, 143}, 3)) << int(c[0]) << " " << int(c[1]) << " " << int(c[2]);
}

TEST(ColourMap, Endpoints) {
  EXPECT_EQ(viridis(0.0), (Rgb{68, 1, 84}));
  EXPECT_EQ(viridis(1.0), (Rgb{253, 231, 37}));
  EXPECT_EQ(viridis(-3.0), viridis(0.0));
  EXPECT_EQ(viridis(7.0), viridis(1.0));
  EXPECT_EQ(viridis(std::nan("")), viridis(0.0));
  EXPECT_EQ(blue_white_red(0.0), (Rgb{33, 102, 172}));
  EXPECT_EQ(blue_white_red(0.5), (Rgb{247, 247, 247}));
  EXPECT_EQ(blue_white_red(1.0), (Rgb{178, 24, 43}));
  // Viridis brightens monotonically (sum of channels is a rough luminance).
  int prev = -1;
  for (int i = 0; i <= 100; ++i) {
    const Rgb c = viridis(i / 100.0);
    const int lum = 2 * c[0] + 5 * c[1] + c[2];
    EXPECT_GE(lum, prev) << i;
    prev = lum;
  }
}

TEST(Render, ScalarFieldUsesTheColourMapAndDrawsAColourBar) {
  const TetMesh cube = test::cube_six_tets(1.0);
  const Eigen::Matrix3Xd p = cube.positions;
  Surface s = surface_of(cube, p);
  s.scalar.assign(static_cast<std::size_t>(p.cols()), 1.0);  // all at the maximum
  s.scalar_min = 0;
  s.scalar_max = 1;
  s.scalar_name = "depth";
  Camera cam;
  cam.eye = {4.0, 0.5, 0.5};
  cam.target = {0.5, 0.5, 0.5};
  cam.width = 400;
  cam.height = 300;
  const Image img = render(std::span<const Surface>(&s, 1), cam, headlight());
  // Face-on: colour * 1.0 + 0.12 specular, clamped: viridis(1) = (253, 231, 37).
  EXPECT_TRUE(near_rgb(img.pixel(200, 150), {255, 255, 68}, 2));
  // The colour bar on the right holds the map's bottom colour near its lower end.
  bool found_bottom = false;
  for (int y = 150; y < 300 && !found_bottom; ++y)
    for (int x = 200; x < 400 && !found_bottom; ++x) found_bottom = img.pixel(x, y) == viridis(0.0);
  EXPECT_TRUE(found_bottom);
}

TEST(Render, DeterministicBytes) {
  auto mesh = read_mesh(test::mesh_path("torus.msh"));
  ASSERT_TRUE(mesh.has_value()) << mesh.error().message;
  const Eigen::Matrix3Xd p = mesh->positions;
  Surface s = surface_of(*mesh, p);
  s.wireframe = true;
  s.scalar.resize(static_cast<std::size_t>(p.cols()));
  for (Eigen::Index i = 0; i < p.cols(); ++i) s.scalar[static_cast<std::size_t>(i)] = p(2, i);
  s.scalar_min = -0.1;
  s.scalar_max = 0.1;
  const Camera cam = fit_camera(std::span<const Surface>(&s, 1), {-0.5, 1.0, -0.6}, 320, 240);
  const Image a = render(std::span<const Surface>(&s, 1), cam);
  const Image b = render(std::span<const Surface>(&s, 1), cam);
  EXPECT_EQ(encode_png(a), encode_png(b));
  // Not trivial: many pixels differ from the background.
  const Image bg = empty_render(320, 240);
  int covered = 0;
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 320; ++x) covered += a.pixel(x, y) != bg.pixel(x, y);
  EXPECT_GT(covered, 320 * 240 / 10);
}

TEST(Render, HostileInputNeverCrashes) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  Eigen::Matrix3Xd p(3, 7);
  p << 0, 1, 0, nan, 0, 0, 1e300,  //
      0, 0, 1, 0, 0, 0, inf,       //
      0, 0, 0, 0, 0, 0, 0;
  Surface s;
  s.positions = &p;
  s.triangles = {{0, 1, 2}, {0, 1, 3}, {0, 4, 5}, {0, 1, 99}, {-1, 0, 1}, {0, 1, 6}, {2, 2, 2}};
  s.scalar = {0, nan, 1, 2, inf, -inf, 0};
  s.opacity = std::nanf("");
  s.base_color = {std::nanf(""), 0, 0};
  const Camera cam = fit_camera(std::span<const Surface>(&s, 1), {0, 0, -1}, 64, 48);
  EXPECT_TRUE(cam.eye.allFinite());
  EXPECT_TRUE(cam.target.allFinite());
  const Image img = render(std::span<const Surface>(&s, 1), cam);
  ASSERT_EQ(img.rgb.size(), 64u * 48u * 3u);
  // The one valid triangle (0, 1, 2) is drawn: something differs from the background.
  const Image bg = empty_render(64, 48);
  EXPECT_NE(img.rgb, bg.rgb);
  // Null positions, empty input, degenerate camera, NaN view direction, silly sizes.
  Surface none;
  none.triangles = {{0, 1, 2}};
  Camera bad;
  bad.eye = bad.target = {1, 1, 1};
  bad.up = {nan, 0, 0};
  bad.fov_deg = nan;
  bad.width = -5;
  bad.height = 0;
  const Image tiny = render(std::span<const Surface>(&none, 1), bad);
  EXPECT_EQ(tiny.width, 1);
  EXPECT_EQ(tiny.height, 1);
  EXPECT_TRUE(fit_camera({}, {nan, 0, 0}, 10, 10).eye.allFinite());
}

class ScaleAndOffset : public ::testing::TestWithParam<std::pair<double, double>> {};

// The same cube scaled by 1e-6 or moved by 1e6, framed by fit_camera, gives the same
// picture as the unit cube (up to rounding).
TEST_P(ScaleAndOffset, PictureDoesNotDependOnUnits) {
  const auto [scale, offset] = GetParam();
  const TetMesh cube = test::cube_six_tets(1.0);
  const Eigen::Matrix3Xd ref_p = cube.positions;
  const Eigen::Matrix3Xd p = (cube.positions * scale).array() + offset;
  Surface ref = surface_of(cube, ref_p), s = surface_of(cube, p);
  ref.wireframe = s.wireframe = true;
  const Eigen::Vector3d dir(-0.6, 1.0, -0.55);
  const Image a = render(std::span<const Surface>(&ref, 1),
                         fit_camera(std::span<const Surface>(&ref, 1), dir, 120, 90));
  const Image b = render(std::span<const Surface>(&s, 1),
                         fit_camera(std::span<const Surface>(&s, 1), dir, 120, 90));
  int differing = 0;
  for (std::size_t i = 0; i < a.rgb.size(); ++i)
    differing += std::abs(int(a.rgb[i]) - int(b.rgb[i])) > 8;
  EXPECT_LT(differing, 40) << "scale " << scale << " offset " << offset;
}

INSTANTIATE_TEST_SUITE_P(Units, ScaleAndOffset,
                         ::testing::Values(std::pair{1e-6, 0.0}, std::pair{1.0, 1e6},
                                           std::pair{1e-6, 1e3}, std::pair{1e3, -1e6}));

TEST(Render, CameraInsideObjectSeesInsideFaces) {
  const TetMesh cube = test::cube_six_tets(2.0);
  const Eigen::Matrix3Xd p = cube.positions;
  Surface s = surface_of(cube, p);
  Camera cam;
  cam.eye = {1.0, 1.0, 1.0};
  cam.target = {2.0, 1.2, 1.1};
  cam.width = 80;
  cam.height = 60;
  const Image img = render(std::span<const Surface>(&s, 1), cam);
  const Image bg = empty_render(80, 60);
  for (int y = 0; y < 60; y += 5)
    for (int x = 0; x < 80; x += 5) EXPECT_NE(img.pixel(x, y), bg.pixel(x, y)) << x << "," << y;
}

TEST(Render, TrianglesCrossingTheNearPlaneAreClipped) {
  // A large floor at z = 0 seen from just above it: it extends behind the camera.
  Eigen::Matrix3Xd p(3, 4);
  p << -100, 100, 100, -100,  //
      -100, -100, 100, 100,   //
      0, 0, 0, 0;
  Surface s;
  s.positions = &p;
  s.triangles = {{0, 1, 2}, {0, 2, 3}};
  s.wireframe = true;
  Camera cam;
  cam.eye = {0, 0, 1};
  cam.target = {0, 10, 0.5};
  cam.width = 100;
  cam.height = 80;
  const Image img = render(std::span<const Surface>(&s, 1), cam);
  const Image bg = empty_render(100, 80);
  // Bottom rows show the floor, top rows the sky.
  EXPECT_NE(img.pixel(50, 78), bg.pixel(50, 78));
  EXPECT_EQ(img.pixel(50, 1), bg.pixel(50, 1));
}

TEST(Font, DrawsInsideItsBoxOnly) {
  Image img;
  img.width = 120;
  img.height = 80;
  img.rgb.assign(120u * 80u * 3u, 255);
  const std::string text = "Ag1|";
  for (const int scale : {1, 2, 3}) {
    std::fill(img.rgb.begin(), img.rgb.end(), 255);
    draw_text(img, 10, 20, text, {0, 0, 0}, scale);
    const auto [w, h] = text_size(text, scale);
    ASSERT_GT(w, 0);
    int inside = 0, outside = 0;
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) {
        if (img.pixel(x, y)[0] == 255) continue;
        const bool in = x >= 10 && x < 10 + w && y >= 20 && y < 20 + h;
        (in ? inside : outside) += 1;
      }
    EXPECT_GT(inside, 20 * scale) << scale;
    EXPECT_EQ(outside, 0) << scale;
  }
  // Clipped at the image edges, never out of bounds; non-ASCII draws as '?'.
  draw_text(img, -5, -7, "\x01\xff edge", {0, 0, 0}, 2);
  draw_text(img, 115, 75, "clipped", {0, 0, 0}, 4);
  EXPECT_EQ(text_size("ab\nc").at(0), text_size("ab").at(0));
  EXPECT_EQ(text_size("ab\nc").at(1), 2 * text_size("ab").at(1));
}

/// Longest run of `c` in any column (vertical) or row (horizontal).
int longest_run(const Image& img, Rgb c, bool vertical) {
  int best = 0;
  const int outer = vertical ? img.width : img.height, inner = vertical ? img.height : img.width;
  for (int o = 0; o < outer; ++o) {
    int run = 0;
    for (int i = 0; i < inner; ++i) {
      const Rgb p = vertical ? img.pixel(o, i) : img.pixel(i, o);
      run = p == c ? run + 1 : 0;
      best = std::max(best, run);
    }
  }
  return best;
}

TEST(Plot, AxesTicksLinesAndStackedBands) {
  std::vector<double> x(50);
  std::vector<Series> series(2);
  series[0] = {"detect", {}, {31, 119, 180}};
  series[1] = {"respond", {}, {214, 39, 40}};
  for (int i = 0; i < 50; ++i) {
    x[static_cast<std::size_t>(i)] = i;
    series[0].y.push_back(1.0 + 0.5 * std::sin(i * 0.2));
    series[1].y.push_back(i == 20 ? std::nan("") : 0.5 + 0.01 * i);
  }
  for (const bool stacked : {false, true}) {
    PlotOptions o;
    o.title = "time per frame";
    o.x_label = "frame";
    o.y_label = "ms";
    o.stacked = stacked;
    const Image img = plot_lines(x, series, o);
    ASSERT_EQ(img.width, 1000);
    ASSERT_EQ(img.height, 500);
    // Axes: long straight dark lines.
    EXPECT_GT(longest_run(img, {40, 40, 40}, true), 300);
    EXPECT_GT(longest_run(img, {40, 40, 40}, false), 700);
    // Both series' colours appear.
    int blue = 0, red = 0;
    for (int y = 0; y < img.height; ++y)
      for (int xx = 0; xx < img.width; ++xx) {
        blue += img.pixel(xx, y) == series[0].color;
        red += img.pixel(xx, y) == series[1].color;
      }
    EXPECT_GT(blue, 50);
    EXPECT_GT(red, 50);
  }
  // Degenerate input: no data, one point, constant values.
  EXPECT_EQ(plot_lines({}, {}, PlotOptions{}).width, 1000);
  const std::vector<double> one = {3.0};
  const std::vector<Series> flat = {{"flat", {2.0}, {0, 0, 0}}};
  EXPECT_GT(longest_run(plot_lines(one, flat, PlotOptions{}), {40, 40, 40}, true), 300);
}

TEST(Vtu, ReadsBackWhatTheCoreWrites) {
  const TetMesh cube = test::cube_five_tets(2.0);
  std::vector<VtuField> fields(2);
  fields[0].name = "depth";
  fields[1].name = "force";
  fields[1].components = 3;
  for (Index i = 0; i < cube.num_nodes(); ++i) {
    fields[0].values.push_back(0.25 * i);
    for (const double v : {3.0 * i, 4.0 * i, 0.0}) fields[1].values.push_back(v);
  }
  const auto path = std::filesystem::temp_directory_path() / "tc_viz_cube.vtu";
  ASSERT_TRUE(write_vtu(path, cube, fields).ok());
  auto back = read_vtu(path);
  ASSERT_TRUE(back.has_value()) << back.error().message;
  EXPECT_EQ(back->mesh.positions, cube.positions);
  EXPECT_EQ(back->mesh.tets, cube.tets);
  EXPECT_EQ(back->mesh.node_ids, cube.node_ids);
  ASSERT_EQ(back->point_fields.size(), 3u);  // node_id, depth, |force|
  EXPECT_EQ(back->point_fields[1].name, "depth");
  EXPECT_EQ(back->point_fields[1].values, fields[0].values);
  EXPECT_EQ(back->point_fields[2].name, "force");
  EXPECT_DOUBLE_EQ(back->point_fields[2].values[2], 10.0);
  std::filesystem::remove(path);

  EXPECT_EQ(read_vtu("/nonexistent/x.vtu").error().code, ErrorCode::kIo);
  EXPECT_EQ(read_vtu_buffer("hello", "h.vtu").error().code, ErrorCode::kParse);
  const std::string binary =
      "<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=\"1\" "
      "NumberOfCells=\"0\"><Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" "
      "format=\"binary\">AAAA</DataArray></Points></Piece></UnstructuredGrid></VTKFile>";
  EXPECT_EQ(read_vtu_buffer(binary, "b.vtu").error().code, ErrorCode::kUnsupported);
  const std::string bad_index =
      "<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=\"1\" "
      "NumberOfCells=\"1\"><Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" "
      "format=\"ascii\">0 0 0</DataArray></Points><Cells><DataArray type=\"Int64\" "
      "Name=\"connectivity\" format=\"ascii\">0 0 0 7</DataArray><DataArray type=\"Int64\" "
      "Name=\"offsets\" format=\"ascii\">4</DataArray><DataArray type=\"UInt8\" Name=\"types\" "
      "format=\"ascii\">10</DataArray></Cells></Piece></UnstructuredGrid></VTKFile>";
  const auto e = read_vtu_buffer(bad_index, "i.vtu");
  ASSERT_FALSE(e.has_value());
  EXPECT_EQ(e.error().code, ErrorCode::kInvalidMesh);
  EXPECT_NE(e.error().message.find("cell 0 refers to point 7"), std::string::npos);
}

}  // namespace
}  // namespace tc::viz

// The software rasterizer: camera set-up, near-plane clipping, z-buffer, per-pixel
// shading, wireframe overlay, supersampling, colour bar.
#include "render.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "draw.hpp"

namespace tc::viz {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Shading: colour = base * (ambient + diffuse * |n.l|) + specular * (n.l)^shininess.
constexpr float kAmbient = 0.28f;
constexpr float kDiffuse = 0.72f;
constexpr float kSpecular = 0.12f;
constexpr int kShininess = 32;
// Wireframe: line half-width in output pixels and its darkening factor.
constexpr double kEdgeHalfWidth = 0.55;
constexpr float kEdgeDarken = 0.55f;
// Corners whose smooth normal turns more than this from the face normal use the face
// normal (keeps the box's edges sharp and the torus smooth).
const double kCreaseCos = std::cos(35.0 * kPi / 180.0);
// Grey for non-finite scalars.
constexpr float kNanGrey = 0.55f;

/// Orthonormal camera frame.
struct View {
  Eigen::Vector3d eye, right, up, forward;
  double focal = 1;  // pixels (supersampled) per unit of x/z
  double cx = 0, cy = 0;
  double znear = 1e-6;
};

View make_view(const Camera& cam, int w, int h) {
  View v;
  v.eye = cam.eye;
  Eigen::Vector3d f = cam.target - cam.eye;
  if (!f.allFinite() || f.norm() == 0) f = Eigen::Vector3d(0, 1, 0);
  v.forward = f.normalized();
  Eigen::Vector3d up = cam.up.allFinite() ? cam.up : Eigen::Vector3d(0, 0, 1);
  Eigen::Vector3d r = v.forward.cross(up);
  if (r.norm() < 1e-9 * std::max(1.0, up.norm())) {
    // Up parallel to the view: pick the axis least aligned with it.
    Eigen::Index axis = 0;
    v.forward.cwiseAbs().minCoeff(&axis);
    r = v.forward.cross(Eigen::Vector3d::Unit(axis));
  }
  v.right = r.normalized();
  v.up = v.right.cross(v.forward);
  double fov = std::isfinite(cam.fov_deg) ? std::clamp(cam.fov_deg, 1.0, 170.0) : 35.0;
  v.focal = 0.5 * h / std::tan(0.5 * fov * kPi / 180.0);
  v.cx = 0.5 * w;
  v.cy = 0.5 * h;
  const double dist = (cam.target - cam.eye).norm();
  v.znear = std::isfinite(dist) && dist > 0 ? 1e-3 * dist : 1e-6;
  return v;
}

/// A vertex in camera space with its attributes.
struct CamVertex {
  Eigen::Vector3d p;  // camera space: x right, y up, z forward (depth)
  Eigen::Vector3d n;  // shading normal, camera space
  double t = 0;       // colour-map coordinate (NaN allowed)
};

CamVertex lerp(const CamVertex& a, const CamVertex& b, double s) {
  return {a.p + s * (b.p - a.p), a.n + s * (b.n - a.n), a.t + s * (b.t - a.t)};
}

/// Clips a triangle against z >= znear; writes 0, 3 or 4 vertices (a convex polygon).
int clip_near(const CamVertex (&in)[3], double znear, CamVertex (&out)[4]) {
  int k = 0;
  for (int i = 0; i < 3; ++i) {
    const CamVertex& a = in[i];
    const CamVertex& b = in[(i + 1) % 3];
    const bool ain = a.p.z() >= znear, bin = b.p.z() >= znear;
    if (ain) out[k++] = a;
    if (ain != bin) out[k++] = lerp(a, b, (znear - a.p.z()) / (b.p.z() - a.p.z()));
  }
  return k;
}

/// Float RGB frame buffer with a depth buffer (1/z, larger is nearer).
struct Frame {
  int w = 0, h = 0;
  std::vector<float> rgb;
  std::vector<float> inv_z;
};

void fill_background(Frame& fb, bool gradient) {
  const Eigen::Vector3f top(0.98f, 0.985f, 0.99f), bottom(0.80f, 0.84f, 0.88f);
  for (int y = 0; y < fb.h; ++y) {
    const float s =
        gradient && fb.h > 1 ? static_cast<float>(y) / static_cast<float>(fb.h - 1) : 0.0f;
    const Eigen::Vector3f c = top + s * (bottom - top);
    float* row = fb.rgb.data() + static_cast<std::size_t>(y) * fb.w * 3;
    for (int x = 0; x < fb.w; ++x) {
      row[3 * x] = c.x();
      row[3 * x + 1] = c.y();
      row[3 * x + 2] = c.z();
    }
  }
}

/// Per-surface colouring: maps a scalar to t in [0, 1] and t to a colour.
struct ColourMap {
  bool active = false;
  bool diverging = false;
  double lo = 0, hi = 1;  // range shown on the colour bar
  double to_t(double s) const {
    if (!std::isfinite(s)) return std::numeric_limits<double>::quiet_NaN();
    if (!(hi > lo)) return 0.5;
    return std::clamp((s - lo) / (hi - lo), 0.0, 1.0);
  }
  Eigen::Vector3f colour(double t) const {
    if (!std::isfinite(t)) return {kNanGrey, kNanGrey, kNanGrey};
    const auto c = diverging ? blue_white_red(t) : viridis(t);
    return {c[0] / 255.0f, c[1] / 255.0f, c[2] / 255.0f};
  }
};

ColourMap colour_map_of(const Surface& s) {
  ColourMap m;
  if (s.scalar.empty()) return m;
  m.active = true;
  double lo = s.scalar_min, hi = s.scalar_max;
  if (!std::isfinite(lo) || !std::isfinite(hi)) lo = 0, hi = 1;
  if (lo > hi) std::swap(lo, hi);
  if (lo < 0 && hi > 0) {
    // Signed data: symmetric range so that 0 is white.
    m.diverging = true;
    const double a = std::max(-lo, hi);
    lo = -a;
    hi = a;
  }
  m.lo = lo;
  m.hi = hi;
  return m;
}

/// Smooth per-node normals (area-weighted, world space) of one surface; zero where a
/// node has no valid triangle.
std::vector<Eigen::Vector3d> node_normals(const Surface& s, const std::vector<char>& valid) {
  const auto& P = *s.positions;
  std::vector<Eigen::Vector3d> n(static_cast<std::size_t>(P.cols()), Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < s.triangles.size(); ++i) {
    if (!valid[i]) continue;
    const auto& t = s.triangles[i];
    const Eigen::Vector3d fn = (P.col(t[1]) - P.col(t[0])).cross(P.col(t[2]) - P.col(t[0]));
    for (const auto v : t) n[static_cast<std::size_t>(v)] += fn;
  }
  for (auto& v : n) {
    const double len = v.norm();
    v = len > 0 && std::isfinite(len) ? Eigen::Vector3d(v / len) : Eigen::Vector3d::Zero();
  }
  return n;
}

struct RasterParams {
  const ColourMap* map = nullptr;
  Eigen::Vector3f base;
  float opacity = 1;
  bool wireframe = false;
  double edge_half_width = 1;  // in supersampled pixels
};

/// Rasterizes one screen-space triangle (already near-clipped) into the frame.
void raster_triangle(Frame& fb, const View& view, const CamVertex& a, const CamVertex& b,
                     const CamVertex& c, const RasterParams& rp, const bool (&edge_real)[3]) {
  const CamVertex* v[3] = {&a, &b, &c};
  double sx[3], sy[3], iz[3];
  for (int i = 0; i < 3; ++i) {
    iz[i] = 1.0 / v[i]->p.z();
    sx[i] = view.cx + view.focal * v[i]->p.x() * iz[i];
    sy[i] = view.cy - view.focal * v[i]->p.y() * iz[i];
    if (!std::isfinite(sx[i]) || !std::isfinite(sy[i])) return;
  }
  const double area = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sx[2] - sx[0]) * (sy[1] - sy[0]);
  if (!(std::abs(area) > 1e-12)) return;
  const double xmin = std::min({sx[0], sx[1], sx[2]}), xmax = std::max({sx[0], sx[1], sx[2]});
  const double ymin = std::min({sy[0], sy[1], sy[2]}), ymax = std::max({sy[0], sy[1], sy[2]});
  const int x0 = std::max(0, static_cast<int>(std::floor(std::max(xmin, -1.0))));
  const int x1 = std::min(fb.w - 1, static_cast<int>(std::ceil(std::min(xmax, fb.w + 1.0))));
  const int y0 = std::max(0, static_cast<int>(std::floor(std::max(ymin, -1.0))));
  const int y1 = std::min(fb.h - 1, static_cast<int>(std::ceil(std::min(ymax, fb.h + 1.0))));
  if (x0 > x1 || y0 > y1) return;
  const double inv_area = 1.0 / area;
  // Edge lengths in (supersampled) pixels, for the wireframe distance.
  double elen[3];
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    elen[i] = std::hypot(sx[k] - sx[j], sy[k] - sy[j]);  // edge opposite vertex i
  }
  const double abs_area = std::abs(area);
  // Attributes divided by z for perspective-correct interpolation.
  Eigen::Vector3d nz[3];
  double tz[3];
  for (int i = 0; i < 3; ++i) {
    nz[i] = v[i]->n * iz[i];
    tz[i] = v[i]->t * iz[i];
  }
  const Eigen::Vector3d face_n =
      (v[1]->p - v[0]->p).cross(v[2]->p - v[0]->p).normalized();  // camera space
  for (int y = y0; y <= y1; ++y) {
    const double py = y + 0.5;
    for (int x = x0; x <= x1; ++x) {
      const double px = x + 0.5;
      double w0 = ((sx[1] - px) * (sy[2] - py) - (sx[2] - px) * (sy[1] - py)) * inv_area;
      double w1 = ((sx[2] - px) * (sy[0] - py) - (sx[0] - px) * (sy[2] - py)) * inv_area;
      double w2 = 1.0 - w0 - w1;
      if (w0 < 0 || w1 < 0 || w2 < 0) continue;
      const double inv_zp = w0 * iz[0] + w1 * iz[1] + w2 * iz[2];
      const std::size_t idx = static_cast<std::size_t>(y) * fb.w + x;
      if (!(inv_zp > fb.inv_z[idx])) continue;
      const double zp = 1.0 / inv_zp;
      // Shading normal, flipped toward the viewer (two-sided).
      Eigen::Vector3d n = (w0 * nz[0] + w1 * nz[1] + w2 * nz[2]) * zp;
      const double nlen = n.norm();
      n = nlen > 1e-12 ? Eigen::Vector3d(n / nlen) : face_n;
      // View ray at this pixel (camera space), from the eye.
      const Eigen::Vector3d ray =
          Eigen::Vector3d((px - view.cx) / view.focal, -(py - view.cy) / view.focal, 1.0)
              .normalized();
      double ndl = -n.dot(ray);
      if (face_n.dot(ray) > 0) ndl = -ndl;  // back face: use the flipped normal
      ndl = std::clamp(ndl, 0.0, 1.0);
      Eigen::Vector3f albedo = rp.base;
      if (rp.map->active) albedo = rp.map->colour((w0 * tz[0] + w1 * tz[1] + w2 * tz[2]) * zp);
      const float d = static_cast<float>(ndl);
      float spec = 1.0f;
      for (int i = 0; i < kShininess; ++i) spec *= d;
      Eigen::Vector3f col =
          albedo * (kAmbient + kDiffuse * d) + Eigen::Vector3f::Constant(kSpecular * spec);
      if (rp.wireframe) {
        // Screen distance to the nearest real edge: w_i * 2|area| / |edge_i|.
        double dist = std::numeric_limits<double>::infinity();
        const double w[3] = {w0, w1, w2};
        for (int i = 0; i < 3; ++i)
          if (edge_real[i] && elen[i] > 0) dist = std::min(dist, w[i] * abs_area / elen[i]);
        if (dist < rp.edge_half_width + 1.0) {
          const double cover = std::clamp(rp.edge_half_width + 1.0 - dist, 0.0, 1.0);
          col *= 1.0f - static_cast<float>(cover) * (1.0f - kEdgeDarken);
        }
      }
      col = col.cwiseMin(1.0f).cwiseMax(0.0f);
      float* dst = fb.rgb.data() + idx * 3;
      if (rp.opacity >= 1.0f) {
        fb.inv_z[idx] = static_cast<float>(inv_zp);
        dst[0] = col.x();
        dst[1] = col.y();
        dst[2] = col.z();
      } else {
        const float o = std::max(rp.opacity, 0.0f);
        for (int k = 0; k < 3; ++k) dst[k] = o * col[k] + (1 - o) * dst[k];
      }
    }
  }
}

void draw_surface(Frame& fb, const View& view, const Surface& s, const RasterParams& rp_in) {
  if (s.positions == nullptr || s.triangles.empty()) return;
  const auto& P = *s.positions;
  const auto n_nodes = static_cast<std::int64_t>(P.cols());
  std::vector<char> valid(s.triangles.size(), 0);
  for (std::size_t i = 0; i < s.triangles.size(); ++i) {
    const auto& t = s.triangles[i];
    bool ok = true;
    for (const auto v : t) ok = ok && v >= 0 && v < n_nodes && P.col(v).allFinite();
    if (ok) {
      const Eigen::Vector3d fn = (P.col(t[1]) - P.col(t[0])).cross(P.col(t[2]) - P.col(t[0]));
      const double len = fn.norm();
      ok = len > 0 && std::isfinite(len);
    }
    valid[i] = ok ? 1 : 0;
  }
  const std::vector<Eigen::Vector3d> smooth = node_normals(s, valid);
  const ColourMap map = colour_map_of(s);
  RasterParams rp = rp_in;
  rp.map = &map;
  rp.base = s.base_color.allFinite() ? Eigen::Vector3f(s.base_color.cwiseMax(0.0f).cwiseMin(1.0f))
                                     : Eigen::Vector3f(0.8f, 0.8f, 0.8f);
  rp.opacity = std::isfinite(s.opacity) ? std::clamp(s.opacity, 0.0f, 1.0f) : 1.0f;
  rp.wireframe = s.wireframe;
  const bool scalars = s.scalar.size() == static_cast<std::size_t>(n_nodes);
  for (std::size_t i = 0; i < s.triangles.size(); ++i) {
    if (!valid[i]) continue;
    const auto& t = s.triangles[i];
    const Eigen::Vector3d fn =
        (P.col(t[1]) - P.col(t[0])).cross(P.col(t[2]) - P.col(t[0])).normalized();
    CamVertex cv[3];
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d d = P.col(t[k]) - view.eye;
      cv[k].p = Eigen::Vector3d(d.dot(view.right), d.dot(view.up), d.dot(view.forward));
      const Eigen::Vector3d& sn = smooth[static_cast<std::size_t>(t[k])];
      const Eigen::Vector3d wn = sn.dot(fn) >= kCreaseCos ? sn : fn;
      cv[k].n = Eigen::Vector3d(wn.dot(view.right), wn.dot(view.up), wn.dot(view.forward));
      cv[k].t = scalars ? map.to_t(s.scalar[static_cast<std::size_t>(t[k])])
                        : std::numeric_limits<double>::quiet_NaN();
    }
    if (!map.active)
      for (auto& c : cv) c.t = 0;
    CamVertex poly[4];
    const int k = clip_near(cv, view.znear, poly);
    if (k < 3) continue;
    // Edges of the clipped polygon that lie on the original triangle's edges are drawn
    // in wireframe; the cut along the near plane is not.
    auto on_original = [&](const CamVertex& p, const CamVertex& q) {
      return !(std::abs(p.p.z() - view.znear) < 1e-12 * std::max(1.0, view.znear) &&
               std::abs(q.p.z() - view.znear) < 1e-12 * std::max(1.0, view.znear));
    };
    if (k == 3) {
      const bool e[3] = {true, true, true};
      raster_triangle(fb, view, poly[0], poly[1], poly[2], rp, e);
    } else {
      // Fan (0,1,2) and (0,2,3); the diagonal 0-2 is not an edge.
      const bool e1[3] = {on_original(poly[1], poly[2]), false, on_original(poly[0], poly[1])};
      const bool e2[3] = {on_original(poly[2], poly[3]), on_original(poly[3], poly[0]), false};
      raster_triangle(fb, view, poly[0], poly[1], poly[2], rp, e1);
      raster_triangle(fb, view, poly[0], poly[2], poly[3], rp, e2);
    }
  }
}

std::string format_value(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

void draw_colour_bar(Image& img, const ColourMap& map, const std::string& name) {
  const int bar_w = std::max(10, img.width / 60);
  const int bar_h = std::max(40, img.height / 2);
  const int label_w = text_size("-0.0000e-00").at(0);
  const int x0 = img.width - bar_w - label_w - 24;
  const int y0 = (img.height - bar_h) / 2;
  if (x0 < 0 || y0 < 0) return;
  for (int y = 0; y < bar_h; ++y) {
    const double t = 1.0 - static_cast<double>(y) / std::max(1, bar_h - 1);
    const auto c = map.diverging ? blue_white_red(t) : viridis(t);
    for (int x = 0; x < bar_w; ++x) detail::put_pixel(img, x0 + x, y0 + y, c);
  }
  const std::array<std::uint8_t, 3> black{30, 30, 30};
  detail::draw_rect_outline(img, x0 - 1, y0 - 1, bar_w + 2, bar_h + 2, black);
  const int th = text_size("0").at(1);
  draw_text(img, x0 + bar_w + 6, y0 - th / 2, format_value(map.hi), black);
  draw_text(img, x0 + bar_w + 6, y0 + bar_h - th / 2, format_value(map.lo), black);
  if (map.diverging) draw_text(img, x0 + bar_w + 6, y0 + bar_h / 2 - th / 2, "0", black);
  if (!name.empty()) {
    const int nw = text_size(name).at(0);
    draw_text(img, std::max(0, std::min(x0 + bar_w / 2 - nw / 2, img.width - nw - 4)),
              y0 - 2 * th - 4, name, black);
  }
}

}  // namespace

Camera fit_camera(std::span<const Surface> surfaces, const Eigen::Vector3d& view_dir, int width,
                  int height) {
  Camera cam;
  cam.width = width;
  cam.height = height;
  Eigen::Vector3d dir = view_dir;
  if (!dir.allFinite() || dir.norm() == 0) dir = Eigen::Vector3d(-0.5, 1.0, -0.45);
  dir.normalize();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const Surface& s : surfaces) {
    if (s.positions == nullptr) continue;
    const auto& P = *s.positions;
    for (const auto& t : s.triangles)
      for (const auto v : t)
        if (v >= 0 && v < P.cols() && P.col(v).allFinite()) {
          lo = lo.cwiseMin(P.col(v));
          hi = hi.cwiseMax(P.col(v));
        }
  }
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 1.0;
  if ((hi.array() >= lo.array()).all()) {
    centre = 0.5 * (lo + hi);
    radius = 0.5 * (hi - lo).norm();
    if (!(radius > 0) || !std::isfinite(radius)) radius = std::max(1e-6, 1e-6 * centre.norm());
  }
  const double aspect = height > 0 ? static_cast<double>(std::max(width, 1)) / height : 1.0;
  const double half_v = 0.5 * cam.fov_deg * kPi / 180.0;
  const double half_h = std::atan(std::tan(half_v) * aspect);
  const double half = std::min(half_v, half_h);
  const double dist = 1.04 * radius / std::sin(half);
  cam.target = centre;
  cam.eye = centre - dir * dist;
  cam.up = std::abs(dir.z()) > 0.98 ? Eigen::Vector3d(0, 1, 0) : Eigen::Vector3d(0, 0, 1);
  return cam;
}

Image render(std::span<const Surface> surfaces, const Camera& camera) {
  return render(surfaces, camera, RenderOptions{});
}

Image render(std::span<const Surface> surfaces, const Camera& camera,
             const RenderOptions& options) {
  const int width = std::clamp(camera.width, 1, 16384);
  const int height = std::clamp(camera.height, 1, 16384);
  const int ss = std::clamp(options.supersample, 1, 4);
  Frame fb;
  fb.w = width * ss;
  fb.h = height * ss;
  fb.rgb.assign(static_cast<std::size_t>(fb.w) * fb.h * 3, 0.0f);
  fb.inv_z.assign(static_cast<std::size_t>(fb.w) * fb.h, 0.0f);
  fill_background(fb, options.background_gradient);
  const View view = make_view(camera, fb.w, fb.h);
  RasterParams rp;
  rp.edge_half_width = kEdgeHalfWidth * ss;
  // Opaque surfaces first, then the transparent ones in the given order.
  for (int pass = 0; pass < 2; ++pass)
    for (const Surface& s : surfaces) {
      const bool transparent = std::isfinite(s.opacity) && s.opacity < 1.0f;
      if (transparent == (pass == 1)) draw_surface(fb, view, s, rp);
    }
  // Box filter down to the output size.
  Image img;
  img.width = width;
  img.height = height;
  img.rgb.resize(static_cast<std::size_t>(width) * height * 3);
  const float norm = 255.0f / static_cast<float>(ss * ss);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int k = 0; k < 3; ++k) {
        float sum = 0;
        for (int j = 0; j < ss; ++j)
          for (int i = 0; i < ss; ++i)
            sum += fb.rgb[(static_cast<std::size_t>(y * ss + j) * fb.w + (x * ss + i)) * 3 + k];
        img.rgb[(static_cast<std::size_t>(y) * width + x) * 3 + k] =
            static_cast<std::uint8_t>(std::clamp(std::lround(sum * norm), 0L, 255L));
      }
  if (options.colour_bar)
    for (const Surface& s : surfaces)
      if (!s.scalar.empty()) {
        draw_colour_bar(img, colour_map_of(s), s.scalar_name);
        break;
      }
  if (!options.title.empty()) draw_text(img, 12, 10, options.title, {20, 20, 20}, 2);
  return img;
}

}  // namespace tc::viz

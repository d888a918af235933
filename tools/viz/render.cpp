// The software rasterizer: camera set-up, near-plane clipping, z-buffer, per-pixel
// shading, wireframe overlay, supersampling, colour bar.
#include "render.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "draw.hpp"

namespace tc::viz {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Shading: colour = base * (ambient + diffuse * |n.l|) + specular * (n.h)^32 (Blinn-Phong;
// the exponent is applied by five squarings in the rasteriser).
constexpr float kAmbient = 0.28f;
constexpr float kDiffuse = 0.72f;
constexpr float kSpecular = 0.12f;
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
  std::array<Eigen::Vector3f, 256> lut;  // 256 steps of the map, 0..1 RGB
  void build_lut() {
    for (int i = 0; i < 256; ++i) {
      const auto c = diverging ? blue_white_red(i / 255.0) : viridis(i / 255.0);
      lut[static_cast<std::size_t>(i)] = {c[0] / 255.0f, c[1] / 255.0f, c[2] / 255.0f};
    }
  }
  Eigen::Vector3f colour(float t) const {
    if (!std::isfinite(t)) return {kNanGrey, kNanGrey, kNanGrey};
    const int i = static_cast<int>(std::clamp(t, 0.0f, 1.0f) * 255.0f + 0.5f);
    return lut[static_cast<std::size_t>(i)];
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
  m.build_lut();
  return m;
}

/// Shading normals per triangle corner (world space, unit): the area-weighted mean of
/// the normals of the triangles around the corner's node that turn less than the crease
/// angle from this triangle (smooth torus, sharp box edges).
std::vector<std::array<Eigen::Vector3f, 3>> corner_normals(
    const Surface& s, const std::vector<std::uint32_t>& tris,
    const std::vector<Eigen::Vector3d>& area_n) {
  const auto n_nodes = static_cast<std::size_t>(s.positions->cols());
  // Node -> valid triangles (CSR, triangle order).
  std::vector<std::uint32_t> offsets(n_nodes + 1, 0);
  for (const std::uint32_t i : tris)
    for (const auto v : s.triangles[i]) ++offsets[static_cast<std::size_t>(v) + 1];
  for (std::size_t i = 0; i < n_nodes; ++i) offsets[i + 1] += offsets[i];
  std::vector<std::uint32_t> adj(offsets.back());
  std::vector<std::uint32_t> fill(offsets.begin(), offsets.end() - 1);
  for (const std::uint32_t i : tris)
    for (const auto v : s.triangles[i]) adj[fill[static_cast<std::size_t>(v)]++] = i;
  std::vector<std::array<Eigen::Vector3f, 3>> out(s.triangles.size());
  for (const std::uint32_t i : tris) {
    const Eigen::Vector3d fi = area_n[i].normalized();
    for (int k = 0; k < 3; ++k) {
      const auto v = static_cast<std::size_t>(s.triangles[i][static_cast<std::size_t>(k)]);
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (std::uint32_t a = offsets[v]; a < offsets[v + 1]; ++a) {
        const Eigen::Vector3d& nj = area_n[adj[a]];
        if (nj.dot(fi) >= kCreaseCos * nj.norm()) sum += nj;
      }
      const double len = sum.norm();
      out[i][static_cast<std::size_t>(k)] =
          (len > 0 && std::isfinite(len) ? Eigen::Vector3d(sum / len) : fi).cast<float>();
    }
  }
  return out;
}

struct RasterParams {
  Eigen::Vector3f light{0, 0, -1};  // toward the light, camera space, unit
  Eigen::Vector3f half{0, 0, -1};   // Blinn half vector of light and view, unit
  const ColourMap* map = nullptr;
  Eigen::Vector3f base;
  float opacity = 1;
  bool wireframe = false;
  double edge_half_width = 1;  // in supersampled pixels
};

/// A vertex ready for rasterization: camera-space position, camera-space normal, t.
struct CamVertex {
  Eigen::Vector3d p;  // x right, y up, z forward (depth)
  Eigen::Vector3d n;
  double t = 0;  // colour-map coordinate (NaN allowed)
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

/// Rasterizes one triangle (already near-clipped) into the frame. `back`: the eye sees
/// the triangle's back (inside) side, whose normal is flipped for shading. The light is
/// a headlight along the view axis: n.l = -n_z in camera space.
void raster_triangle(Frame& fb, const View& view, const CamVertex& a, const CamVertex& b,
                     const CamVertex& c, const RasterParams& rp, bool back,
                     const bool (&edge_real)[3]) {
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
  // Barycentric weights as affine functions of the pixel centre: w_i = ex_i x + ey_i y + e0_i.
  const double inv_area = 1.0 / area;
  double ex[3], ey[3], e0[3];
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    ex[i] = (sy[j] - sy[k]) * inv_area;
    ey[i] = (sx[k] - sx[j]) * inv_area;
    e0[i] = (sx[j] * sy[k] - sx[k] * sy[j]) * inv_area;
  }
  // Wireframe: screen distance to edge i is w_i * |area| / |edge_i|.
  double edge_scale[3];
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    const double len = std::hypot(sx[k] - sx[j], sy[k] - sy[j]);
    edge_scale[i] = edge_real[i] && len > 0 ? std::abs(area) / len : -1.0;
  }
  // Attributes divided by z (perspective-correct interpolation), in float.
  Eigen::Vector3f nz[3];
  float tz[3];
  for (int i = 0; i < 3; ++i) {
    nz[i] = (v[i]->n * iz[i]).cast<float>();
    tz[i] = static_cast<float>(v[i]->t * iz[i]);
  }
  // Back faces are shaded with the flipped normal.
  const float flip = back ? -1.0f : 1.0f;
  const double reach = rp.edge_half_width + 1.0;
  for (int y = y0; y <= y1; ++y) {
    const double py = y + 0.5;
    // The row's span where every w_i >= 0 (pixel centres x + 0.5); the test inside the
    // loop stays, for rounding at the span's ends.
    int xl = x0, xr = x1;
    for (int i = 0; i < 3 && xl <= xr; ++i) {
      const double c0 = ey[i] * py + e0[i];  // w_i = ex_i * px + c0
      // Clamped to [-1, w] before the conversion: near-degenerate edges give bounds far
      // outside int's range.
      const double lim = static_cast<double>(fb.w);
      if (ex[i] > 0) {
        xl =
            std::max(xl, static_cast<int>(std::clamp(std::ceil(-c0 / ex[i] - 0.5) - 1, -1.0, lim)));
      } else if (ex[i] < 0) {
        xr = std::min(xr,
                      static_cast<int>(std::clamp(std::floor(-c0 / ex[i] - 0.5) + 1, -1.0, lim)));
      } else if (c0 < 0) {
        xr = xl - 1;
      }
    }
    float* dst_row = fb.rgb.data() + static_cast<std::size_t>(y) * fb.w * 3;
    float* z_row = fb.inv_z.data() + static_cast<std::size_t>(y) * fb.w;
    for (int x = xl; x <= xr; ++x) {
      const double px = x + 0.5;
      const double w0 = ex[0] * px + ey[0] * py + e0[0];
      const double w1 = ex[1] * px + ey[1] * py + e0[1];
      const double w2 = ex[2] * px + ey[2] * py + e0[2];
      if (w0 < 0 || w1 < 0 || w2 < 0) continue;
      const float inv_zp = static_cast<float>(w0 * iz[0] + w1 * iz[1] + w2 * iz[2]);
      if (!(inv_zp > z_row[x])) continue;
      const float zp = 1.0f / inv_zp;
      const float f0 = static_cast<float>(w0) * zp, f1 = static_cast<float>(w1) * zp,
                  f2 = static_cast<float>(w2) * zp;
      const Eigen::Vector3f n = f0 * nz[0] + f1 * nz[1] + f2 * nz[2];
      const float nlen = n.norm();
      const float inv_len = nlen > 1e-20f ? flip / nlen : 0.0f;
      const float d = std::clamp(n.dot(rp.light) * inv_len, 0.0f, 1.0f);
      const float h = std::clamp(n.dot(rp.half) * inv_len, 0.0f, 1.0f);
      Eigen::Vector3f albedo = rp.base;
      if (rp.map->active) albedo = rp.map->colour(f0 * tz[0] + f1 * tz[1] + f2 * tz[2]);
      float spec = h * h;  // h^32 by squaring
      spec *= spec;
      spec *= spec;
      spec *= spec;
      spec *= spec;
      Eigen::Vector3f col =
          albedo * (kAmbient + kDiffuse * d) + Eigen::Vector3f::Constant(kSpecular * spec);
      if (rp.wireframe) {
        double dist = std::numeric_limits<double>::infinity();
        if (edge_scale[0] > 0) dist = std::min(dist, w0 * edge_scale[0]);
        if (edge_scale[1] > 0) dist = std::min(dist, w1 * edge_scale[1]);
        if (edge_scale[2] > 0) dist = std::min(dist, w2 * edge_scale[2]);
        if (dist < reach) {
          const float cover = static_cast<float>(std::min(reach - dist, 1.0));
          col *= 1.0f - cover * (1.0f - kEdgeDarken);
        }
      }
      col = col.cwiseMin(1.0f).cwiseMax(0.0f);
      float* dst = dst_row + 3 * x;
      if (rp.opacity >= 1.0f) {
        z_row[x] = inv_zp;
        dst[0] = col.x();
        dst[1] = col.y();
        dst[2] = col.z();
      } else {
        const float o = rp.opacity;
        for (int k = 0; k < 3; ++k) dst[k] = o * col[k] + (1 - o) * dst[k];
      }
    }
  }
}

void draw_surface(Frame& fb, const View& view, const Surface& s, const RasterParams& rp_in) {
  if (s.positions == nullptr || s.triangles.empty()) return;
  const auto& P = *s.positions;
  const auto n_nodes = static_cast<std::int64_t>(P.cols());
  RasterParams rp = rp_in;
  rp.base = s.base_color.allFinite() ? Eigen::Vector3f(s.base_color.cwiseMax(0.0f).cwiseMin(1.0f))
                                     : Eigen::Vector3f(0.8f, 0.8f, 0.8f);
  rp.opacity = std::isfinite(s.opacity) ? std::clamp(s.opacity, 0.0f, 1.0f) : 1.0f;
  rp.wireframe = s.wireframe;
  const bool transparent = rp.opacity < 1.0f;

  // Valid triangles (indices in range, finite, non-zero area) with their area normals and
  // their nearest and farthest depth.
  std::vector<Eigen::Vector3d> area_n(s.triangles.size(), Eigen::Vector3d::Zero());
  std::vector<std::uint32_t> tris;
  std::vector<std::pair<double, std::uint32_t>> order;
  for (std::size_t i = 0; i < s.triangles.size(); ++i) {
    const auto& t = s.triangles[i];
    bool ok = true;
    for (const auto v : t) ok = ok && v >= 0 && v < n_nodes && P.col(v).allFinite();
    if (!ok) continue;
    const Eigen::Vector3d fn = (P.col(t[1]) - P.col(t[0])).cross(P.col(t[2]) - P.col(t[0]));
    const double len = fn.norm();
    if (!(len > 0) || !std::isfinite(len)) continue;
    area_n[i] = fn;
    tris.push_back(static_cast<std::uint32_t>(i));
    double zmin = std::numeric_limits<double>::infinity(), zmax = -zmin;
    for (const auto v : t) {
      const double z = (P.col(v) - view.eye).dot(view.forward);
      zmin = std::min(zmin, z);
      zmax = std::max(zmax, z);
    }
    // Opaque: front to back (hidden samples then fail the depth test before shading);
    // transparent: back to front. Ties keep the triangle order: deterministic.
    order.emplace_back(transparent ? -zmax : zmin, static_cast<std::uint32_t>(i));
  }
  std::sort(order.begin(), order.end());
  const auto normals = corner_normals(s, tris, area_n);
  const ColourMap map = colour_map_of(s);
  rp.map = &map;
  const bool scalars = s.scalar.size() == static_cast<std::size_t>(n_nodes);
  for (const auto& [key, i] : order) {
    const auto& t = s.triangles[i];
    // Transparent surfaces show their front faces only (else a closed surface would be
    // blended twice and look denser than its opacity).
    const bool back = area_n[i].dot(P.col(t[0]) - view.eye) > 0;
    if (transparent && back) continue;
    CamVertex cv[3];
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d d = P.col(t[k]) - view.eye;
      cv[k].p = Eigen::Vector3d(d.dot(view.right), d.dot(view.up), d.dot(view.forward));
      const Eigen::Vector3d wn = normals[i][static_cast<std::size_t>(k)].cast<double>();
      cv[k].n = Eigen::Vector3d(wn.dot(view.right), wn.dot(view.up), wn.dot(view.forward));
      cv[k].t = !map.active ? 0.0
                : scalars   ? map.to_t(s.scalar[static_cast<std::size_t>(t[k])])
                            : std::numeric_limits<double>::quiet_NaN();
    }
    CamVertex poly[4];
    const int k = clip_near(cv, view.znear, poly);
    if (k < 3) continue;
    if (k == 3) {
      const bool e[3] = {true, true, true};
      raster_triangle(fb, view, poly[0], poly[1], poly[2], rp, back, e);
    } else {
      // Fan (0,1,2) and (0,2,3); the diagonal 0-2 and the cut along the near plane are
      // not edges of the original triangle.
      auto on_near = [&](const CamVertex& p) {
        return std::abs(p.p.z() - view.znear) <= 1e-12 * std::max(1.0, view.znear);
      };
      const bool e1[3] = {!(on_near(poly[1]) && on_near(poly[2])), false,
                          !(on_near(poly[0]) && on_near(poly[1]))};
      const bool e2[3] = {!(on_near(poly[2]) && on_near(poly[3])),
                          !(on_near(poly[3]) && on_near(poly[0])), false};
      raster_triangle(fb, view, poly[0], poly[1], poly[2], rp, back, e1);
      raster_triangle(fb, view, poly[0], poly[2], poly[3], rp, back, e2);
    }
  }
}

std::string format_value(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

/// Layout of the colour bar: bar and label sizes, and the panel's total width.
struct BarLayout {
  int bar_w = 0, bar_h = 0, label_w = 0, panel_w = 0;
};

BarLayout bar_layout(int width, int height, const ColourMap& map, const std::string& name) {
  BarLayout b;
  b.bar_w = std::max(10, width / 60);
  b.bar_h = std::max(40, height / 2);
  b.label_w = std::max({text_size(format_value(map.hi)).at(0),
                        text_size(format_value(map.lo)).at(0), text_size("0").at(0)});
  b.panel_w = std::max(b.bar_w + b.label_w + 16, text_size(name).at(0) + 12) + 18;
  return b;
}

void draw_colour_bar(Image& img, const ColourMap& map, const std::string& name) {
  const BarLayout b = bar_layout(img.width, img.height, map, name);
  const int px = img.width - b.panel_w;  // panel's left edge
  const int x0 = px + 10;                // bar's left edge
  const int y0 = (img.height - b.bar_h) / 2;
  const int th = text_size("0").at(1);
  if (px < 0 || y0 - 2 * th - 10 < 0) return;
  // A light panel behind the bar and its labels keeps them readable over the scene.
  for (int y = y0 - 2 * th - 10; y < y0 + b.bar_h + th + 4; ++y)
    for (int x = px; x < img.width - 8; ++x) detail::blend_pixel(img, x, y, {255, 255, 255}, 0.6);
  for (int y = 0; y < b.bar_h; ++y) {
    const double t = 1.0 - static_cast<double>(y) / std::max(1, b.bar_h - 1);
    const auto c = map.diverging ? blue_white_red(t) : viridis(t);
    for (int x = 0; x < b.bar_w; ++x) detail::put_pixel(img, x0 + x, y0 + y, c);
  }
  const std::array<std::uint8_t, 3> black{30, 30, 30};
  detail::draw_rect_outline(img, x0 - 1, y0 - 1, b.bar_w + 2, b.bar_h + 2, black);
  draw_text(img, x0 + b.bar_w + 6, y0 - th / 2, format_value(map.hi), black);
  draw_text(img, x0 + b.bar_w + 6, y0 + b.bar_h - th / 2, format_value(map.lo), black);
  if (map.diverging) draw_text(img, x0 + b.bar_w + 6, y0 + b.bar_h / 2 - th / 2, "0", black);
  if (!name.empty()) draw_text(img, x0, y0 - 2 * th - 4, name, black);
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
  // The supersampled buffers are kept per thread between calls (no page faults per
  // frame); every sample is rewritten, so the output does not depend on the history.
  thread_local Frame fb;
  fb.w = width * ss;
  fb.h = height * ss;
  fb.rgb.resize(static_cast<std::size_t>(fb.w) * fb.h * 3);
  fb.inv_z.assign(static_cast<std::size_t>(fb.w) * fb.h, 0.0f);
  fill_background(fb, options.background_gradient);
  View view = make_view(camera, fb.w, fb.h);
  // With a colour bar, the scene is drawn in the part of the image left of its panel.
  const Surface* bar_surface = nullptr;
  if (options.colour_bar)
    for (const Surface& s : surfaces)
      if (!s.scalar.empty()) {
        bar_surface = &s;
        break;
      }
  if (bar_surface != nullptr) {
    const int panel =
        bar_layout(width, height, colour_map_of(*bar_surface), bar_surface->scalar_name).panel_w;
    if (panel < width / 2) {
      const double keep = static_cast<double>(width - panel) / width;
      view.cx *= keep;
      view.focal *= keep;
    }
  }
  RasterParams rp;
  rp.edge_half_width = kEdgeHalfWidth * ss;
  Eigen::Vector3d light = options.light;
  if (!light.allFinite() || light.norm() == 0) light = Eigen::Vector3d(0, 0, -1);
  light.normalize();
  rp.light = light.cast<float>();
  rp.half = (light + Eigen::Vector3d(0, 0, -1)).normalized().cast<float>();
  if (!rp.half.allFinite()) rp.half = Eigen::Vector3f(0, 0, -1);
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
  std::vector<float> acc(static_cast<std::size_t>(width) * 3);
  for (int y = 0; y < height; ++y) {
    std::fill(acc.begin(), acc.end(), 0.0f);
    for (int j = 0; j < ss; ++j) {
      const float* src = fb.rgb.data() + static_cast<std::size_t>(y * ss + j) * fb.w * 3;
      for (int x = 0; x < width; ++x)
        for (int i = 0; i < ss; ++i)
          for (int k = 0; k < 3; ++k) acc[3 * x + k] += src[3 * (x * ss + i) + k];
    }
    std::uint8_t* dst = img.rgb.data() + static_cast<std::size_t>(y) * width * 3;
    for (std::size_t q = 0; q < acc.size(); ++q)
      dst[q] = static_cast<std::uint8_t>(std::clamp(acc[q] * norm + 0.5f, 0.0f, 255.0f));
  }
  if (bar_surface != nullptr)
    draw_colour_bar(img, colour_map_of(*bar_surface), bar_surface->scalar_name);
  if (!options.title.empty())
    draw_text(img, 12, 10, options.title, {20, 20, 20}, width >= 600 ? 2 : 1);
  return img;
}

}  // namespace tc::viz

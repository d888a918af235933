#include "core/depth/grid_fast_marching.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include "core/depth/boundary_surface.hpp"
#include "core/depth/point_simplex_distance.hpp"

namespace tc {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::uint8_t kFar = 0, kTrial = 1, kAlive = 2;

}  // namespace

template <int D>
GridFastMarching<D>::GridFastMarching(std::vector<std::array<Index, D>> simplices, int resolution)
    : simplices_(std::move(simplices)), n_(std::max(resolution, 2)) {
  std::size_t total = 1;
  for (int i = 0; i < D; ++i) {
    stride_[i] = total;
    total *= static_cast<std::size_t>(n_);
  }
  value_.assign(total, kInf);
  state_.assign(total, kFar);
  lo_.setZero();
  h_.setOnes();
}

template <int D>
void GridFastMarching<D>::seed_band(const Points& positions) {
  using Vec = Eigen::Matrix<double, D, 1>;
  // Band: one cell diagonal. Every grid point whose true distance is within it gets
  // its exact distance (its nearest feature's box, grown by the band, contains it).
  const double band = h_.norm();
  for (const auto& s : simplices_) {
    Vec c[D];
    Vec lo = Vec::Constant(kInf), hi = Vec::Constant(-kInf);
    for (int k = 0; k < D; ++k) {
      c[k] = positions.col(s[k]);
      lo = lo.cwiseMin(c[k]);
      hi = hi.cwiseMax(c[k]);
    }
    int first[D], last[D];
    bool empty = false;
    for (int i = 0; i < D; ++i) {
      // Clamp in double first: a feature far outside the grid must not overflow int.
      const double f = std::ceil((lo[i] - band - lo_[i]) / h_[i]);
      const double l = std::floor((hi[i] + band - lo_[i]) / h_[i]);
      first[i] = static_cast<int>(std::clamp(f, 0.0, static_cast<double>(n_)));
      last[i] = static_cast<int>(std::clamp(l, -1.0, static_cast<double>(n_ - 1)));
      empty = empty || first[i] > last[i];
    }
    if (empty) continue;
    int g[D];
    for (int i = 0; i < D; ++i) g[i] = first[i];
    for (;;) {
      std::size_t p = 0;
      Vec x;
      for (int i = 0; i < D; ++i) {
        p += static_cast<std::size_t>(g[i]) * stride_[i];
        x[i] = lo_[i] + h_[i] * g[i];
      }
      double d2;
      if constexpr (D == 3) {
        d2 = point_triangle_distance(x, c[0], c[1], c[2]).sq_dist;
      } else {
        d2 = point_segment_distance(x, c[0], c[1]).sq_dist;
      }
      value_[p] = std::min(value_[p], std::sqrt(d2));
      int i = 0;
      while (i < D && ++g[i] > last[i]) {
        g[i] = first[i];
        ++i;
      }
      if (i == D) break;
    }
  }
  seeded_ = 0;
  for (std::size_t p = 0; p < value_.size(); ++p) {
    if (value_[p] <= band) {
      state_[p] = kAlive;
      ++seeded_;
    } else {
      value_[p] = kInf;
    }
  }
}

template <int D>
double GridFastMarching<D>::upwind(std::size_t p) const {
  // Smallest alive neighbour per axis.
  double a[D];
  double w[D];
  int k = 0;
  std::size_t rest = p;
  for (int i = D - 1; i >= 0; --i) {
    const auto gi = static_cast<int>(rest / stride_[i]);
    rest %= stride_[i];
    double best = kInf;
    if (gi > 0 && state_[p - stride_[i]] == kAlive) best = value_[p - stride_[i]];
    if (gi < n_ - 1 && state_[p + stride_[i]] == kAlive)
      best = std::min(best, value_[p + stride_[i]]);
    if (best < kInf) {
      a[k] = best;
      w[k] = 1.0 / (h_[i] * h_[i]);
      ++k;
    }
  }
  if (k == 0) return kInf;
  // Sort the axes by neighbour value and add them while the solution stays upwind.
  for (int i = 1; i < k; ++i)
    for (int j = i; j > 0 && a[j] < a[j - 1]; --j) {
      std::swap(a[j], a[j - 1]);
      std::swap(w[j], w[j - 1]);
    }
  double t = a[0] + 1.0 / std::sqrt(w[0]);
  double sa = 0.0, sb = 0.0, sc = 0.0;
  for (int m = 0; m < k; ++m) {
    if (m > 0 && t <= a[m]) break;
    sa += w[m];
    sb += w[m] * a[m];
    sc += w[m] * a[m] * a[m];
    const double disc = sb * sb - sa * (sc - 1.0);
    if (disc < 0.0) break;
    t = (sb + std::sqrt(disc)) / sa;
  }
  return t;
}

template <int D>
void GridFastMarching<D>::march() {
  heap_.clear();
  const auto greater = std::greater<std::pair<double, std::size_t>>{};
  const auto try_update = [&](std::size_t q) {
    if (state_[q] == kAlive) return;
    const double t = upwind(q);
    if (t < value_[q]) {
      value_[q] = t;
      state_[q] = kTrial;
      heap_.emplace_back(t, q);
      std::push_heap(heap_.begin(), heap_.end(), greater);
    }
  };
  const auto neighbours = [&](std::size_t p, auto&& f) {
    std::size_t rest = p;
    for (int i = D - 1; i >= 0; --i) {
      const auto gi = static_cast<int>(rest / stride_[i]);
      rest %= stride_[i];
      if (gi > 0) f(p - stride_[i]);
      if (gi < n_ - 1) f(p + stride_[i]);
    }
  };
  for (std::size_t p = 0; p < value_.size(); ++p)
    if (state_[p] == kAlive) neighbours(p, try_update);
  while (!heap_.empty()) {
    std::pop_heap(heap_.begin(), heap_.end(), greater);
    const auto [t, p] = heap_.back();
    heap_.pop_back();
    if (state_[p] == kAlive || t > value_[p]) continue;
    state_[p] = kAlive;
    neighbours(p, try_update);
  }
}

template <int D>
void GridFastMarching<D>::compute(const Points& positions, std::span<const Index> nodes,
                                  std::span<double> depth) {
  using Vec = Eigen::Matrix<double, D, 1>;
  if (nodes.empty()) return;
  Vec lo = Vec::Constant(kInf), hi = Vec::Constant(-kInf);
  for (const Index v : nodes) {
    lo = lo.cwiseMin(positions.col(v));
    hi = hi.cwiseMax(positions.col(v));
  }
  const double extent = (hi - lo).maxCoeff();
  for (int i = 0; i < D; ++i) {
    // A flat axis still needs a positive spacing.
    const double e = hi[i] - lo[i] > 0.0 ? hi[i] - lo[i] : (extent > 0.0 ? extent : 1.0);
    h_[i] = e / (n_ - 1);
  }
  lo_ = lo;
  std::fill(value_.begin(), value_.end(), kInf);
  std::fill(state_.begin(), state_.end(), kFar);
  seed_band(positions);
  march();

  // Multilinear interpolation in the cell holding each node.
  for (const Index v : nodes) {
    int cell[D];
    double t[D];
    for (int i = 0; i < D; ++i) {
      const double u = (positions(i, v) - lo_[i]) / h_[i];
      cell[i] = std::clamp(static_cast<int>(std::floor(u)), 0, n_ - 2);
      t[i] = std::clamp(u - cell[i], 0.0, 1.0);
    }
    double sum = 0.0;
    for (int corner = 0; corner < (1 << D); ++corner) {
      std::size_t p = 0;
      double weight = 1.0;
      for (int i = 0; i < D; ++i) {
        const int bit = (corner >> i) & 1;
        p += static_cast<std::size_t>(cell[i] + bit) * stride_[i];
        weight *= bit ? t[i] : 1.0 - t[i];
      }
      if (weight > 0.0) sum += weight * value_[p];
    }
    depth[v] = sum;
  }
}

template class GridFastMarching<2>;
template class GridFastMarching<3>;

namespace {

template <int D, class Mesh, class Elements>
Expected<std::vector<double>> grid_one_off(const Mesh& mesh, const Elements& elements,
                                           std::vector<std::array<Index, D>> simplices,
                                           int resolution) {
  const auto n = static_cast<std::size_t>(mesh.positions.cols());
  std::vector<std::uint8_t> used(n, 0);
  for (const auto& e : elements)
    for (const Index v : e) used[v] = 1;
  std::vector<Index> nodes;
  for (std::size_t v = 0; v < n; ++v)
    if (used[v]) {
      if (!mesh.positions.col(static_cast<Index>(v)).allFinite())
        return Error{ErrorCode::kInvalidArgument,
                     "node " + std::to_string(v) + " has a non-finite coordinate"};
      nodes.push_back(static_cast<Index>(v));
    }
  std::vector<double> depth(n, std::numeric_limits<double>::infinity());
  GridFastMarching<D> fm(std::move(simplices), resolution);
  fm.compute(mesh.positions, nodes, depth);
  return depth;
}

}  // namespace

Expected<std::vector<double>> compute_depth_grid_fm(const TetMesh& mesh, const Topology& topo,
                                                    int resolution) {
  return grid_one_off<3>(mesh, mesh.tets, topo.boundary_faces, resolution);
}

Expected<std::vector<double>> compute_depth_grid_fm(const TriMesh2& mesh, const Topology2& topo,
                                                    int resolution) {
  return grid_one_off<2>(mesh, mesh.triangles, topo.boundary_segments, resolution);
}

}  // namespace tc

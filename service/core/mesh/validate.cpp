#include "core/mesh/validate.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>
#include <sstream>
#include <stdexcept>
#include <string>

#include "core/common/cpu_dispatch.hpp"
#include "core/common/parallel_chunks.hpp"
#include "core/common/target_clones.hpp"
#include "core/mesh/geometry.hpp"
#include "core/mesh/spatial_order.hpp"

namespace tc {
namespace {

/// Tets per chunk of the parallel shape check: large enough that a chunk's fixed cost
/// vanishes, small enough that 2 threads share a 300k-tet object evenly.
constexpr std::size_t kShapeChunk = 8192;

/// Tets per block of not_slivers_lanes(): one SIMD lane each.
constexpr int kLanes = 8;

/// Margin on q^2 of not_slivers_lanes(): 1e-9 against a rounding error of at most
/// ~1.2e-11; tets within it of the threshold (q < 1.000005 s at s = 0.01) take the exact
/// path.
constexpr double kSquaredQualityMargin = 1e-9;

}  // namespace

namespace {

/// For kLanes tets at once, whether each surely has quality >= s (s2_margin = s^2 +
/// kSquaredQualityMargin), from one triple product and six squared edge lengths, without
/// the square root and the division of tet_quality(): q = sqrt(2) * 6V / l_rms^3, so
/// q >= s exactly when 6V > 0 and 2 (6V)^2 >= s^2 l_rms^6. Rounding: every edge vector is
/// a difference of two coordinates, correct to one rounding, and each edge is at most
/// sqrt(6) l_rms long, so the triple product 6V is off by at most ~60 eps (sqrt(6)
/// l_rms)^3 ~ 2e-13 l_rms^3 and 2 (6V)^2 / l_rms^6 = q^2 by at most ~1.2e-11 (tet_quality()
/// itself by less). A tet that passes with the margin has a computed tet_quality() >= s
/// as well; the others take tet_quality() itself, so the report does not depend on this
/// test's bits. The lanes are plain loops the compiler vectorises, once for AVX2 and once
/// for the x86-64 baseline (pick_kernel() picks one); one tet at a time the
/// loop was latency-bound (~70 cycles).
[[gnu::always_inline]] inline unsigned not_slivers_lanes(const double* x, const Tet* tets,
                                                         double s2_margin) {
  constexpr double kSmallest = 1e-290, kInfinity = std::numeric_limits<double>::infinity();
  double a[3][kLanes], b[3][kLanes], c[3][kLanes], l2[kLanes] = {};
  for (int l = 0; l < kLanes; ++l) {
    const Tet& t = tets[l];
    const double* p0 = x + 3 * static_cast<std::ptrdiff_t>(t[0]);
    const double* p1 = x + 3 * static_cast<std::ptrdiff_t>(t[1]);
    const double* p2 = x + 3 * static_cast<std::ptrdiff_t>(t[2]);
    const double* p3 = x + 3 * static_cast<std::ptrdiff_t>(t[3]);
    for (int k = 0; k < 3; ++k) {
      a[k][l] = p1[k] - p0[k];
      b[k][l] = p2[k] - p0[k];
      c[k][l] = p3[k] - p0[k];
    }
  }
  for (int k = 0; k < 3; ++k)
    for (int l = 0; l < kLanes; ++l) {
      const double d = b[k][l] - a[k][l], e = c[k][l] - a[k][l], f = c[k][l] - b[k][l];
      l2[l] +=
          (a[k][l] * a[k][l] + b[k][l] * b[k][l]) + (c[k][l] * c[k][l] + d * d) + (e * e + f * f);
    }
  double v6[kLanes], lhs[kLanes], rhs[kLanes];
  for (int l = 0; l < kLanes; ++l) {
    v6[l] = a[0][l] * (b[1][l] * c[2][l] - b[2][l] * c[1][l]) +
            a[1][l] * (b[2][l] * c[0][l] - b[0][l] * c[2][l]) +
            a[2][l] * (b[0][l] * c[1][l] - b[1][l] * c[0][l]);
    // 2 (6V)^2 >= s2 (l2 / 6)^3, without the division: 432 (6V)^2 >= s2 l2^3.
    lhs[l] = 432.0 * (v6[l] * v6[l]);
    rhs[l] = s2_margin * (l2[l] * l2[l] * l2[l]);
  }
  // Only where tet_quality() computes without overflow or underflow: s2 l2^3 finite (so
  // are l2 and 6V) and above 1e-290 (so 6V^2 and l2 are normal numbers, and no product of
  // differences loses more than the rounding above). Beyond, tet_quality() decides: a node
  // at 1e231 m made l2 infinite there (quality 0: degenerate) and l2^3 and 432 (6V)^2 both
  // infinite here (found by the fuzz target `mesh`).
  unsigned good = 0;
  for (int l = 0; l < kLanes; ++l)
    good |= static_cast<unsigned>((v6[l] > 0.0) & (lhs[l] >= rhs[l]) & (rhs[l] >= kSmallest) &
                                  (rhs[l] < kInfinity))
            << l;
  return good;
}

/// The two copies of not_slivers_lanes() (pick_kernel()).
unsigned not_slivers_baseline(const double* x, const Tet* tets, double s2_margin) {
  return not_slivers_lanes(x, tets, s2_margin);
}
TC_AVX2_TARGET unsigned not_slivers_avx2(const double* x, const Tet* tets, double s2_margin) {
  return not_slivers_lanes(x, tets, s2_margin);
}

}  // namespace

namespace {

/// Counts i and keeps it if it is among the `max_listed` smallest indices seen so far
/// (`first` stays sorted): the lists do not depend on the order tets are checked in.
void add_smallest(DefectList& list, Index i, std::size_t max_listed) {
  ++list.count;
  if (list.first.size() == max_listed && (max_listed == 0 || i >= list.first.back())) return;
  list.first.insert(std::upper_bound(list.first.begin(), list.first.end(), i), i);
  if (list.first.size() > max_listed) list.first.pop_back();
}

/// Appends `part` (the defects of another chunk) to `into`, keeping the `max_listed`
/// smallest indices in order.
void merge(DefectList& into, const DefectList& part, std::size_t max_listed) {
  into.count += part.count;
  into.first.insert(into.first.end(), part.first.begin(), part.first.end());
  std::sort(into.first.begin(), into.first.end());
  if (into.first.size() > max_listed) into.first.resize(max_listed);
}

/// Shapes of the tets, in parallel chunks merged in chunk order; tets[k] is the mesh's tet
/// index[k] (`index` empty: k). The report depends neither on the thread count nor on the
/// order of `tets`. `skip` (empty, or one flag per entry of `tets`) leaves tets out.
void check_shapes(const Positions& p, std::span<const Tet> tets, const ValidationOptions& opt,
                  const std::vector<std::uint8_t>& skip, std::span<const Index> index,
                  ValidationReport& report) {
  std::vector<ValidationReport> parts(detail::num_chunks(tets.size(), kShapeChunk));
  const bool fast = !opt.compute_min_quality;
  const double s = std::max(opt.sliver_quality, opt.degenerate_quality);
  const double s2_margin = s * s + kSquaredQualityMargin;
  const auto not_slivers = pick_kernel(not_slivers_baseline, not_slivers_avx2);
  detail::for_chunks(tets.size(), kShapeChunk,
                     [&](std::size_t begin, std::size_t end, std::size_t c) {
                       ValidationReport& part = parts[c];
                       const auto exact = [&](std::size_t k) {
                         const double q = tet_quality(p, tets[k]);
                         const Index ti = index.empty() ? static_cast<Index>(k) : index[k];
                         if (q < part.min_quality) part.min_quality = q;
                         // (A quality that is not finite, of a tet too large or too
                         // small for doubles, is degenerate.)
                         if (!(std::abs(q) >= opt.degenerate_quality) || !std::isfinite(q)) {
                           add_smallest(part.degenerate, ti, opt.max_listed);
                         } else if (q < 0.0) {
                           add_smallest(part.inverted, ti, opt.max_listed);
                         } else if (q < opt.sliver_quality) {
                           add_smallest(part.sliver, ti, opt.max_listed);
                         }
                       };
                       std::size_t k = begin;
                       if (fast && skip.empty()) {
                         for (; k + kLanes <= end; k += kLanes) {
                           const unsigned good = not_slivers(p.data(), tets.data() + k, s2_margin);
                           if (good == (1u << kLanes) - 1) continue;
                           for (int l = 0; l < kLanes; ++l)
                             if (!(good >> l & 1u)) exact(k + static_cast<std::size_t>(l));
                         }
                       }
                       for (; k < end; ++k)
                         if (skip.empty() || !skip[k]) exact(k);
                     });
  for (const ValidationReport& part : parts) {
    report.min_quality = std::min(report.min_quality, part.min_quality);
    merge(report.degenerate, part.degenerate, opt.max_listed);
    merge(report.inverted, part.inverted, opt.max_listed);
    merge(report.sliver, part.sliver, opt.max_listed);
  }
  if (fast) report.min_quality = std::numeric_limits<double>::quiet_NaN();
}

void check_coordinates(const Positions& p, const ValidationOptions& opt, ValidationReport& report) {
  for (Index i = 0; i < p.cols(); ++i)
    if (!p.col(i).allFinite()) report.nonfinite_node.add(i, opt.max_listed);
}

}  // namespace

void detail::check_tet_shapes(const Positions& positions, std::span<const Tet> tets,
                              std::span<const Index> index, const ValidationOptions& options,
                              ValidationReport& report) {
  check_shapes(positions, tets, options, {}, index, report);
}

void append_defects(std::ostringstream& out, const DefectList& list, const char* what) {
  if (list.count == 0) return;
  if (out.tellp() > 0) out << "; ";
  out << list.count << ' ' << what << " (first:";
  for (std::size_t i = 0; i < list.first.size(); ++i) out << (i ? ", " : " ") << list.first[i];
  out << ')';
}

std::string ValidationReport::summary() const {
  std::ostringstream out;
  append_defects(out, index_out_of_range, "tets with a node index out of range");
  append_defects(out, repeated_node, "tets with a repeated node");
  append_defects(out, nonfinite_node, "nodes with non-finite coordinates");
  append_defects(out, degenerate, "degenerate (zero-volume) tets");
  append_defects(out, inverted, "inverted tets");
  append_defects(out, sliver, "sliver tets");
  return out.str();
}

ValidationReport validate_mesh(const TetMesh& mesh, const ValidationOptions& options) {
  ValidationReport report;
  const Index n = mesh.num_nodes();
  check_coordinates(mesh.positions, options, report);
  std::vector<std::uint8_t> skip(mesh.tets.size(), 0);
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const Tet& tet = mesh.tets[t];
    const auto ti = static_cast<Index>(t);
    bool in_range = true;
    for (const Index v : tet) in_range = in_range && v >= 0 && v < n;
    if (!in_range) {
      report.index_out_of_range.add(ti, options.max_listed);
      skip[t] = 1;
      continue;
    }
    bool repeated = false;
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) repeated = repeated || tet[a] == tet[b];
    bool finite = true;
    for (const Index v : tet) finite = finite && mesh.positions.col(v).allFinite();
    if (repeated) report.repeated_node.add(ti, options.max_listed);
    if (repeated || !finite) skip[t] = 1;
  }
  check_shapes(mesh.positions, mesh.tets, options, skip, {}, report);
  return report;
}

ValidationReport validate_positions(const Positions& positions, const std::vector<Tet>& tets,
                                    const ValidationOptions& options) {
  ValidationReport report;
  check_coordinates(positions, options, report);
  if (report.nonfinite_node.count > 0) return report;
  check_shapes(positions, tets, options, {}, {}, report);
  return report;
}

TetCheckOrder make_tet_check_order(const Positions& positions, const std::vector<Tet>& tets) {
  TetCheckOrder order;
  order.index = tets_in_morton_order(positions, tets);
  order.tets.reserve(tets.size());
  for (const Index t : order.index) order.tets.push_back(tets[static_cast<std::size_t>(t)]);
  return order;
}

ValidationReport validate_positions(const Positions& positions, const TetCheckOrder& order,
                                    const ValidationOptions& options) {
  if (order.index.size() != order.tets.size())
    throw std::invalid_argument("validate_positions: " + std::to_string(order.index.size()) +
                                " indices for " + std::to_string(order.tets.size()) + " tets");
  ValidationReport report;
  check_coordinates(positions, options, report);
  if (report.nonfinite_node.count > 0) return report;
  check_shapes(positions, order.tets, options, {}, order.index, report);
  return report;
}

Status require_valid(const ValidationReport& report, const std::string& what) {
  if (report.clean()) return {};
  ValidationReport defects = report;
  defects.sliver = {};
  return Error{ErrorCode::kInvalidMesh, what + ": " + defects.summary()};
}

}  // namespace tc

#include "core/mesh/validate.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/common/parallel_chunks.hpp"
#include "core/mesh/geometry.hpp"

namespace tc {
namespace {

void append(std::ostringstream& out, const DefectList& list, const char* what) {
  if (list.count == 0) return;
  if (out.tellp() > 0) out << "; ";
  out << list.count << ' ' << what << " (first:";
  for (std::size_t i = 0; i < list.first.size(); ++i) out << (i ? ", " : " ") << list.first[i];
  out << ')';
}

/// Tets per chunk of the parallel shape check: large enough that a chunk's fixed cost
/// vanishes, small enough that 2 threads share a 300k-tet object evenly.
constexpr std::size_t kShapeChunk = 8192;

/// Appends `part` (the defects of a later range of indices) to `into`, keeping the
/// first `max_listed` indices in index order.
void merge(DefectList& into, const DefectList& part, std::size_t max_listed) {
  into.count += part.count;
  for (const Index i : part.first)
    if (into.first.size() < max_listed) into.first.push_back(i);
}

/// Shapes of the tets, in parallel chunks merged in index order (the report does not
/// depend on the thread count). `skip` (empty, or one flag per tet) leaves tets out.
void check_shapes(const Positions& p, const std::vector<Tet>& tets, const ValidationOptions& opt,
                  const std::vector<std::uint8_t>& skip, ValidationReport& report) {
  std::vector<ValidationReport> parts(detail::num_chunks(tets.size(), kShapeChunk));
  detail::for_chunks(tets.size(), kShapeChunk,
                     [&](std::size_t begin, std::size_t end, std::size_t c) {
                       ValidationReport& part = parts[c];
                       for (std::size_t t = begin; t < end; ++t) {
                         if (!skip.empty() && skip[t]) continue;
                         const double q = tet_quality(p, tets[t]);
                         const auto ti = static_cast<Index>(t);
                         if (q < part.min_quality) part.min_quality = q;
                         if (std::abs(q) < opt.degenerate_quality) {
                           part.degenerate.add(ti, opt.max_listed);
                         } else if (q < 0.0) {
                           part.inverted.add(ti, opt.max_listed);
                         } else if (q < opt.sliver_quality) {
                           part.sliver.add(ti, opt.max_listed);
                         }
                       }
                     });
  for (const ValidationReport& part : parts) {
    report.min_quality = std::min(report.min_quality, part.min_quality);
    merge(report.degenerate, part.degenerate, opt.max_listed);
    merge(report.inverted, part.inverted, opt.max_listed);
    merge(report.sliver, part.sliver, opt.max_listed);
  }
}

void check_coordinates(const Positions& p, const ValidationOptions& opt, ValidationReport& report) {
  for (Index i = 0; i < p.cols(); ++i)
    if (!p.col(i).allFinite()) report.nonfinite_node.add(i, opt.max_listed);
}

}  // namespace

std::string ValidationReport::summary() const {
  std::ostringstream out;
  append(out, index_out_of_range, "tets with a node index out of range");
  append(out, repeated_node, "tets with a repeated node");
  append(out, nonfinite_node, "nodes with non-finite coordinates");
  append(out, degenerate, "degenerate (zero-volume) tets");
  append(out, inverted, "inverted tets");
  append(out, sliver, "sliver tets");
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
  check_shapes(mesh.positions, mesh.tets, options, skip, report);
  return report;
}

ValidationReport validate_positions(const Positions& positions, const std::vector<Tet>& tets,
                                    const ValidationOptions& options) {
  ValidationReport report;
  check_coordinates(positions, options, report);
  if (report.nonfinite_node.count > 0) return report;
  check_shapes(positions, tets, options, {}, report);
  return report;
}

Status require_valid(const ValidationReport& report, const std::string& what) {
  if (report.clean()) return {};
  ValidationReport defects = report;
  defects.sliver = {};
  return Error{ErrorCode::kInvalidMesh, what + ": " + defects.summary()};
}

}  // namespace tc

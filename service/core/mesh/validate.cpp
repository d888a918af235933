#include "core/mesh/validate.hpp"

#include <cmath>
#include <sstream>

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

void check_shapes(const Positions& p, const std::vector<Tet>& tets, const ValidationOptions& opt,
                  const std::vector<std::uint8_t>& skip, ValidationReport& report) {
  for (std::size_t t = 0; t < tets.size(); ++t) {
    if (!skip.empty() && skip[t]) continue;
    const double q = tet_quality(p, tets[t]);
    const auto ti = static_cast<Index>(t);
    if (q < report.min_quality) report.min_quality = q;
    if (std::abs(q) < opt.degenerate_quality) {
      report.degenerate.add(ti, opt.max_listed);
    } else if (q < 0.0) {
      report.inverted.add(ti, opt.max_listed);
    } else if (q < opt.sliver_quality) {
      report.sliver.add(ti, opt.max_listed);
    }
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

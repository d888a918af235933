// Local measure of interpenetration for the demo's outputs: the depth of every node of
// an object that lies inside another object, as the exact distance field of the
// penetrated object (core distance module, compute_depth_exact) interpolated at the
// node with the barycentric weights of the tet that contains it. Independent of the
// service: it checks the service's work from the outside.
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

#include "core/mesh/tet_mesh.hpp"
#include "core/mesh/topology.hpp"

namespace tc::sim {

class PenetrationProbe {
 public:
  /// (Re)declares object i's tets (after a cut too); n = its node count.
  void set_object(std::size_t i, const std::vector<Tet>& tets, Index n);

  /// Per object, per node: the depth (metres, >= 0) of the node inside any other
  /// object (the largest), 0 outside. `positions[i]` is object i's 3 x n positions.
  std::vector<std::vector<double>> measure(std::span<const Eigen::Matrix3Xd* const> positions);

  /// Object i's self-penetration at positions x (3 x n): the deepest of its nodes inside a
  /// tet of the same object that does not contain it, at its exact distance to that
  /// part's boundary (exact_self_depth(): the faces of the tet's component outside the
  /// node's own neighbourhood), metres; 0 when no node is inside such a tet.
  double self_depth(std::size_t i, const Eigen::Matrix3Xd& x) const;

 private:
  struct Object {
    std::vector<Tet> tets;
    Topology topology;
    std::vector<Index> node_component;  ///< component of each node's first tet (-1: none)
    bool ready = false;
  };
  std::vector<Object> objects_;
};

}  // namespace tc::sim

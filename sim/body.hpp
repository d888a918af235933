// A deformable (or static) tetrahedral body for the demo simulator: lumped-mass
// hyperelastic FEM (stable Neo-Hookean, Smith, de Goes and Kim 2018, without the log
// term). step() integrates with symplectic (semi-implicit) Euler in substeps, contact
// forces held constant over one frame; ImplicitStepper (implicit_step.hpp) integrates
// with backward Euler and the service's contact stiffness blocks (the demo's default).
// docs/DEMO.md explains the model and why it was chosen.
//
//   auto body = tc::sim::Body::create(mesh, {.density = 1000, .young = 2e5});
//   body->step(dt, substeps, gravity, contact);   // contact: 3 x n, newtons
//   body->tear(0.4);                               // removes over-stretched tets
//
// Units: metres, kilograms, seconds, newtons, pascals.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/common/result.hpp"
#include "core/mesh/tet_mesh.hpp"

namespace tc::sim {

struct Material {
  double density = 1000.0;  ///< kg/m^3
  double young = 1e5;       ///< Young's modulus, Pa
  double poisson = 0.3;     ///< [0, 0.49]
  /// Mass-proportional (Rayleigh alpha) damping, 1/s: dv/dt -= damping * v. 0 = none.
  double damping = 0.0;
};

/// Energies of a body (joules).
struct Energy {
  double kinetic = 0.0;
  double elastic = 0.0;
  double gravity = 0.0;  ///< -m g.x summed over nodes (relative to the origin)
  [[nodiscard]] double total() const { return kinetic + elastic + gravity; }
};

class Body {
 public:
  /// Builds a body from a mesh whose positions are its rest shape (and initial state).
  /// kInvalidMesh for a degenerate or inverted tet, kInvalidArgument for bad material.
  static Expected<Body> create(TetMesh mesh, const Material& material);

  /// Pins nodes: they keep their position and have zero velocity.
  void fix_nodes(const std::vector<Index>& nodes);
  /// Nodes whose rest position satisfies |x| >= limit_x or |y| >= limit_y (the border
  /// of a slab centred on the origin), for fix_nodes().
  [[nodiscard]] std::vector<Index> border_nodes(double limit_x, double limit_y) const;

  /// Advances by `dt` in `substeps` equal symplectic Euler steps under gravity and the
  /// per-node external forces `contact` (3 x n, constant over dt; empty = none).
  void step(double dt, int substeps, const Eigen::Vector3d& gravity,
            const Eigen::Matrix3Xd& contact);

  /// Removes every tet whose largest principal stretch exceeds 1 + `strain` (a tear),
  /// then the nodes no tet uses any more (indices are compacted, order kept). Returns
  /// the number of tets removed; the mesh, state and pinned nodes are updated.
  std::size_t tear(double strain);

  /// Largest principal strain (stretch - 1) over the tets.
  [[nodiscard]] double max_strain() const;

  [[nodiscard]] Energy energy(const Eigen::Vector3d& gravity) const;
  /// Kinetic energy removed by the material damping since creation (joules).
  [[nodiscard]] double dissipated() const { return dissipated_; }
  /// Sum of elastic forces on every node (3 x n), for tests.
  [[nodiscard]] Eigen::Matrix3Xd elastic_forces() const;

  /// Rest mesh (positions = rest positions).
  [[nodiscard]] const TetMesh& rest_mesh() const { return rest_; }
  [[nodiscard]] const Eigen::Matrix3Xd& positions() const { return x_; }
  [[nodiscard]] const Eigen::Matrix3Xd& velocities() const { return v_; }
  [[nodiscard]] const Eigen::VectorXd& masses() const { return mass_; }
  [[nodiscard]] const std::vector<bool>& pinned() const { return pinned_; }
  [[nodiscard]] const Material& material() const { return material_; }
  [[nodiscard]] Index node_count() const { return static_cast<Index>(x_.cols()); }
  /// Sets the state (tests, initial velocity).
  void set_velocities(const Eigen::Matrix3Xd& v) { v_ = v; }
  void set_positions(const Eigen::Matrix3Xd& x) { x_ = x; }
  /// Smallest time step explicit integration takes safely for the elastic forces
  /// (CFL-like: shortest tet altitude over the dilatational wave speed), seconds.
  [[nodiscard]] double stable_dt() const;

  // For integrators outside this class (implicit_step.hpp):
  /// Inverse rest edge matrices, one per tet.
  [[nodiscard]] const std::vector<Eigen::Matrix3d>& dm_inv() const { return dm_inv_; }
  /// Rest volumes, one per tet, m^3.
  [[nodiscard]] const std::vector<double>& volumes() const { return volume_; }
  /// Stable Neo-Hookean parameters, Pa (lambda = Lame lambda + mu).
  [[nodiscard]] double mu() const { return mu_; }
  [[nodiscard]] double lambda() const { return lambda_; }
  /// Books energy removed by damping outside step() (joules).
  void add_dissipated(double joules) { dissipated_ += joules; }
  /// Number of tets with det F <= 0 (inverted or flat) in the current state.
  [[nodiscard]] std::size_t inverted_tets() const;

 private:
  Body() = default;
  void precompute();
  void add_elastic_forces(Eigen::Matrix3Xd& f) const;

  TetMesh rest_;
  Material material_;
  double mu_ = 0.0;
  double lambda_ = 0.0;  ///< stable Neo-Hookean lambda (= Lame lambda + mu)
  Eigen::Matrix3Xd x_;
  Eigen::Matrix3Xd v_;
  Eigen::VectorXd mass_;
  std::vector<bool> pinned_;
  std::vector<Eigen::Matrix3d> dm_inv_;  ///< inverse rest edge matrices
  std::vector<double> volume_;           ///< rest volumes
  Eigen::Matrix3Xd force_;               ///< scratch
  double dissipated_ = 0.0;
};

}  // namespace tc::sim

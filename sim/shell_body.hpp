// A deformable triangle-based body for the demo simulator (the paper's Fig. 14: "a
// deformable sphere falls on a tissue"): a closed triangle shell with lumped masses, a
// spring on every edge and an ideal gas inside. The service sees it as a surface object
// (docs/SURFACES.md): forces on its vertices from the tet objects' depth maps, with their
// stiffness blocks. docs/DEMO.md, "Triangle-based bodies", explains the model.
//
//   Psi(x) = sum_edges k_e/2 (|x_b - x_a| - L_e)^2 + p0 (V - V0) - p0 V0 ln(V / V0)
//
// V is the enclosed volume, V0 its rest value. The gas term is an isothermal ideal gas at
// p0 inside a shell surrounded by p0: no net pressure at rest (the rest shape is an
// equilibrium), p0 (V0 / V - 1) of overpressure when squeezed, +inf as V -> 0. The edge
// springs k_e = stretch * A_e / (3 L_e^2) (A_e: area of the edge's two triangles) make
// the membrane stiffness `stretch` (N/m) independent of the mesh to first order: a uniform
// stretch e of an equilateral mesh stores 1/2 stretch e^2 per unit area.
//
// step() is backward Euler with the service's contact forces and 3x3 blocks, the same
// incremental potential as ImplicitStepper (implicit_step.hpp) with Psi above: Newton with
// the springs' Hessians projected to PSD, the gas's rank-one term d2Psi/dV2 (dV)(dV)^T by
// Sherman-Morrison (its p'(V) d2V part, indefinite, is left to the line search), conjugate
// gradients for the linear solves, and a backtracking line search on the potential, which
// is +inf for V <= 0.
//
//   auto shell = tc::sim::ShellBody::create(surface, {.mass = 20, .stretch = 4e3,
//                                                     .pressure = 2e4});
//   shell->step(dt, gravity, forces /*3 x n*/, blocks /*3 x 3n*/);
#pragma once

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "body.hpp"
#include "core/common/result.hpp"
#include "core/mesh/surface_mesh.hpp"
#include "implicit_step.hpp"

namespace tc::sim {

struct ShellMaterial {
  double mass = 1.0;      ///< total mass, kg, lumped to the vertices by area
  double stretch = 1e3;   ///< membrane stiffness (Young's modulus x thickness), N/m
  double pressure = 1e4;  ///< p0 of the gas inside (and of the air outside), Pa
  double damping = 0.0;   ///< mass-proportional damping, 1/s
};

class ShellBody {
 public:
  /// Builds a shell from a closed, consistently oriented surface whose positions are its
  /// rest shape (and initial state); inward-facing triangles are turned outward. Errors
  /// (kInvalidMesh, kInvalidArgument) name what is wrong: an open or non-manifold surface,
  /// degenerate triangles, unused vertices, a bad material value.
  static Expected<ShellBody> create(SurfaceMesh surface, const ShellMaterial& material);

  /// Backward Euler over `dt` under `gravity`, the contact forces `forces` (3 x n, empty =
  /// none) and their blocks `blocks` (3 x 3n, symmetric negative semi-definite df_i/dx_i;
  /// empty = none). `max_newton` >= 1 iterations at most.
  StepReport step(double dt, const Eigen::Vector3d& gravity, const Eigen::Matrix3Xd& forces,
                  const Eigen::Matrix3Xd& blocks, int max_newton = 4);

  [[nodiscard]] Energy energy(const Eigen::Vector3d& gravity) const;
  /// Kinetic energy removed by the damping since creation, J.
  [[nodiscard]] double dissipated() const { return dissipated_; }
  /// Enclosed volume now / at rest, m^3.
  [[nodiscard]] double volume() const { return volume_of(x_); }
  [[nodiscard]] double rest_volume() const { return rest_volume_; }
  /// -dPsi/dx (3 x n): springs and gas, for tests.
  [[nodiscard]] Eigen::Matrix3Xd internal_forces() const;
  /// Psi(x) at the current positions, J.
  [[nodiscard]] double internal_energy() const { return potential_of(x_); }

  /// Rest surface (positions = rest positions, triangles outward).
  [[nodiscard]] const SurfaceMesh& rest_surface() const { return rest_; }
  [[nodiscard]] const Eigen::Matrix3Xd& positions() const { return x_; }
  [[nodiscard]] const Eigen::Matrix3Xd& velocities() const { return v_; }
  [[nodiscard]] const Eigen::VectorXd& masses() const { return mass_; }
  [[nodiscard]] const ShellMaterial& material() const { return material_; }
  [[nodiscard]] Index node_count() const { return static_cast<Index>(x_.cols()); }
  void set_velocities(const Eigen::Matrix3Xd& v) { v_ = v; }
  void set_positions(const Eigen::Matrix3Xd& x) { x_ = x; }

  ShellBody(ShellBody&&) noexcept;
  ShellBody& operator=(ShellBody&&) noexcept;
  ShellBody(const ShellBody&) = delete;
  ShellBody& operator=(const ShellBody&) = delete;
  ~ShellBody();

 private:
  ShellBody();
  [[nodiscard]] double volume_of(const Eigen::Matrix3Xd& x) const;
  [[nodiscard]] double potential_of(const Eigen::Matrix3Xd& x) const;  // Psi, +inf at V <= 0
  /// dPsi/dx (3 x n).
  [[nodiscard]] Eigen::Matrix3Xd potential_gradient(const Eigen::Matrix3Xd& x) const;
  /// dV/dx (3 x n).
  [[nodiscard]] Eigen::Matrix3Xd volume_gradient(const Eigen::Matrix3Xd& x) const;

  SurfaceMesh rest_;
  ShellMaterial material_;
  std::vector<std::array<Index, 2>> edges_;
  std::vector<double> rest_length_;
  std::vector<double> spring_k_;
  double rest_volume_ = 0.0;
  Eigen::Matrix3Xd x_;
  Eigen::Matrix3Xd v_;
  Eigen::VectorXd mass_;
  double dissipated_ = 0.0;
  struct Solver;
  std::unique_ptr<Solver> solver_;
};

}  // namespace tc::sim

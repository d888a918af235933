// Backward Euler for a Body with penalty contact given as forces plus their 3x3 df/dx
// blocks (what tetcollided sends with `pipeline.compute_stiffness: true`). One frame is
// the minimisation of the incremental potential (docs/DEMO.md, "Integration")
//
//   E(x) = 1/(2h^2) |x - x~|_M^2 + a/(2h) |x - xn|_M^2 + Psi_el(x)
//          - fc . (x - xn) - 1/2 (x - xn)^T Kc (x - xn),        x~ = xn + h vn + h^2 g
//
// whose stationary point is backward Euler with mass-proportional damping a and the
// contact force linearised about the frame's positions, fc + Kc (x - xn). Newton's method
// with the stable Neo-Hookean Hessian made positive semi-definite per tet (dP/dF projected,
// neo_hookean.hpp), a backtracking (Armijo) line search on E that also refuses steps
// inverting a tet, and a sparse LDL^T (pattern analysed once per topology) or CG.
// Kc is negative semi-definite, so the system matrix M/h^2 + aM/h + H_psd - Kc is
// positive definite. Pinned nodes keep their positions (their rows are the identity).
//
//   tc::sim::ImplicitStepper stepper;
//   auto report = stepper.step(body, dt, gravity, forces /*3 x n*/, blocks /*3 x 3n*/);
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <vector>

#include "body.hpp"

namespace tc::sim {

/// The terms of the incremental potential above that every body's step shares, its Psi
/// aside: inertia about x~ = xn + h vn + h^2 g, mass-proportional damping a, and the
/// contact force linearised about xn (fc and the symmetrised blocks Kc). ImplicitStepper
/// adds the Neo-Hookean Psi, ShellBody (shell_body.hpp) its springs and gas.
class InertiaAndContact {
 public:
  /// `forces` 3 x n or empty, `blocks` 3 x 3n or empty (as ImplicitStepper::step takes).
  InertiaAndContact(const Eigen::VectorXd& mass, double h, double damping,
                    const Eigen::Vector3d& gravity, const Eigen::Matrix3Xd& xn,
                    const Eigen::Matrix3Xd& vn, const Eigen::Matrix3Xd& forces,
                    const Eigen::Matrix3Xd& blocks);
  /// Node i's terms of E at x.
  [[nodiscard]] double energy(Index i, const Eigen::Matrix3Xd& x) const;
  /// Node i's terms of dE/dx at x.
  [[nodiscard]] Eigen::Vector3d gradient(Index i, const Eigen::Matrix3Xd& x) const;
  /// Node i's diagonal block of d2E/dx2: (m/h^2 + a m/h) I - Kc_i.
  [[nodiscard]] Eigen::Matrix3d hessian(Index i) const;
  /// The damping's work over the step that ends at velocities v, J.
  [[nodiscard]] double damping_work(const Eigen::Matrix3Xd& v) const;

 private:
  const Eigen::VectorXd& mass_;
  double h_;
  double damping_;
  const Eigen::Matrix3Xd& xn_;
  const Eigen::Matrix3Xd& forces_;
  Eigen::Matrix3Xd target_;
  std::vector<Eigen::Matrix3d> kc_;  ///< empty without blocks
};

enum class LinearSolver { kLdlt, kCg };

struct ImplicitOptions {
  int max_newton = 4;  ///< Newton iterations per step, >= 1
  /// Stop when the Newton step changes no node's velocity by more than this, m/s.
  double velocity_tolerance = 1e-4;
  LinearSolver solver = LinearSolver::kLdlt;
  double cg_tolerance = 1e-8;  ///< relative residual of CG
};

struct StepReport {
  int newton_iterations = 0;
  int line_search_halvings = 0;  ///< total over the iterations
  /// Largest velocity change of the last Newton step (after the line search), m/s.
  double last_update = 0.0;
  bool linear_solver_failed = false;
  /// The line search found no decrease of E along a Newton direction (the iterate was
  /// kept; with one Newton step per frame that frame is free flight plus nothing).
  bool line_search_failed = false;
};

/// One Newton update of a backward Euler step: a backtracking (Armijo, 1e-4) line search
/// of `potential` (E, +inf where inadmissible) from x, where E = e, along `dir` with
/// slope g . dir; halves the step down to 1e-6. On a decrease it moves x and e, sets
/// report.last_update (largest velocity change, m/s, for a frame of h seconds) and
/// returns true; otherwise it sets report.line_search_failed and leaves x alone.
template <typename Potential>
bool line_search(const Potential& potential, const Eigen::Matrix3Xd& dir, double slope, double h,
                 Eigen::Matrix3Xd& x, double& e, StepReport& report) {
  double step = 1.0;
  Eigen::Matrix3Xd trial = x + dir;
  double e_trial = potential(trial);
  while (!(e_trial <= e + 1e-4 * step * slope) && step > 1e-6) {
    step *= 0.5;
    ++report.line_search_halvings;
    trial = x + step * dir;
    e_trial = potential(trial);
  }
  if (!(e_trial <= e + 1e-4 * step * slope)) {  // no decrease: keep x
    report.line_search_failed = true;
    return false;
  }
  x = std::move(trial);
  e = e_trial;
  report.last_update = step * dir.colwise().norm().maxCoeff() / h;
  return true;
}

class ImplicitStepper {
 public:
  explicit ImplicitStepper(ImplicitOptions options = {});
  ~ImplicitStepper();
  ImplicitStepper(ImplicitStepper&&) noexcept;
  ImplicitStepper& operator=(ImplicitStepper&&) noexcept;
  ImplicitStepper(const ImplicitStepper&) = delete;
  ImplicitStepper& operator=(const ImplicitStepper&) = delete;

  /// Advances `body` by one backward Euler step of `dt` seconds under `gravity` (m/s^2),
  /// the contact forces `forces` (3 x n, newtons, at the current positions; empty = none)
  /// and their derivatives `blocks` (3 x 3n: the 3x3 df_i/dx_i of node i in columns
  /// 3i..3i+2, N/m, symmetric negative semi-definite; empty = none). The material damping
  /// of the body is applied implicitly and booked in Body::dissipated().
  StepReport step(Body& body, double dt, const Eigen::Vector3d& gravity,
                  const Eigen::Matrix3Xd& forces, const Eigen::Matrix3Xd& blocks);

  [[nodiscard]] const ImplicitOptions& options() const { return options_; }

 private:
  struct Impl;
  ImplicitOptions options_;
  std::unique_ptr<Impl> impl_;
};

/// Elastic Hessian of the whole body (3n x 3n, N/m), exact or with each tet's dP/dF
/// projected to PSD; pinned nodes are not treated specially. For tests and tools.
Eigen::SparseMatrix<double> elastic_hessian(const Body& body, bool psd);

}  // namespace tc::sim

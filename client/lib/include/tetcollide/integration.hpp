// What a simulator's integrator needs to use the service's forces stably
// (docs/INTEGRATORS.md): the per-node weight of the penalty, and the largest contact
// stiffness an explicit (symplectic Euler) step of a given length stays stable with.
//
//   const tc::client::Mesh mesh = tc::client::read_mesh("liver.msh");
//   std::vector<double> mass = ...;  // lumped node masses, kg
//   const double k = tc::client::max_explicit_stiffness(mesh, mass, 1e-3, /*damping=*/0.0);
//   params.stiffness = 0.5 * k;      // keep a margin below the bound
#pragma once

#include <span>
#include <vector>

#include "tetcollide/client.hpp"

namespace tc::client {

/// The point response's weight of every node, metres: half the summed length of the
/// node's edges (the edges of the mesh's tets, or of its triangles for a surface) at the
/// rest positions; 0 for a node no cell uses. A node pushed d metres deep feels
/// `stiffness * weight * d` newtons (docs/RESPONSE.md section 3).
/// @return n values (n = rest_positions.size() / 3).
TC_CLIENT_API std::vector<double> node_weights(const Mesh& mesh);

/// The largest penalty stiffness k (N/m^2) for which a symplectic Euler step of `dt`
/// seconds stays stable for every node of `mesh` with mass `node_masses[i]` (kg, n
/// values) in contact with a much heavier or static object, with contact damping
/// `damping` (N s/m^2): every node with weight w_i > 0 must satisfy
///     k w_i dt^2 / m_i + 2 c w_i dt / m_i < 4,
/// so k < (4 m_i - 2 c w_i dt) / (w_i dt^2). This is the bound itself: choose a stiffness
/// below it (half is a common margin); a node in contact with a light object, or several
/// contacts at once, lowers it. Returns 0 when the damping alone is unstable
/// (c w_i dt / m_i >= 2 for some node).
/// @throws std::invalid_argument when node_masses does not have n positive finite values or
///         dt or damping is not finite and positive (>= 0 for damping).
TC_CLIENT_API double max_explicit_stiffness(const Mesh& mesh, std::span<const double> node_masses,
                                            double dt, double damping = 0.0);

}  // namespace tc::client

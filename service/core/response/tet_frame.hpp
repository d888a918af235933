// The affine frame of one tet: barycentric coordinates of a point and the gradient of a
// field interpolated linearly from the tet's four nodes (paper Section 5.1, with its two
// printed formulas corrected; derivations in docs/RESPONSE.md).
#pragma once

#include <Eigen/Core>
#include <array>

namespace tc {

/// Frames whose scale-free quality |det G| / l_rms^3 is below this are treated as flat:
/// G^-1 would amplify rounding by more than ~1e10.
inline constexpr double kMinFrameQuality = 1e-10;

/// The frame of the tet (x0, x1, x2, x3): origin x3 and axes along the three edges that
/// meet there,
///     G = [x0 - x3, x1 - x3, x2 - x3]   (3 x 3, metres).
/// The paper prints G = [p - x1, p - x2, p - x3], which depends on the query point p and
/// is not a frame of the tet; with that matrix u = G^-1 (p - x4) is not barycentric.
struct TetFrame {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();   ///< x3, metres
  Eigen::Matrix3d inverse = Eigen::Matrix3d::Zero();  ///< G^-1, 1/metres; zero when flat
  double volume6 = 0.0;  ///< -det G = 6 x signed_volume(x0..x3), m^3 (< 0: inverted)
  double quality = 0.0;  ///< det G / l_rms^3, scale-free (0.707 for the regular tet)
  bool regular = false;  ///< |quality| >= kMinFrameQuality and everything finite
};

/// Builds the frame of the tet (x0, x1, x2, x3), positions in metres (any offset: the
/// frame works on differences). Never divides by zero: a flat, collapsed or non-finite
/// tet gives regular == false and a zero inverse.
TetFrame make_tet_frame(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                        const Eigen::Vector3d& x2, const Eigen::Vector3d& x3);

/// Barycentric coordinates (b0, b1, b2, b3) of p, metres: u = G^-1 (p - x3) and
/// b = (u0, u1, u2, 1 - u0 - u1 - u2), so p = sum_k b_k x_k. Inside the tet all b_k >= 0.
/// Requires frame.regular.
Eigen::Vector4d barycentric(const TetFrame& frame, const Eigen::Vector3d& p);

/// Gradient (1/metre times the value unit) of d(x) = sum_k b_k(x) d_k, the linear
/// interpolation of the node values d = (d0, d1, d2, d3):
///     grad d = G^-T (d0 - d3, d1 - d3, d2 - d3).
/// The paper prints G^-1 (u1 - u4, u2 - u4, u3 - u4): it differences the barycentric
/// coordinates instead of the node values, and lacks the transpose. Requires
/// frame.regular.
Eigen::Vector3d linear_gradient(const TetFrame& frame, const Eigen::Vector4d& values);

/// Gradients of the four barycentric coordinates, 1/metre: the rows of G^-1 for b0..b2
/// and minus their sum for b3. Requires frame.regular.
std::array<Eigen::Vector3d, 4> barycentric_gradients(const TetFrame& frame);

}  // namespace tc

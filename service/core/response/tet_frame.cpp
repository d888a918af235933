#include "core/response/tet_frame.hpp"

#include <Eigen/LU>
#include <cmath>

namespace tc {

TetFrame make_tet_frame(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                        const Eigen::Vector3d& x2, const Eigen::Vector3d& x3) {
  TetFrame frame;
  frame.origin = x3;
  Eigen::Matrix3d g;
  g.col(0) = x0 - x3;
  g.col(1) = x1 - x3;
  g.col(2) = x2 - x3;
  if (!g.allFinite()) return frame;
  const double l2 = (g.col(0).squaredNorm() + g.col(1).squaredNorm() + g.col(2).squaredNorm() +
                     (x0 - x1).squaredNorm() + (x0 - x2).squaredNorm() + (x1 - x2).squaredNorm()) /
                    6.0;
  // det [x0 - x3, x1 - x3, x2 - x3] = -det [x1 - x0, x2 - x0, x3 - x0] = -6 V.
  frame.volume6 = -g.determinant();
  if (!(l2 > 0.0) || !std::isfinite(frame.volume6)) return frame;
  frame.quality = frame.volume6 / (l2 * std::sqrt(l2));
  if (!(std::abs(frame.quality) >= kMinFrameQuality)) return frame;
  frame.inverse = g.inverse();
  frame.regular = frame.inverse.allFinite();
  if (!frame.regular) frame.inverse.setZero();
  return frame;
}

Eigen::Vector4d barycentric(const TetFrame& frame, const Eigen::Vector3d& p) {
  const Eigen::Vector3d u = frame.inverse * (p - frame.origin);
  return {u.x(), u.y(), u.z(), 1.0 - u.x() - u.y() - u.z()};
}

Eigen::Vector3d linear_gradient(const TetFrame& frame, const Eigen::Vector4d& values) {
  const Eigen::Vector3d delta(values[0] - values[3], values[1] - values[3], values[2] - values[3]);
  return frame.inverse.transpose() * delta;
}

std::array<Eigen::Vector3d, 4> barycentric_gradients(const TetFrame& frame) {
  std::array<Eigen::Vector3d, 4> grads;
  for (int k = 0; k < 3; ++k) grads[k] = frame.inverse.row(k).transpose();
  grads[3] = -(grads[0] + grads[1] + grads[2]);
  return grads;
}

}  // namespace tc

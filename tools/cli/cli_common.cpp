#include "cli_common.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <numbers>
#include <random>

namespace tc::cli {

int report_error(const std::string& message, int code) {
  std::fprintf(stderr, "tetcollide: error: %s\n", message.c_str());
  return code;
}

int report_error(const Error& error) {
  return report_error(error.message, kExitBadInput);
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  if (values.size() % 2 == 1) return *mid;
  const double upper = *mid;
  const double lower = *std::max_element(values.begin(), mid);
  return 0.5 * (lower + upper);
}

Status turn_about_centre(Positions& x, const std::vector<double>& turn) {
  if (turn.size() != 4) return Error{ErrorCode::kInvalidArgument, "--turn-b takes AX AY AZ DEG"};
  if (!std::all_of(turn.begin(), turn.end(), [](double v) { return std::isfinite(v); }))
    return Error{ErrorCode::kInvalidArgument, "--turn-b: the axis and angle must be finite"};
  const Eigen::Vector3d axis(turn[0], turn[1], turn[2]);
  if (!(axis.norm() > 0.0) || !std::isfinite(axis.norm()))
    return Error{ErrorCode::kInvalidArgument, "--turn-b: the axis must not be zero"};
  if (x.cols() == 0) return {};
  const Eigen::Vector3d centre = 0.5 * (x.rowwise().minCoeff() + x.rowwise().maxCoeff());
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(turn[3] * std::numbers::pi / 180.0, axis.normalized()).toRotationMatrix();
  x = (rotation * (x.colwise() - centre)).colwise() + centre;
  return {};
}

void print_json(const nlohmann::json& value) {
  std::cout << value.dump(2) << '\n';
}

}  // namespace tc::cli

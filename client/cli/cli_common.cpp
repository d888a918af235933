#include "cli_common.hpp"

#include <algorithm>
#include <cstdio>
#include <iostream>

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

void print_json(const nlohmann::json& value) {
  std::cout << value.dump(2) << '\n';
}

}  // namespace tc::cli

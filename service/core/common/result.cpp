#include "core/common/result.hpp"

namespace tc {

std::string_view error_code_name(ErrorCode code) noexcept {
  switch (code) {
    case ErrorCode::kIo:
      return "io";
    case ErrorCode::kParse:
      return "parse";
    case ErrorCode::kUnsupported:
      return "unsupported";
    case ErrorCode::kInvalidMesh:
      return "invalid_mesh";
    case ErrorCode::kInvalidArgument:
      return "invalid_argument";
    case ErrorCode::kUnknownObject:
      return "unknown_object";
    case ErrorCode::kStaleVersion:
      return "stale_version";
    case ErrorCode::kOversized:
      return "oversized";
  }
  return "unknown";
}

}  // namespace tc

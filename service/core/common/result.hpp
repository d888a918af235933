// Errors as values at the boundaries: readers, validation and parsers return
// Expected<T>, a value or an Error with a code and a message naming the file, line,
// object or index at fault.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <variant>

namespace tc {

/// Error categories shared by the core, the daemon and the CLI.
enum class ErrorCode {
  kIo,           ///< file cannot be opened or read
  kParse,        ///< malformed text or binary content
  kUnsupported,  ///< valid input that this build does not handle (format version, ...)
  kInvalidMesh,  ///< indices out of range, repeated nodes, non-finite coordinates, ...
  kInvalidArgument,
  kUnknownObject,
  kStaleVersion,
  kOversized,
};

/// Stable lower-case name of an error code ("io", "parse", ...).
std::string_view error_code_name(ErrorCode code) noexcept;

struct Error {
  ErrorCode code;
  std::string message;
};

/// A value of type T, or an Error. Minimal stand-in for C++23 std::expected.
template <typename T>
class Expected {
 public:
  Expected(T value) : data_(std::move(value)) {}      // NOLINT(google-explicit-constructor)
  Expected(Error error) : data_(std::move(error)) {}  // NOLINT(google-explicit-constructor)

  [[nodiscard]] bool has_value() const noexcept { return data_.index() == 0; }
  explicit operator bool() const noexcept { return has_value(); }

  T& value() & { return std::get<0>(data_); }
  const T& value() const& { return std::get<0>(data_); }
  T&& value() && { return std::get<0>(std::move(data_)); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }

  [[nodiscard]] const Error& error() const { return std::get<1>(data_); }

 private:
  std::variant<T, Error> data_;
};

/// Success-or-error for operations without a value.
class Status {
 public:
  Status() = default;
  Status(Error error) : error_(std::move(error)), ok_(false) {}  // NOLINT
  [[nodiscard]] bool ok() const noexcept { return ok_; }
  explicit operator bool() const noexcept { return ok_; }
  [[nodiscard]] const Error& error() const { return error_; }

 private:
  Error error_{ErrorCode::kIo, {}};
  bool ok_ = true;
};

}  // namespace tc

// Shared by the fuzz targets: a reader that turns the fuzzer's bytes into typed values
// (every read succeeds; past the end it yields zeros), and a check that aborts with a
// message, so a broken invariant is a crash both under libFuzzer and in the regression
// runner (a plain gcc build without libFuzzer).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <type_traits>

/// Aborts (a finding) when `cond` is false.
#define TC_FUZZ_CHECK(cond)                                                              \
  do {                                                                                   \
    if (!(cond)) {                                                                       \
      std::fprintf(stderr, "%s:%d: fuzz check failed: %s\n", __FILE__, __LINE__, #cond); \
      std::abort();                                                                      \
    }                                                                                    \
  } while (false)

namespace tc::fuzz {

class FuzzInput {
 public:
  FuzzInput(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  [[nodiscard]] std::size_t remaining() const { return size_ - pos_; }

  /// The next sizeof(T) bytes as T (little-endian memcpy; missing bytes read as 0).
  template <typename T>
  T take() {
    static_assert(std::is_trivially_copyable_v<T>);
    unsigned char bytes[sizeof(T)] = {};
    const std::size_t n = remaining() < sizeof(T) ? remaining() : sizeof(T);
    if (n > 0) std::memcpy(bytes, data_ + pos_, n);
    pos_ += n;
    T value;
    std::memcpy(&value, bytes, sizeof(T));
    return value;
  }

  /// An integer in [0, bound) (0 when bound is 0), from one or two bytes.
  std::uint32_t small(std::uint32_t bound) {
    if (bound == 0) return 0;
    const std::uint32_t raw = bound <= 256 ? take<std::uint8_t>() : take<std::uint16_t>();
    return raw % bound;
  }

  /// A coordinate-like double: mostly from a small grid (so tets with positive volume
  /// appear often), sometimes one of the hard values (NaN, inf, huge, tiny, -0), and
  /// sometimes 8 raw bytes.
  double coordinate() {
    const std::uint8_t selector = take<std::uint8_t>();
    if (selector < 200) return static_cast<double>(selector % 9) * 0.5 - 1.0;
    if (selector < 240) {
      static constexpr double kSpecial[] = {std::numeric_limits<double>::quiet_NaN(),
                                            std::numeric_limits<double>::infinity(),
                                            -std::numeric_limits<double>::infinity(),
                                            1e6,
                                            -1e6,
                                            1e-6,
                                            1e300,
                                            -0.0,
                                            std::numeric_limits<double>::denorm_min(),
                                            std::numeric_limits<double>::max()};
      return kSpecial[selector % (sizeof(kSpecial) / sizeof(kSpecial[0]))];
    }
    return take<double>();
  }

  /// A string of up to `max` bytes (length byte first).
  std::string text(std::size_t max) {
    std::size_t n = take<std::uint8_t>();
    if (n > max) n = max;
    if (n > remaining()) n = remaining();
    std::string out(reinterpret_cast<const char*>(data_ + pos_), n);
    pos_ += n;
    return out;
  }

  /// Everything not read yet.
  std::string_view rest() {
    std::string_view out(reinterpret_cast<const char*>(data_ + pos_), remaining());
    pos_ = size_;
    return out;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

/// The fuzzer's bytes as text.
inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

}  // namespace tc::fuzz

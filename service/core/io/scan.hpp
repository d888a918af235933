// Internal to core/io: the scanners the mesh readers share. A text scanner that hands
// out lines with their numbers and splits them into tokens, a bounds-checked binary
// reader, number parsing with std::from_chars, and error formatting
// ("file:line: message" for text, "file: byte N: message" for binary).
#pragma once

#include <bit>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>
#include <unordered_map>
#include <vector>

#include "core/common/result.hpp"
#include "core/mesh/tet_mesh.hpp"

namespace tc::io_detail {

/// Reads a whole file into memory (kIo error naming the file when it cannot).
Expected<std::string> read_whole_file(const std::filesystem::path& path);

/// Writes `data` to a file, replacing it (kIo error naming the file when it cannot).
Status write_whole_file(const std::filesystem::path& path, std::string_view data);

/// A token as it may appear in an error message: at most 40 characters, non-printable
/// bytes escaped as \xNN, in single quotes.
std::string quote(std::string_view token);

/// "name:line: message".
Error text_error(ErrorCode code, const std::string& name, std::size_t line,
                 const std::string& message);
/// "name: byte offset: message".
Error binary_error(ErrorCode code, const std::string& name, std::size_t offset,
                   const std::string& message);

inline bool is_blank(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

/// Parses the whole token as a decimal integer (an optional leading '+' is accepted).
inline bool parse_int(std::string_view token, std::int64_t& out) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const char* end = token.data() + token.size();
  const auto [ptr, ec] = std::from_chars(token.data(), end, out);
  return ec == std::errc() && ptr == end;
}

/// Parses the whole token as a floating-point number ("nan" and "inf" parse, and so
/// does a value beyond the double range, as inf; the caller checks finiteness so it can
/// report them precisely). A value below the smallest subnormal reads as 0.
bool parse_double(std::string_view token, double& out);

/// Whitespace-separated tokens of one line.
class Tokens {
 public:
  explicit Tokens(std::string_view line) : rest_(line) {}
  /// The next token, or false at the end of the line.
  bool next(std::string_view& token) {
    std::size_t i = 0;
    while (i < rest_.size() && is_blank(rest_[i])) ++i;
    if (i == rest_.size()) {
      rest_ = {};
      return false;
    }
    std::size_t j = i;
    while (j < rest_.size() && !is_blank(rest_[j])) ++j;
    token = rest_.substr(i, j - i);
    rest_.remove_prefix(j);
    return true;
  }
  /// True when only blanks remain.
  bool at_end() {
    std::size_t i = 0;
    while (i < rest_.size() && is_blank(rest_[i])) ++i;
    rest_.remove_prefix(i);
    return rest_.empty();
  }
  /// Counts (and consumes) the remaining tokens.
  std::size_t count_rest() {
    std::size_t n = 0;
    std::string_view t;
    while (next(t)) ++n;
    return n;
  }

 private:
  std::string_view rest_;
};

/// Number of whitespace-separated tokens in a line.
inline std::size_t count_tokens(std::string_view line) {
  return Tokens(line).count_rest();
}

/// Trims blanks at both ends.
inline std::string_view trim(std::string_view s) {
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

/// Hands out the lines of a buffer with their 1-based numbers. Also used for the text
/// parts of binary files (section headers), where `offset()` locates the data.
class LineScanner {
 public:
  explicit LineScanner(std::string_view data) : data_(data) {}

  /// The next line (without its '\n'; a trailing '\r' is kept and treated as a blank
  /// by Tokens and trim), or false at the end of the data.
  bool next(std::string_view& line) {
    if (pos_ >= data_.size()) return false;
    const std::size_t nl = data_.find('\n', pos_);
    const std::size_t end = nl == std::string_view::npos ? data_.size() : nl;
    line = data_.substr(pos_, end - pos_);
    start_ = pos_;
    pos_ = nl == std::string_view::npos ? data_.size() : nl + 1;
    ++line_;
    return true;
  }
  /// The next line that holds something other than blanks.
  bool next_nonblank(std::string_view& line) {
    while (next(line))
      if (!trim(line).empty()) return true;
    return false;
  }
  /// Number of the line last returned by next() (0 before the first).
  [[nodiscard]] std::size_t line() const { return line_; }
  /// Byte offset where the line last returned by next() starts.
  [[nodiscard]] std::size_t line_start() const { return start_; }
  /// Byte offset of the first unread byte.
  [[nodiscard]] std::size_t offset() const { return pos_; }
  [[nodiscard]] std::size_t remaining() const { return data_.size() - pos_; }
  [[nodiscard]] std::string_view data() const { return data_; }
  /// Moves to a byte offset (after binary data was read from there by hand).
  void seek(std::size_t offset) { pos_ = offset < data_.size() ? offset : data_.size(); }

 private:
  std::string_view data_;
  std::size_t pos_ = 0;
  std::size_t start_ = 0;
  std::size_t line_ = 0;
};

/// Little-endian scalar load from unaligned memory.
template <typename T>
T load_le(const char* p) {
  T value;
  std::memcpy(&value, p, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
    std::memcpy(&value, bytes, sizeof(T));
  }
  return value;
}

/// Node tag -> 0-based node index. Tags up to about twice the node count (plus a
/// margin) live in a dense table, larger ones in a hash map, so memory stays
/// proportional to the number of nodes whatever the tags are.
class TagMap {
 public:
  /// Index of `tag`, or -1.
  [[nodiscard]] Index find(std::int64_t tag) const {
    if (tag >= 0 && static_cast<std::uint64_t>(tag) < dense_.size()) {
      const Index i = dense_[static_cast<std::size_t>(tag)];
      if (i >= 0 || sparse_.empty()) return i;
    }
    if (sparse_.empty()) return -1;
    const auto it = sparse_.find(tag);
    return it == sparse_.end() ? -1 : it->second;
  }
  /// Adds tag -> index; false when the tag is already present.
  bool insert(std::int64_t tag, Index index) {
    if (find(tag) >= 0) return false;
    const std::uint64_t limit = 2 * (static_cast<std::uint64_t>(count_) + 1) + (1u << 20);
    if (tag >= 0 && static_cast<std::uint64_t>(tag) < limit) {
      const auto t = static_cast<std::size_t>(tag);
      if (t >= dense_.size()) {
        std::size_t grown = dense_.size() * 2;
        if (grown < t + 1) grown = t + 1;
        if (grown > limit) grown = static_cast<std::size_t>(limit);
        dense_.resize(grown, -1);
      }
      dense_[t] = index;
    } else {
      sparse_.emplace(tag, index);
    }
    ++count_;
    return true;
  }

 private:
  std::vector<Index> dense_;
  std::unordered_map<std::int64_t, Index> sparse_;
  std::size_t count_ = 0;
};

}  // namespace tc::io_detail

#include "core/io/scan.hpp"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <system_error>

namespace tc::io_detail {

Expected<std::string> read_whole_file(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    return Error{ErrorCode::kIo, path.string() + ": is a directory, expected a mesh file"};
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{ErrorCode::kIo, path.string() + ": cannot open file"};
  std::string data;
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  in.seekg(0, std::ios::beg);
  if (size > 0) {
    data.resize(static_cast<std::size_t>(size));
    in.read(data.data(), size);
    if (in.gcount() != size) return Error{ErrorCode::kIo, path.string() + ": read error"};
  } else {
    // Size unknown (a pipe or a special file): read in chunks.
    char buffer[1 << 16];
    while (in.read(buffer, sizeof(buffer)) || in.gcount() > 0)
      data.append(buffer, static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) return Error{ErrorCode::kIo, path.string() + ": read error"};
  return data;
}

Status write_whole_file(const std::filesystem::path& path, std::string_view data) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) return Error{ErrorCode::kIo, path.string() + ": cannot open file for writing"};
  out.write(data.data(), static_cast<std::streamsize>(data.size()));
  out.flush();
  if (!out) return Error{ErrorCode::kIo, path.string() + ": write error"};
  return {};
}

bool parse_double(std::string_view token, double& out) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const char* end = token.data() + token.size();
  const auto [ptr, ec] = std::from_chars(token.data(), end, out, std::chars_format::general);
  if (ec == std::errc() && ptr == end) return true;
  if (ec != std::errc::result_out_of_range || ptr != end) return false;
  // Well-formed but out of range (1e999, 1e-400): strtod gives inf or 0 as IEEE does.
  char buffer[128];
  if (token.size() >= sizeof(buffer)) return false;
  std::memcpy(buffer, token.data(), token.size());
  buffer[token.size()] = '\0';
  char* stop = nullptr;
  out = std::strtod(buffer, &stop);
  return stop == buffer + token.size();
}

std::string quote(std::string_view token) {
  constexpr std::size_t kMax = 40;
  std::string out = "'";
  for (std::size_t i = 0; i < token.size() && i < kMax; ++i) {
    const auto c = static_cast<unsigned char>(token[i]);
    if (c >= 0x20 && c < 0x7f && c != '\'') {
      out += static_cast<char>(c);
    } else {
      char hex[8];
      std::snprintf(hex, sizeof(hex), "\\x%02x", c);
      out += hex;
    }
  }
  if (token.size() > kMax) out += "...";
  out += "'";
  return out;
}

Error text_error(ErrorCode code, const std::string& name, std::size_t line,
                 const std::string& message) {
  return Error{code, name + ":" + std::to_string(line) + ": " + message};
}

Error binary_error(ErrorCode code, const std::string& name, std::size_t offset,
                   const std::string& message) {
  return Error{code, name + ": byte " + std::to_string(offset) + ": " + message};
}

}  // namespace tc::io_detail

// PNG encoder on zlib (ISO/IEC 15948): signature, IHDR (8-bit RGB), one IDAT, IEND.
// Each row's filter is chosen by the usual minimum-sum-of-absolute-differences
// heuristic, which depends only on the pixels, so the bytes are deterministic.
#include <zlib.h>

#include <cstdio>
#include <cstdlib>
#include <memory>

#include "render.hpp"

namespace tc::viz {
namespace {

void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  out.push_back(static_cast<std::uint8_t>(v >> 24));
  out.push_back(static_cast<std::uint8_t>(v >> 16));
  out.push_back(static_cast<std::uint8_t>(v >> 8));
  out.push_back(static_cast<std::uint8_t>(v));
}

void put_chunk(std::vector<std::uint8_t>& out, const char (&type)[5],
               const std::vector<std::uint8_t>& data) {
  put_u32(out, static_cast<std::uint32_t>(data.size()));
  const std::size_t start = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data.begin(), data.end());
  const uLong crc = crc32(0L, out.data() + start, static_cast<uInt>(out.size() - start));
  put_u32(out, static_cast<std::uint32_t>(crc));
}

int paeth(int a, int b, int c) {
  const int p = a + b - c;
  const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return a;
  return pb <= pc ? b : c;
}

/// Filters one row (bpp = 3) with filter `type` into `out` (without the type byte).
void filter_row(int type, const std::uint8_t* row, const std::uint8_t* prev, std::size_t n,
                std::uint8_t* out) {
  for (std::size_t i = 0; i < n; ++i) {
    const int a = i >= 3 ? row[i - 3] : 0;
    const int b = prev != nullptr ? prev[i] : 0;
    const int c = i >= 3 && prev != nullptr ? prev[i - 3] : 0;
    int pred = 0;
    switch (type) {
      case 1:
        pred = a;
        break;
      case 2:
        pred = b;
        break;
      case 3:
        pred = (a + b) / 2;
        break;
      case 4:
        pred = paeth(a, b, c);
        break;
      default:
        pred = 0;
    }
    out[i] = static_cast<std::uint8_t>(row[i] - pred);
  }
}

}  // namespace

std::vector<std::uint8_t> encode_png(const Image& image) {
  const std::size_t stride = static_cast<std::size_t>(image.width) * 3;
  std::vector<std::uint8_t> raw;
  raw.reserve((stride + 1) * static_cast<std::size_t>(image.height));
  std::vector<std::uint8_t> best(stride), trial(stride);
  for (int y = 0; y < image.height; ++y) {
    const std::uint8_t* row = image.rgb.data() + y * stride;
    const std::uint8_t* prev = y > 0 ? row - stride : nullptr;
    long best_cost = -1;
    int best_type = 0;
    for (int type = 0; type <= 4; ++type) {
      filter_row(type, row, prev, stride, trial.data());
      long cost = 0;
      for (const std::uint8_t v : trial) cost += v < 128 ? v : 256 - v;
      if (best_cost < 0 || cost < best_cost) {
        best_cost = cost;
        best_type = type;
        best.swap(trial);
      }
    }
    raw.push_back(static_cast<std::uint8_t>(best_type));
    raw.insert(raw.end(), best.begin(), best.end());
  }
  uLongf packed_size = compressBound(static_cast<uLong>(raw.size()));
  std::vector<std::uint8_t> packed(packed_size);
  if (compress2(packed.data(), &packed_size, raw.data(), static_cast<uLong>(raw.size()), 6) != Z_OK)
    return {};
  packed.resize(packed_size);

  std::vector<std::uint8_t> out = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::vector<std::uint8_t> ihdr;
  put_u32(ihdr, static_cast<std::uint32_t>(image.width));
  put_u32(ihdr, static_cast<std::uint32_t>(image.height));
  ihdr.insert(ihdr.end(), {8, 2, 0, 0, 0});  // depth 8, RGB, deflate, filter 0, no interlace
  put_chunk(out, "IHDR", ihdr);
  put_chunk(out, "IDAT", packed);
  put_chunk(out, "IEND", {});
  return out;
}

tc::Status write_png(const Image& image, const std::string& path) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgb.size() != static_cast<std::size_t>(image.width) * image.height * 3)
    return Error{ErrorCode::kInvalidArgument,
                 path + ": image is empty or its pixel buffer does not match " +
                     std::to_string(image.width) + " x " + std::to_string(image.height)};
  const std::vector<std::uint8_t> bytes = encode_png(image);
  if (bytes.empty()) return Error{ErrorCode::kIo, path + ": PNG compression failed"};
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!f) return Error{ErrorCode::kIo, path + ": cannot open file for writing"};
  if (std::fwrite(bytes.data(), 1, bytes.size(), f.get()) != bytes.size())
    return Error{ErrorCode::kIo, path + ": write failed"};
  if (std::fclose(f.release()) != 0) return Error{ErrorCode::kIo, path + ": write failed"};
  return {};
}

}  // namespace tc::viz

// Seeded deformations for timing: every coordinate moved by a reproducible offset, so
// that repeated frames of a benchmark or of `tetcollide respond|detect --jitter` time a
// deforming object instead of the same positions again.
#pragma once

#include <cstdint>
#include <random>

#include "core/mesh/tet_mesh.hpp"

namespace tc {

/// `out` = `base` with every coordinate moved by a seeded random offset in [-m, m], the
/// same for a given (frame, object) on every run and machine (mt19937_64 of frame and
/// object, the doubles made from its integers). m = 0 (or not a number) copies base.
inline void jitter_positions(const Positions& base, double m, std::int64_t frame, int object,
                             Positions& out) {
  out = base;
  if (!(m > 0.0)) return;
  std::mt19937_64 rng(0x9e3779b97f4a7c15ULL ^ (static_cast<std::uint64_t>(frame) << 8) ^
                      static_cast<std::uint64_t>(object));
  const auto unit = [&] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };  // [0, 1)
  for (Eigen::Index i = 0; i < out.size(); ++i) out.data()[i] += m * (2.0 * unit() - 1.0);
}

}  // namespace tc

// Mesh file layer: reading a 303,918-tet box (38^3 nodes) from memory in each Gmsh
// format and from TetGen text, and writing it as .vtu. Baselines in the same run: a
// memchr pass over the 2.2 text (a floor: touch every byte once) and the same text
// parsed token by token with std::istringstream (the approach the readers avoid).
#include <benchmark/benchmark.h>

#include <cstring>
#include <filesystem>
#include <sstream>
#include <string>

#include "core/io/mesh_io.hpp"
#include "test_meshes.hpp"

namespace {

const tc::TetMesh& box() {
  static const tc::TetMesh mesh = tc::test::structured_box(37, 37, 37, Eigen::Vector3d(0, 0, 0),
                                                           Eigen::Vector3d(1.3, 0.7, 2.9));
  return mesh;
}

const std::string& text(tc::GmshFormat format) {
  static std::string cache[3];
  std::string& s = cache[static_cast<int>(format)];
  if (s.empty()) s = *tc::format_gmsh(box(), format);
  return s;
}

void read_gmsh_format(benchmark::State& state, tc::GmshFormat format) {
  const std::string& data = text(format);
  for (auto _ : state) {
    auto mesh = tc::read_gmsh_buffer(data, "box.msh");
    if (!mesh || mesh->num_tets() != box().num_tets()) state.SkipWithError("read failed");
    benchmark::DoNotOptimize(mesh);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * data.size()));
  state.counters["tets"] = static_cast<double>(box().num_tets());
  state.counters["MB"] = static_cast<double>(data.size()) / 1e6;
}

void BM_ReadGmsh22Ascii(benchmark::State& state) {
  read_gmsh_format(state, tc::GmshFormat::kMsh22Ascii);
}
void BM_ReadGmsh41Ascii(benchmark::State& state) {
  read_gmsh_format(state, tc::GmshFormat::kMsh41Ascii);
}
void BM_ReadGmsh41Binary(benchmark::State& state) {
  read_gmsh_format(state, tc::GmshFormat::kMsh41Binary);
}

void BM_ReadTetGen(benchmark::State& state) {
  // TetGen text built from the same mesh, 1-based.
  std::string node = std::to_string(box().num_nodes()) + " 3 0 0\n";
  for (tc::Index i = 0; i < box().num_nodes(); ++i) {
    std::ostringstream line;
    line.precision(17);
    line << i + 1 << ' ' << box().positions(0, i) << ' ' << box().positions(1, i) << ' '
         << box().positions(2, i) << '\n';
    node += line.str();
  }
  std::string ele = std::to_string(box().num_tets()) + " 4 0\n";
  for (tc::Index t = 0; t < box().num_tets(); ++t) {
    const tc::Tet& tet = box().tets[static_cast<std::size_t>(t)];
    ele += std::to_string(t + 1) + ' ' + std::to_string(tet[0] + 1) + ' ' +
           std::to_string(tet[1] + 1) + ' ' + std::to_string(tet[2] + 1) + ' ' +
           std::to_string(tet[3] + 1) + '\n';
  }
  for (auto _ : state) {
    auto mesh = tc::read_tetgen_buffers(node, ele, "box");
    if (!mesh || mesh->num_tets() != box().num_tets()) state.SkipWithError("read failed");
    benchmark::DoNotOptimize(mesh);
  }
  state.SetBytesProcessed(
      static_cast<std::int64_t>(state.iterations() * (node.size() + ele.size())));
}

void BM_WriteVtu(benchmark::State& state) {
  const auto path = std::filesystem::temp_directory_path() / "tc_bench_io.vtu";
  for (auto _ : state) {
    if (!tc::write_vtu(path, box()).ok()) state.SkipWithError("write failed");
  }
  state.counters["MB"] = static_cast<double>(std::filesystem::file_size(path)) / 1e6;
  std::filesystem::remove(path);
}

void BM_Baseline_CountLines22(benchmark::State& state) {
  const std::string& data = text(tc::GmshFormat::kMsh22Ascii);
  for (auto _ : state) {
    std::size_t lines = 0;
    const char* p = data.data();
    const char* end = p + data.size();
    while ((p = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)))))
      ++lines, ++p;
    benchmark::DoNotOptimize(lines);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * data.size()));
}

void BM_Baseline_Istream22(benchmark::State& state) {
  // Every token of the 2.2 text through operator>>: numbers as double, the rest skipped.
  const std::string& data = text(tc::GmshFormat::kMsh22Ascii);
  for (auto _ : state) {
    std::istringstream in(data);
    std::string token;
    double sum = 0.0;
    while (in >> token)
      if (token[0] != '$') sum += std::stod(token);
    benchmark::DoNotOptimize(sum);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * data.size()));
}

}  // namespace

BENCHMARK(BM_Baseline_CountLines22)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Baseline_Istream22)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadGmsh22Ascii)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadGmsh41Ascii)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadGmsh41Binary)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadTetGen)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_WriteVtu)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
